//! The reference renders every datasets-gen mesh (hard cases included) and the NASA grids with no
//! NaN or inf pixel, no lost ray, and bit-identically twice.

use algorithms::camera::{Camera, Projection, View};
use algorithms::render::raycast::RayCaster;
use algorithms::render::Renderer;
use algorithms::{Mesh, TransferFunction};

fn check(name: &str, mesh: &Mesh, tf: &TransferFunction, size: u32) {
    let mut rc = RayCaster::new("exact", "reference");
    rc.prepare(mesh, tf).unwrap();
    for (view, proj) in [
        (View::new(0.0, 0.0), Projection::Ortho),
        (View::new(90.0, 0.0), Projection::Ortho),
        (View::new(37.0, 23.0), Projection::Persp),
    ] {
        let cam = Camera::new(&mesh.bbox(), view, proj, size, size);
        let (a, stats) = rc.render_f64(mesh, &cam).unwrap();
        let (b, _) = rc.render_f64(mesh, &cam).unwrap();
        assert!(
            a.iter()
                .flatten()
                .all(|c| c.is_finite() && *c >= 0.0 && *c <= 1.0 + 1e-9),
            "{name} {view:?}: non-finite or out-of-range pixel"
        );
        assert!(
            a.iter()
                .zip(&b)
                .all(|(p, q)| p.map(f64::to_bits) == q.map(f64::to_bits)),
            "{name} {view:?}: not deterministic"
        );
        assert_eq!(stats.lost, 0, "{name} {view:?}: lost rays");
        assert!(stats.steps > 0, "{name} {view:?}: no ray entered the mesh");
    }
}

#[test]
fn every_generated_mesh() {
    // A transfer function with very large tau too, so that opacity saturates.
    let dense = TransferFunction::from_json(
        r#"{"points": [{"s": 0, "rgb": [1, 0.5, 0], "tau": 0}, {"s": 0.5, "rgb": [0, 1, 0], "tau": 1e4},
                       {"s": 1, "rgb": [1, 1, 1], "tau": 1e6}]}"#,
        "dense",
    )
    .unwrap();
    let default = TransferFunction::preset("default").unwrap();
    for g in datasets_gen::generators() {
        let size = if g.name.starts_with("hard-") {
            g.default_tets.min(3000)
        } else {
            3000
        };
        let mesh = datasets_gen::generate(g.name, Some(size), 7)
            .unwrap_or_else(|e| panic!("{}: {e}", g.name));
        check(g.name, &mesh, &default, 24);
        if g.name == "hard-saturate" || g.name == "hard-slivers" {
            check(g.name, &mesh, &dense, 24);
        }
    }
}

#[test]
fn nasa_grids() {
    let tf = TransferFunction::preset("default").unwrap();
    for name in ["blunt", "post", "comb"] {
        let Some(mesh) = tetbench_tests::test_util::nasa(name) else {
            continue;
        };
        check(name, &mesh, &tf, 40);
    }
}
