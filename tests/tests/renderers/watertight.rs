//! The reference is watertight: with a transfer function whose τ is positive
//! everywhere, every pixel whose centre the projected boundary covers is not transparent, and no
//! ray is counted in `missed_rays`. Coverage is decided independently of the ray caster, by the
//! boundary rasteriser of JBU (exact 2-D orientation at the pixel centre, top-left rule).
//!
//! The CI test uses a few Fibonacci views at small sizes; `full_check` (ignored) is the ≥ 100
//! views at 256² check, run in release:
//! `cargo test --release -p tetbench-tests --test renderers watertight -- --ignored --nocapture`
//! (`WATERTIGHT_VIEWS`, `WATERTIGHT_SIZE` override the view count and size, `WATERTIGHT_MESHES`
//! a comma-separated list of mesh names restricts it).

use algorithms::camera::{fibonacci_views, Camera, Projection};
use algorithms::render::jbu::BoundaryRaster;
use algorithms::render::raycast::RayCaster;
use algorithms::render::Renderer;
use algorithms::{Mesh, TransferFunction};

/// τ > 0 over the whole scalar range, so any positive length of mesh along a ray is visible.
fn opaque_everywhere() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"points": [{"s": 0, "rgb": [0.2, 0.4, 1], "tau": 2},
                       {"s": 0.5, "rgb": [1, 1, 1], "tau": 0.5},
                       {"s": 1, "rgb": [1, 0.3, 0.1], "tau": 4}]}"#,
        "opaque-everywhere",
    )
    .unwrap()
}

/// Holes and missed rays of the ray caster with `integrator` (`exact`: the reference; `partial`:
/// `raycast`'s default; both walk the projected way, whose signs are the reference walk's) over `views` Fibonacci views at `size`² (even views orthographic,
/// odd perspective). Returns (covered pixels, transparent covered pixels, missed_rays), and
/// prints the first few holes.
fn holes_with(
    name: &str,
    mesh: &Mesh,
    views: usize,
    size: u32,
    integrator: &str,
) -> (u64, u64, u64) {
    let tf = opaque_everywhere();
    let mut rc = RayCaster::new(integrator, "raycast");
    rc.prepare(mesh, &tf).unwrap();
    let raster = BoundaryRaster::new(mesh);
    let (mut covered, mut transparent, mut missed) = (0u64, 0u64, 0u64);
    for (k, view) in fibonacci_views(views).into_iter().enumerate() {
        let proj = if k % 2 == 0 {
            Projection::Ortho
        } else {
            Projection::Persp
        };
        let cam = Camera::new(&mesh.bbox(), view, proj, size, size);
        let (px, stats) = rc.render_f64(mesh, &cam).unwrap();
        let layers = raster.layers(&cam, 1);
        missed += stats.missed;
        for (p, (c, &n)) in px.iter().zip(&layers.count).enumerate() {
            if n == 0 {
                continue;
            }
            covered += 1;
            if c[3] <= 0.0 {
                if transparent < 5 {
                    eprintln!(
                        "{name}: hole at pixel ({}, {}), view {:.6},{:.6} {}",
                        p % size as usize,
                        p / size as usize,
                        view.azimuth,
                        view.elevation,
                        proj.name()
                    );
                }
                transparent += 1;
            }
        }
    }
    (covered, transparent, missed)
}

fn check(name: &str, mesh: &Mesh, views: usize, size: u32) {
    check_with(name, mesh, views, size, "exact");
}

fn check_with(name: &str, mesh: &Mesh, views: usize, size: u32, integrator: &str) {
    let (covered, transparent, missed) = holes_with(name, mesh, views, size, integrator);
    eprintln!(
        "{name}: {views} views at {size}²: {covered} covered pixels, {transparent} transparent, \
         missed_rays {missed}"
    );
    assert!(covered > 0, "{name}: the boundary covers no pixel");
    assert_eq!(
        transparent, 0,
        "{name}: transparent pixels inside the boundary"
    );
    assert_eq!(missed, 0, "{name}: missed rays");
}

fn hard_cases() -> impl Iterator<Item = (&'static str, Mesh)> {
    datasets_gen::generators()
        .iter()
        .filter(|g| g.name.starts_with("hard-"))
        .map(|g| {
            let mesh = datasets_gen::generate(g.name, Some(g.default_tets.min(3000)), 3)
                .unwrap_or_else(|e| panic!("{}: {e}", g.name));
            (g.name, mesh)
        })
}

#[test]
fn hard_cases_have_no_holes() {
    for (name, mesh) in hard_cases() {
        check(name, &mesh, 16, 40);
    }
}

/// `partial` walks as the reference does (the projected walk), so it is watertight too.
#[test]
fn hard_cases_have_no_holes_with_the_projected_walk() {
    for (name, mesh) in hard_cases() {
        check_with(name, &mesh, 16, 40, "partial");
    }
}

#[test]
fn nasa_grids_have_no_holes() {
    for name in ["blunt", "post", "comb"] {
        if let Some(mesh) = tetbench_tests::test_util::nasa(name) {
            check(name, &mesh, 8, 64);
        }
    }
}

/// The ≥ 100-view check (ignored: minutes in release).
#[test]
#[ignore]
fn full_check() {
    let env = |k: &str, d: usize| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let (views, size) = (
        env("WATERTIGHT_VIEWS", 100),
        env("WATERTIGHT_SIZE", 256) as u32,
    );
    // WATERTIGHT_MESHES=blunt,hard-caps picks meshes by name (default: all).
    let only = std::env::var("WATERTIGHT_MESHES").ok();
    let wanted = |name: &str| {
        only.as_ref()
            .is_none_or(|o| o.split(',').any(|m| m == name))
    };
    for name in ["blunt", "post", "comb"] {
        if !wanted(name) {
            continue;
        }
        if let Some(mesh) = tetbench_tests::test_util::nasa(name) {
            check(name, &mesh, views, size);
        }
    }
    for (name, mesh) in hard_cases() {
        if wanted(name) {
            check(name, &mesh, views, size);
        }
    }
}
