//! cpu-pt on every generated mesh (hard cases included): finite pixels with every sort, and on
//! the meshes where the visibility order is exact (convex, acyclic), agreement with the
//! reference: no cracks along the class 3/4 projections of an axis-aligned grid, no spikes on
//! slivers.

use algorithms::camera::{Camera, Projection, View};
use algorithms::metrics::compare;
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};

fn render(
    name: &str,
    mesh: &Mesh,
    tf: &TransferFunction,
    renderer: &str,
    sort: Option<&str>,
    integ: &str,
    cam: &Camera,
) -> algorithms::image::Image {
    let opts = RenderOptions {
        sort: sort.map(String::from),
        integrator: Some(integ.into()),
        ..Default::default()
    };
    let mut r = render::make(renderer, &opts).unwrap();
    r.prepare(mesh, tf)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let f = r
        .render(mesh, cam)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(
        f.image.non_finite_pixels(),
        0,
        "{name} {renderer} {sort:?} {integ}"
    );
    assert!(
        f.image
            .pixels
            .iter()
            .flatten()
            .all(|&c| (0.0..=1.0001).contains(&c)),
        "{name}: pixel out of range"
    );
    f.image
}

#[test]
fn every_generated_mesh_renders_finite_with_every_sort() {
    let tf = TransferFunction::preset("default").unwrap();
    for g in datasets_gen::generators() {
        let size = if g.name.starts_with("hard-") {
            g.default_tets.min(2000)
        } else {
            2000
        };
        let mesh = datasets_gen::generate(g.name, Some(size), 3).unwrap();
        for (view, proj) in [
            (View::new(0.0, 0.0), Projection::Ortho),
            (View::new(31.0, 17.0), Projection::Persp),
        ] {
            let cam = Camera::new(&mesh.bbox(), view, proj, 24, 24);
            for sort in ["centroid", "centroid-radix", "bucket", "mpvonc"] {
                render(g.name, &mesh, &tf, "cpu-pt", Some(sort), "partial", &cam);
            }
            for integ in ["average", "preint", "exact"] {
                render(g.name, &mesh, &tf, "cpu-pt", Some("mpvonc"), integ, &cam);
            }
        }
    }
}

#[test]
fn degenerate_projections_and_slivers_match_the_reference() {
    let tf = TransferFunction::preset("default").unwrap();
    // hard-axis-aligned at the canonical views: every tet projects to class 3 or 4, edges fall
    // on pixel centres. hard-slivers and hard-caps: thin tets across the mesh.
    for name in [
        "hard-axis-aligned",
        "hard-slivers",
        "hard-caps",
        "hard-needles",
        "hard-negative",
        "cc5",
        "torso",
    ] {
        let mesh = datasets_gen::generate(name, Some(6000), 5).unwrap();
        for view in [
            View::new(0.0, 0.0),
            View::new(90.0, 0.0),
            View::new(0.0, 90.0),
            View::new(33.0, 27.0),
        ] {
            let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 48, 48);
            let reference = render(name, &mesh, &tf, "reference", None, "exact", &cam);
            let pt = render(name, &mesh, &tf, "cpu-pt", Some("mpvonc"), "exact", &cam);
            let e = compare(&pt, &reference).unwrap();
            assert!(
                e.rmse <= 1e-4,
                "{name} {view:?}: rmse {} max_abs {}",
                e.rmse,
                e.max_abs
            );
        }
    }
}

#[test]
fn extinction_beyond_f32_range_stays_finite() {
    // tau = 1e308 overflows f32; every renderer and integrator must still give finite pixels.
    let tf = TransferFunction::from_json(
        r#"{"points": [{"s": 0, "rgb": [1, 1, 1], "tau": 1e308}, {"s": 1, "rgb": [0.5, 1, 0], "tau": 1e308}]}"#,
        "huge.json",
    )
    .unwrap();
    let mesh = datasets_gen::generate("spx", Some(2000), 1).unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(20.0, 10.0),
        Projection::Persp,
        24,
        24,
    );
    for integ in ["average", "partial", "preint", "exact"] {
        render("spx", &mesh, &tf, "cpu-pt", Some("centroid"), integ, &cam);
        render("spx", &mesh, &tf, "raycast", None, integ, &cam);
    }
}
