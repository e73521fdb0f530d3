//! Every registered renderer against `reference`: whatever `render::REGISTRY` holds when the
//! test runs renders a small convex mesh (a `cc6` lattice, which every renderer takes, the
//! lattice-only ones included) with each integrator its entry declares, ortho, from two views,
//! and must stay within the RMSE bound its entry states for that integrator
//! (`RendererInfo::max_rmse`, CONVENTIONS §6). A new renderer is tested the moment it is
//! registered; an entry that declares an integrator without a bound fails. The wrapper pattern
//! (`jbu:`) has no integrators of its own and is tested around every renderer in `jbu`. GPU renderers run
//! on whatever adapter there is (lavapipe in CI); external ones (the VTK peers) when
//! `TETBENCH_VTK_PYTHON` is set, as `vtk_peers` decides. The `pt` and `raycasting` peers of
//! `peers/examples/peers.toml` are registered first, as the command line registers declared
//! peers, and held to their integrator class's bound (docs/peers.md): that needs `make`, `g++`
//! and a `python3` with numpy, as CI has.

use algorithms::camera::{Camera, Projection, View};
use algorithms::metrics::compare;
use algorithms::render::peer::{self, decl, PeerFamily};
use algorithms::render::{self, Family, RenderOptions, RendererInfo, REGISTRY};
use algorithms::{Mesh, TransferFunction};
use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;
use tetbench_tests::test_util::{gpu_available, vtk_enabled};

const SIZE: u32 = 48;

fn mesh() -> Mesh {
    datasets_gen::generate("cc6", Some(3000), 1).unwrap()
}

fn views() -> [View; 2] {
    [View::new(0.0, 0.0), View::new(37.0, 21.0)]
}

/// Registers the drawing peers of `peers/examples/peers.toml` (once per process) and returns
/// their entries: the C++ ones built with `make`, `python3` taken as one that has numpy.
fn example_peers() -> Vec<&'static RendererInfo> {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let make = Command::new("make")
            .arg("-C")
            .arg(root.join("peers/examples/cpp"))
            .output()
            .expect("run make (the C++ example peers need make and g++)");
        assert!(
            make.status.success(),
            "building the C++ example peers failed: {}",
            String::from_utf8_lossy(&make.stderr)
        );
        let has_numpy = |py: &str| {
            Command::new(py)
                .args(["-c", "import numpy"])
                .output()
                .is_ok_and(|o| o.status.success())
        };
        let python = ["python3", "/usr/bin/python3"]
            .into_iter()
            .find(|py| has_numpy(py))
            .expect("the Python example peers need a python3 with numpy");
        let mut specs = decl::load_file(&root.join("peers/examples/peers.toml")).unwrap();
        specs.retain(|s| s.family != PeerFamily::Other);
        for s in &mut specs {
            if s.launch.program == "python3" {
                s.launch.program = python.into();
            }
        }
        peer::register(specs).unwrap();
    });
    peer::registered().iter().map(|r| r.info).collect()
}

/// Whether `r` can run here; `false` says why on stderr (a requirement that is not met fails
/// inside the helpers instead).
fn runs_here(r: &RendererInfo) -> bool {
    if r.family == Family::External {
        return peer::find(r.name).is_some() || vtk_enabled(r.name);
    }
    !r.needs_gpu || gpu_available(r.name)
}

/// The RMSE of `name` with `integrator` against the reference, worst over the views.
fn worst_rmse(name: &str, integrator: &str, mesh: &Mesh, tf: &TransferFunction) -> f64 {
    let opts = RenderOptions {
        integrator: Some(integrator.to_string()),
        ..Default::default()
    };
    let mut r = render::make(name, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
    r.prepare(mesh, tf)
        .unwrap_or_else(|e| panic!("{name} {integrator}: {e}"));
    let mut reference = render::make("reference", &RenderOptions::default()).unwrap();
    reference.prepare(mesh, tf).unwrap();
    let mut worst = 0.0f64;
    for view in views() {
        let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, SIZE, SIZE);
        let img = r
            .render(mesh, &cam)
            .unwrap_or_else(|e| panic!("{name} {integrator}: {e}"))
            .image;
        let want = reference.render(mesh, &cam).unwrap().image;
        let e = compare(&img, &want).unwrap();
        assert!(
            e.rmse.is_finite(),
            "{name} {integrator} {view:?}: non-finite error"
        );
        worst = worst.max(e.rmse);
    }
    worst
}

#[test]
fn every_registered_renderer_matches_the_reference_within_its_bound() {
    let (mesh, tf) = (mesh(), TransferFunction::preset("default").unwrap());
    let mut report = Vec::new();
    let peers = example_peers();
    assert!(peers.len() >= 2, "no example peers registered");
    for r in REGISTRY
        .iter()
        .copied()
        .chain(peers)
        .filter(|r| !render::is_wrapper(r.name))
    {
        for integ in r.integrators {
            let bound = r
                .max_rmse
                .iter()
                .find(|(i, _)| i == integ)
                .unwrap_or_else(|| panic!("{}: no max_rmse for integrator '{integ}'", r.name))
                .1;
            if !runs_here(r) {
                continue;
            }
            let rmse = worst_rmse(r.name, integ, &mesh, &tf);
            eprintln!(
                "{:14} {integ:8} rmse {rmse:.3e} (bound {bound:.1e})",
                r.name
            );
            if rmse > bound {
                report.push(format!("{} {integ}: rmse {rmse:.3e} > {bound:.1e}", r.name));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}
