//! Helpers shared by the workspace's integration tests: the NASA grids when they are there,
//! and whether the GPU and the VTK peers can run (a requirement set by CI that is not met is a
//! failure, not a skip).

use algorithms::io::{self, LoadOptions};
use algorithms::mesh::Mesh;

/// A NASA grid by short name (`blunt`, `post`, `comb`), or `None` with a "skipped" line when its
/// file is not there — a failure instead when `TETBENCH_REQUIRE_DATA=1`.
pub fn nasa(name: &str) -> Option<Mesh> {
    match io::resolve_short_name(name) {
        Some(Ok(_)) => {
            Some(io::load(name, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}")))
        }
        _ => {
            if std::env::var("TETBENCH_REQUIRE_DATA").is_ok_and(|v| v == "1") {
                panic!("{name}: data not found and TETBENCH_REQUIRE_DATA=1");
            }
            eprintln!("{name}: data not found, skipped");
            None
        }
    }
}

/// Whether the VTK peers can run (`TETBENCH_VTK_PYTHON` set); `false` prints that `test` was
/// skipped. Fails when VTK is required (`TETBENCH_REQUIRE_VTK=1`) but not there.
pub fn vtk_enabled(test: &str) -> bool {
    if std::env::var_os("TETBENCH_VTK_PYTHON").is_some_and(|v| !v.is_empty()) {
        return true;
    }
    if std::env::var("TETBENCH_REQUIRE_VTK").is_ok_and(|v| v == "1") {
        panic!("{test}: TETBENCH_VTK_PYTHON is not set and TETBENCH_REQUIRE_VTK=1");
    }
    eprintln!("{test}: TETBENCH_VTK_PYTHON not set, skipped");
    false
}

/// Whether a GPU adapter is there ([`algorithms::gpu::test_gpu`]: prints that `test` was
/// skipped when not, fails under `TETBENCH_REQUIRE_GPU=1`).
pub fn gpu_available(test: &str) -> bool {
    algorithms::gpu::test_gpu(test).is_some()
}
