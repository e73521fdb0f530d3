//! Helpers shared by the integration tests (a module of each test crate that declares it).

use algorithms::io::{self, LoadOptions};
use algorithms::mesh::Mesh;

/// A NASA grid by short name (`blunt`, `post`, `comb`), or `None` with a "skipped" line when its
/// file is not there — a failure instead when `TETBENCH_REQUIRE_DATA=1`.
#[allow(dead_code)]
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
