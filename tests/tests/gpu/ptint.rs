//! `ptint` (two-pass GPU projected tetrahedra) against `cpu-pt` with the same sort and
//! integrator: RMSE ≤ 1e-3 at 128² on `blunt` and on hard cases, ortho and perspective; every
//! degenerate hard case renders finite. Each test needs an adapter:
//! without one it prints SKIPPED, or fails under `TETBENCH_REQUIRE_GPU=1`.

use algorithms::camera::{Camera, Projection, View};
use algorithms::metrics::compare;
use algorithms::render::{self, Frame, RenderOptions};
use algorithms::{Mesh, TransferFunction};

fn frame(
    renderer: &str,
    name: &str,
    mesh: &Mesh,
    tf: &TransferFunction,
    integ: &str,
    cam: &Camera,
) -> Frame {
    let opts = RenderOptions {
        sort: Some("centroid".into()),
        integrator: Some(integ.into()),
        ..Default::default()
    };
    let mut r = render::make(renderer, &opts).unwrap();
    r.prepare(mesh, tf)
        .unwrap_or_else(|e| panic!("{renderer} {}: {e}", name));
    let f = r
        .render(mesh, cam)
        .unwrap_or_else(|e| panic!("{renderer} {}: {e}", name));
    assert_eq!(f.image.non_finite_pixels(), 0, "{renderer} {}", name);
    assert!(
        f.image
            .pixels
            .iter()
            .flatten()
            .all(|&c| (0.0..=1.0001).contains(&c)),
        "{renderer} {}: pixel out of range",
        name
    );
    if renderer == "ptint" {
        assert!(
            r.memory().gpu_bytes > 0 && r.describe().device.contains(" / Rgba"),
            "{}",
            r.describe().device
        );
    }
    f
}

fn counter(f: &Frame, name: &str) -> f64 {
    f.counter(name).unwrap()
}

/// ptint vs cpu-pt; returns the RMSE.
fn check(name: &str, mesh: &Mesh, integ: &str, view: View, proj: Projection) -> f64 {
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(&mesh.bbox(), view, proj, 128, 128);
    let g = frame("ptint", name, mesh, &tf, integ, &cam);
    let c = frame("cpu-pt", name, mesh, &tf, integ, &cam);
    let err = compare(&g.image, &c.image).unwrap();
    eprintln!(
        "{} {integ} ({}, {}) {}: rmse {:.2e} max {:.2e}; drawn gpu {} cpu {}; ptint {:.1} ms",
        name,
        view.azimuth,
        view.elevation,
        proj.name(),
        err.rmse,
        err.max_abs,
        counter(&g, "tets_drawn"),
        counter(&c, "tets_drawn"),
        g.times.total_ms
    );
    assert!(
        err.rmse <= 1e-3,
        "{} {integ} {proj:?}: ptint vs cpu-pt {err:?}",
        name
    );
    // Not a blank pair of images.
    assert!(c.image.pixels.iter().any(|p| p[3] > 0.05), "{}", name);
    assert_eq!(
        counter(&g, "tets_drawn") + counter(&g, "tets_discarded"),
        mesh.num_tets() as f64
    );
    err.rmse
}

#[test]
fn ptint_matches_cpu_pt_on_hard_cases() {
    let Some(_gpu) = algorithms::gpu::test_gpu("ptint_matches_cpu_pt_on_hard_cases") else {
        return;
    };
    // Slivers and needles (ill-conditioned thick vertices), axis-aligned (classes 3 and 4 at
    // view (0, 0)), negative orientation.
    for (name, view) in [
        ("hard-slivers", View::new(30.0, 20.0)),
        ("hard-needles", View::new(-70.0, 35.0)),
        ("hard-axis-aligned", View::new(0.0, 0.0)),
        ("hard-negative", View::new(145.0, -50.0)),
    ] {
        let mesh = datasets_gen::generate(name, Some(12_000), 3).unwrap();
        check(name, &mesh, "partial", view, Projection::Ortho);
        check(
            name,
            &mesh,
            "partial",
            View::new(31.0, 17.0),
            Projection::Persp,
        );
    }
    let name = "hard-slivers";
    let mesh = datasets_gen::generate(name, Some(12_000), 3).unwrap();
    for integ in ["average", "preint"] {
        check(name, &mesh, integ, View::new(30.0, 20.0), Projection::Ortho);
        check(name, &mesh, integ, View::new(31.0, 17.0), Projection::Persp);
    }
}

#[test]
fn ptint_matches_cpu_pt_on_blunt() {
    let Some(_gpu) = algorithms::gpu::test_gpu("ptint_matches_cpu_pt_on_blunt") else {
        return;
    };
    let name = "blunt";
    let Some(mesh) = tetbench_tests::test_util::nasa(name) else {
        return;
    };
    check(
        name,
        &mesh,
        "partial",
        View::new(30.0, 20.0),
        Projection::Ortho,
    );
    check(
        name,
        &mesh,
        "partial",
        View::new(-60.0, 25.0),
        Projection::Persp,
    );
}

/// Every degenerate hard case renders finite and in range (checked in `frame`) with every GPU
/// integrator, in ortho and perspective.
#[test]
fn ptint_renders_degenerate_cases_finite() {
    let Some(_gpu) = algorithms::gpu::test_gpu("ptint_renders_degenerate_cases_finite") else {
        return;
    };
    let tf = TransferFunction::preset("default").unwrap();
    for name in [
        "hard-zero-volume",
        "hard-needles",
        "hard-slivers",
        "hard-duplicates",
        "hard-negative",
        "hard-scalar-range",
        "hard-translated",
        "hard-tiny",
        "hard-constant",
        "hard-saturate",
        "hard-cycle",
    ] {
        let mesh = datasets_gen::generate(name, Some(3000), 1).unwrap();
        for (view, proj) in [
            (View::new(0.0, 0.0), Projection::Ortho),
            (View::new(31.0, 17.0), Projection::Persp),
        ] {
            let cam = Camera::new(&mesh.bbox(), view, proj, 48, 48);
            for integ in ["average", "partial", "preint"] {
                frame("ptint", name, &mesh, &tf, integ, &cam);
            }
        }
    }
}

/// Bad input is a one-line `Error::Input`: an image larger than the adapter's textures, an
/// integrator the GPU does not take.
#[test]
fn ptint_refuses_bad_input_with_a_message() {
    let Some(gpu) = algorithms::gpu::test_gpu("ptint_refuses_bad_input_with_a_message") else {
        return;
    };
    let e = render::make(
        "ptint",
        &RenderOptions {
            sort: None,
            integrator: Some("exact".into()),
            ..Default::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("exact"), "{e}");
    let mesh = datasets_gen::generate("hard-slivers", Some(500), 1).unwrap();
    let tf = TransferFunction::preset("default").unwrap();
    let mut r = render::make("ptint", &RenderOptions::default()).unwrap();
    r.prepare(&mesh, &tf).unwrap();
    let side = gpu.limits.max_texture_dimension_2d + 1;
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(0.0, 0.0),
        Projection::Ortho,
        side,
        4,
    );
    let e = r.render(&mesh, &cam).err().unwrap();
    assert!(matches!(e, algorithms::Error::Input(_)), "{e}");
    assert!(!e.to_string().contains('\n'), "{e}");
}
