//! `cpu-pt --sort xmpvo --integrator exact` equals `reference` on non-convex meshes, where
//! `mpvonc` does not: the per-pixel boundary order across empty space makes
//! the projected-tetrahedra image visibility-exact.
//!
//! The `#[ignore]`d test is the measurement (50 Fibonacci views at 128² on blunt, post,
//! comb, torus, shell, hard-mpvonc, xmpvo beside mpvonc):
//! `cargo test --release -p tetbench-tests --test sorts xmpvo -- --ignored --nocapture`.

use algorithms::camera::{fibonacci_views, Camera, Projection, View};
use algorithms::image::Image;
use algorithms::metrics::compare;
use algorithms::render::jbu::BoundaryRaster;
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};

fn frame(mesh: &Mesh, tf: &TransferFunction, renderer: &str, sort: &str, cam: &Camera) -> Image {
    let opts = RenderOptions {
        sort: (renderer != "reference").then(|| sort.to_string()),
        integrator: Some("exact".into()),
        ..Default::default()
    };
    let mut r = render::make(renderer, &opts).unwrap();
    r.prepare(mesh, tf).unwrap();
    r.render(mesh, cam).unwrap().image
}

/// (RMSE, max_abs) of cpu-pt with `sort` against the reference. Pixels where the reference is
/// exactly transparent although the boundary covers the pixel centre (the reference's holes)
/// are left out of both images; their number is returned too.
fn error(
    mesh: &Mesh,
    tf: &TransferFunction,
    sort: &str,
    cam: &Camera,
    reference: &Image,
    raster: &BoundaryRaster,
) -> (f64, f64, usize) {
    let mut pt = frame(mesh, tf, "cpu-pt", sort, cam);
    let mut rf = reference.clone();
    let cover = raster.layers(cam, 1);
    let mut holes = 0;
    for (k, (a, b)) in pt.pixels.iter_mut().zip(rf.pixels.iter_mut()).enumerate() {
        if cover.count[k] > 0 && *b == [0.0; 4] {
            holes += 1;
            *a = [0.0; 4];
            *b = [0.0; 4];
        }
    }
    let e = compare(&pt, &rf).unwrap();
    (e.rmse, e.max_abs, holes)
}

/// Worst (RMSE, max_abs) of `sorts` over `views` at `size`², and the masked holes.
fn worst(
    mesh: &Mesh,
    tf: &TransferFunction,
    sorts: &[&str],
    views: &[View],
    size: u32,
) -> (Vec<(f64, f64)>, usize) {
    let raster = BoundaryRaster::new(mesh);
    let mut out = vec![(0.0f64, 0.0f64); sorts.len()];
    let mut holes = 0;
    for &view in views {
        let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, size, size);
        let reference = frame(mesh, tf, "reference", "", &cam);
        for (k, sort) in sorts.iter().enumerate() {
            let (rmse, max_abs, h) = error(mesh, tf, sort, &cam, &reference, &raster);
            out[k].0 = out[k].0.max(rmse);
            out[k].1 = out[k].1.max(max_abs);
            if k == 0 {
                holes += h;
            }
        }
    }
    (out, holes)
}

/// The tolerance against the reference order's image.
const RMSE: f64 = 1e-5;
const MAX_ABS: f64 = 2e-3;

#[test]
fn xmpvo_matches_the_reference_where_mpvonc_does_not() {
    let tf = TransferFunction::preset("default").unwrap();
    let mut views = fibonacci_views(5);
    // Along the combs' teeth of hard-mpvonc, where MPVONC's order is wrong.
    views.push(View::new(0.0, 89.0));
    views.push(View::new(0.0, -89.0));
    let mut mpvonc_worst: f64 = 0.0;
    for (name, tets) in [
        ("hard-mpvonc", 24_000),
        ("post-like", 20_000),
        ("torus", 12_000),
        ("shell", 12_000),
    ] {
        let mesh = datasets_gen::generate(name, Some(tets), 7).unwrap();
        let (e, _) = worst(&mesh, &tf, &["xmpvo", "mpvonc"], &views, 48);
        eprintln!(
            "{name}: xmpvo rmse {:.2e} max_abs {:.2e}; mpvonc rmse {:.2e} max_abs {:.2e}",
            e[0].0, e[0].1, e[1].0, e[1].1
        );
        assert!(
            e[0].0 <= RMSE && e[0].1 <= MAX_ABS,
            "{name}: xmpvo rmse {} max_abs {}",
            e[0].0,
            e[0].1
        );
        mpvonc_worst = mpvonc_worst.max(e[1].1);
    }
    // The test can tell a right order from a wrong one.
    assert!(
        mpvonc_worst > 10.0 * MAX_ABS,
        "mpvonc should be visibly wrong on one of these meshes (max_abs {mpvonc_worst})"
    );
}

#[test]
fn xmpvo_matches_the_reference_in_perspective() {
    let tf = TransferFunction::preset("default").unwrap();
    let mesh = datasets_gen::generate("hard-mpvonc", Some(24_000), 3).unwrap();
    for view in [
        View::new(0.0, 89.0),
        View::new(30.0, 60.0),
        View::new(200.0, -70.0),
    ] {
        let cam = Camera::new(&mesh.bbox(), view, Projection::Persp, 48, 48);
        let reference = frame(&mesh, &tf, "reference", "", &cam);
        let pt = frame(&mesh, &tf, "cpu-pt", "xmpvo", &cam);
        let e = compare(&pt, &reference).unwrap();
        eprintln!(
            "persp {view:?}: rmse {:.2e} max_abs {:.2e}",
            e.rmse, e.max_abs
        );
        // The bound. Before cpu-pt took segments from the unsnapped faces its
        // perspective interpolation left ~1e-5 RMSE here (cc6 at these views: 1.1e-5 with
        // either order) and the bound was doubled; now 3-4e-8.
        assert!(
            e.rmse <= RMSE && e.max_abs <= MAX_ABS,
            "{view:?}: rmse {} max_abs {}",
            e.rmse,
            e.max_abs
        );
    }
}

#[test]
fn xmpvo_matches_the_reference_on_the_nasa_grids() {
    let tf = TransferFunction::preset("default").unwrap();
    for name in ["blunt", "post", "comb"] {
        let Some(mesh) = tetbench_tests::test_util::nasa(name) else {
            continue;
        };
        let (e, holes) = worst(&mesh, &tf, &["xmpvo"], &fibonacci_views(3), 64);
        eprintln!(
            "{name}: xmpvo rmse {:.2e} max_abs {:.2e} ({holes} reference holes masked)",
            e[0].0, e[0].1
        );
        assert!(
            e[0].0 <= RMSE && e[0].1 <= MAX_ABS,
            "{name}: xmpvo rmse {} max_abs {}",
            e[0].0,
            e[0].1
        );
    }
}

/// The one miss of the 50-view measurement before the fix: hard-mpvonc at Fibonacci view 36 of
/// 50, 128², where the teeth's faces are 0.28° from edge-on and a grid plane projects 4·10⁻⁴ px
/// from the pixel centres of column 42. cpu-pt interpolated `l` over the snapped fan, 1 % low
/// there (RMSE 3.9e-5, max_abs 1.56e-3 on that column); it now takes each fragment's segment from
/// the unsnapped faces (`algorithms::render::pt::faces`): RMSE 2.9e-8, max_abs 3.6e-7.
#[test]
fn near_edge_on_faces_keep_their_thickness() {
    let tf = TransferFunction::preset("default").unwrap();
    let mesh = datasets_gen::generate("hard-mpvonc", None, 1).unwrap();
    let view = fibonacci_views(50)[36];
    assert!((view.azimuth - 270.28).abs() < 0.01 && (view.elevation + 27.39).abs() < 0.01);
    let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 128, 128);
    let reference = frame(&mesh, &tf, "reference", "", &cam);
    let pt = frame(&mesh, &tf, "cpu-pt", "xmpvo", &cam);
    let e = compare(&pt, &reference).unwrap();
    let column = (0..128)
        .map(|j| {
            let (a, b) = (pt.get(42, j), reference.get(42, j));
            (0..4).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max)
        })
        .fold(0.0f32, f32::max);
    eprintln!(
        "rmse {:.2e} max_abs {:.2e}; column 42 max {column:.2e}",
        e.rmse, e.max_abs
    );
    assert!(e.rmse <= RMSE, "rmse {}", e.rmse);
    assert!(
        e.max_abs <= 2e-4 && column <= 2e-4,
        "max_abs {} column {column}",
        e.max_abs
    );
}

/// The full measurement: 50 Fibonacci views at 128², worst per mesh, xmpvo beside mpvonc.
#[test]
#[ignore]
fn done_when_50_views_at_128() {
    let tf = TransferFunction::preset("default").unwrap();
    let views = fibonacci_views(50);
    let mut meshes: Vec<(String, Mesh)> = ["blunt", "post", "comb"]
        .into_iter()
        .filter_map(|n| tetbench_tests::test_util::nasa(n).map(|m| (n.to_string(), m)))
        .collect();
    for name in ["torus", "shell", "hard-mpvonc"] {
        meshes.push((name.into(), datasets_gen::generate(name, None, 1).unwrap()));
    }
    println!("| mesh | tets | xmpvo RMSE | xmpvo max_abs | mpvonc RMSE | mpvonc max_abs | holes masked |");
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    let mut bad = Vec::new();
    for (name, mesh) in &meshes {
        let (e, holes) = worst(mesh, &tf, &["xmpvo", "mpvonc"], &views, 128);
        println!(
            "| {name} | {} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {holes} |",
            mesh.num_tets(),
            e[0].0,
            e[0].1,
            e[1].0,
            e[1].1
        );
        if !(e[0].0 <= RMSE && e[0].1 <= MAX_ABS) {
            bad.push(name.clone());
        }
    }
    assert!(bad.is_empty(), "over the tolerance: {bad:?}");
}

#[test]
#[ignore]
fn diag_views() {
    let tf = TransferFunction::preset("default").unwrap();
    let name = std::env::var("DIAG_MESH").unwrap_or("post".into());
    let size: u32 = std::env::var("DIAG_SIZE")
        .map(|s| s.parse().unwrap())
        .unwrap_or(128);
    let mesh = tetbench_tests::test_util::nasa(&name)
        .unwrap_or_else(|| datasets_gen::generate(&name, None, 1).unwrap());
    let raster = BoundaryRaster::new(&mesh);
    let only: Option<usize> = std::env::var("DIAG_VIEW").ok().map(|s| s.parse().unwrap());
    for (k, view) in fibonacci_views(50).into_iter().enumerate() {
        if only.is_some_and(|o| o != k) {
            continue;
        }
        let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, size, size);
        let reference = frame(&mesh, &tf, "reference", "", &cam);
        let mut s = algorithms::sort::make("xmpvo").unwrap();
        s.prepare(&mesh).unwrap();
        let mut order = Vec::new();
        let st = s.sort(&mesh, &cam, &mut order).unwrap();
        let (rmse, max_abs, _) = error(&mesh, &tf, "xmpvo", &cam, &reference, &raster);
        if rmse > RMSE || max_abs > MAX_ABS || only.is_some() {
            eprintln!("view {k} {view:?}: rmse {rmse:.2e} max_abs {max_abs:.2e} {st:?}");
            let pt = frame(&mesh, &tf, "cpu-pt", "xmpvo", &cam);
            let mut worst = (0.0f32, 0, 0);
            for j in 0..size {
                for i in 0..size {
                    let a = pt.get(i, j);
                    let b = reference.get(i, j);
                    let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max);
                    if d > worst.0 {
                        worst = (d, i, j);
                    }
                }
            }
            eprintln!("   worst pixel {:?}", worst);
            let mut all: Vec<(f32, u32, u32)> = Vec::new();
            for j in 0..size {
                for i in 0..size {
                    let a = pt.get(i, j);
                    let b = reference.get(i, j);
                    let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max);
                    if d > 2e-4 {
                        all.push((d, i, j));
                    }
                }
            }
            all.sort_by(|x, y| y.0.total_cmp(&x.0));
            eprintln!("   {} pixels over 2e-4", all.len());
            for &(d, i, j) in all.iter().take(12) {
                eprintln!(
                    "   ({i},{j}) d {d:.2e} pt {:?} ref {:?}",
                    pt.get(i, j),
                    reference.get(i, j)
                );
            }
        }
    }
}
