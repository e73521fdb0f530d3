//! `cpu-pt` against `reference`, the fast path against the f64 path, degenerate input, and an
//! ignored throughput run.

use glam::DVec3;

use super::*;
use crate::camera::View;
use crate::metrics::compare;
use crate::render::raycast::RayCaster;
use crate::tf::TfPoint;

/// A box grid of n[0]×n[1]×n[2] cubes, 6 tets per cube (Kuhn, the readers' structured
/// split); scalar from `f`.
pub(crate) fn kuhn_grid(n: [usize; 3], lo: DVec3, hi: DVec3, f: impl Fn(DVec3) -> f64) -> Mesh {
    let dims = n.map(|c| c + 1);
    let mut pos = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let t = DVec3::new(i as f64, j as f64, k as f64)
                    / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                pos.push(lo + (hi - lo) * t);
            }
        }
    }
    let tets = crate::io::split::split_structured("grid", dims, &pos, crate::io::Split::Six)
        .unwrap();
    let s = pos.iter().map(|p| f(*p)).collect();
    Mesh::with_scalars("grid", pos, tets, "s", s).unwrap()
}

fn tf(points: &[(f64, [f64; 3], f64)]) -> TransferFunction {
    TransferFunction {
        name: "test".into(),
        range: Some([0.0, 1.0]),
        points: points
            .iter()
            .map(|&(s, rgb, tau)| TfPoint { s, rgb, tau })
            .collect(),
    }
}

fn smooth_tf() -> TransferFunction {
    tf(&[
        (0.0, [0.1, 0.2, 0.9], 0.5),
        (0.4, [0.2, 0.9, 0.3], 4.0),
        (0.7, [1.0, 0.6, 0.1], 1.0),
        (1.0, [1.0, 1.0, 1.0], 6.0),
    ])
}

fn smooth_grid() -> Mesh {
    // 12×10×11 cubes = 7920 tets; a smooth field spanning [0, 1].
    kuhn_grid(
        [12, 10, 11],
        DVec3::new(-1.0, -0.8, -0.9),
        DVec3::new(1.2, 0.9, 1.0),
        |p| 0.5 + 0.3 * (2.0 * p.x).sin() * (1.5 * p.y).cos() + 0.2 * p.z,
    )
}

fn reference(mesh: &Mesh, tf: &TransferFunction, cam: &Camera) -> Image {
    let mut rc = RayCaster::new("exact", "reference");
    rc.prepare(mesh, tf).unwrap();
    rc.render(mesh, cam).unwrap().image
}

fn pt(mesh: &Mesh, tf: &TransferFunction, cam: &Camera, integ: &str) -> Frame {
    pt_sorted(mesh, tf, cam, integ, false)
}

fn pt_sorted(
    mesh: &Mesh,
    tf: &TransferFunction,
    cam: &Camera,
    integ: &str,
    topological: bool,
) -> Frame {
    let sort = if topological { "mpvonc" } else { "centroid" };
    let mut r = CpuPt::new(sort, integ).unwrap();
    r.prepare(mesh, tf).unwrap();
    let f = r.render(mesh, cam).unwrap();
    assert_eq!(f.image.non_finite_pixels(), 0);
    f
}

const VIEWS: [(f64, f64); 3] = [(30.0, 20.0), (-70.0, 35.0), (145.0, -50.0)];

/// `exact` against `reference` with the centroid order and with MPVONC's order (exact on
/// this convex mesh); both within 1e-4 RMSE on this grid and these views.
fn exact_against_reference(proj: Projection) {
    let mesh = smooth_grid();
    let tf = smooth_tf();
    for (a, e) in VIEWS {
        let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, 96, 80);
        let r = reference(&mesh, &tf, &cam);
        for topo in [false, true] {
            let f = pt_sorted(&mesh, &tf, &cam, "exact", topo);
            let err = compare(&f.image, &r).unwrap();
            let c = |n: &str| f.counter(n).unwrap();
            eprintln!(
                "{} view ({a}, {e}) {}: rmse {:.3e} max {:.3e} cycles {}",
                proj.name(),
                if topo { "mpvonc" } else { "centroid" },
                err.rmse,
                err.max_abs,
                c("sort_cycles")
            );
            assert!(err.rmse <= 1e-4, "view ({a}, {e}): {err:?}");
            assert_eq!(
                c("tets_drawn") + c("tets_discarded"),
                mesh.num_tets() as f64
            );
            assert!(c("fragments") > 0.0);
            if topo {
                assert_eq!(c("sort_cycles"), 0.0);
                assert!(err.max_abs < 1e-4, "view ({a}, {e}): {err:?}");
            }
        }
    }
}

#[test]
fn exact_matches_reference_in_ortho() {
    exact_against_reference(Projection::Ortho);
}

#[test]
fn exact_matches_reference_in_perspective() {
    exact_against_reference(Projection::Persp);
}

/// RMSE of every integrator against `reference`, ortho and persp (run with --nocapture to
/// see the figures).
#[test]
fn integrators_against_reference() {
    let mesh = smooth_grid();
    let tf = smooth_tf();
    for proj in [Projection::Ortho, Projection::Persp] {
        let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), proj, 96, 80);
        let r = reference(&mesh, &tf, &cam);
        for integ in INTEGRATORS {
            let err = compare(&pt_sorted(&mesh, &tf, &cam, integ, true).image, &r).unwrap();
            eprintln!(
                "{} {integ}: rmse {:.3e} max {:.3e}",
                proj.name(),
                err.rmse,
                err.max_abs
            );
            // Loose bounds that still catch a broken integrator or interpolation.
            assert!(err.rmse < 2e-2, "{integ} {proj:?}: {err:?}");
        }
    }
}

/// The f32 fast paths (`average`, `partial`, `preint`) against the f64 integrators behind
/// `dyn Integrator`, same mesh, views and order: RMSE ≤ 1e-5 and max ≤ 2e-4 per image
/// (measured: RMSE ≤ 5e-7, max ≤ 4e-5; the TF table is exact but within 1/4095 of the s
/// range of a control point); and the same counts of drawn tets and fragments, also on 9×7
/// pixels, where most tets have no centre in their box (the fast path's project stage
/// classifies those without their hull points), and on 300×260, where tets of ~20 pixels
/// cross the tiles' edges and leave a few centres in a tile (whose test for a few-centre box
/// must not take them for small tets).
#[test]
fn fast_path_matches_f64_path() {
    let mesh = smooth_grid();
    let tf = smooth_tf();
    // (At 9×7 pixels most tets have no pixel centre in their box.)
    let sizes = [(96, 80), (9, 7), (300, 260)];
    for (proj, (w, h)) in [Projection::Ortho, Projection::Persp]
        .into_iter()
        .flat_map(|p| sizes.map(|s| (p, s)))
    {
        for (a, e) in VIEWS {
            let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, w, h);
            for integ in ["average", "partial", "preint"] {
                let img = |fast: bool| {
                    let mut r = CpuPt::new("centroid", integ).unwrap();
                    r.set_fast_path(fast);
                    r.prepare(&mesh, &tf).unwrap();
                    assert_eq!(r.state.as_ref().unwrap().shading.f32().is_some(), fast);
                    let frame = r.render(&mesh, &cam).unwrap();
                    let count = |name: &str| frame.counter(name).unwrap();
                    let counts = ["tets_drawn", "tets_discarded", "fragments"].map(count);
                    assert!(counts[0] > 0.0);
                    (frame.image, counts)
                };
                let ((f, fc), (d, dc)) = (img(true), img(false));
                assert_eq!(fc, dc, "{integ}: drawn, discarded, fragments");
                let err = compare(&f, &d).unwrap();
                eprintln!(
                    "{} ({a}, {e}) {integ}: fast vs f64 rmse {:.3e} max {:.3e}",
                    proj.name(),
                    err.rmse,
                    err.max_abs
                );
                // (The 9×7 images are for the counts: their segments, each through a large part
                // of the grid, are long enough for the f32 integrators to differ by ~2e-4.)
                if w * h >= 100 {
                    assert!(err.rmse <= 1e-5 && err.max_abs <= 2e-4, "{integ}: {err:?}");
                }
                assert!(f.pixels.iter().any(|p| p[3] > 0.1));
            }
        }
    }
}

/// An axis-aligned grid seen along −z (view (0, 0)) with sizes such that the grid lines fall
/// on pixel centres (x) or pixel boundaries (y) and the other way round: every tet projects to
/// class 3 or 4, faces and edges are parallel to the view axis, and a crack or a double blend
/// at any shared edge would show as a wrong pixel. Constant τ and colour.
#[test]
fn no_cracks_on_an_axis_aligned_grid_at_view_0_0() {
    // Box 4 × 4 × 7: L = 9, so with min(W, H) = 36 a pixel is 1/4 unit and grid steps of
    // 1/2 unit are 2 px.
    let mesh = kuhn_grid(
        [8, 8, 7],
        DVec3::new(-2.0, -2.0, -3.5),
        DVec3::new(2.0, 2.0, 3.5),
        |p| 0.5 + 0.05 * p.x,
    );
    let tf = tf(&[(0.0, [0.8, 0.5, 0.2], 0.6), (1.0, [0.8, 0.5, 0.2], 0.6)]);
    for (w, h) in [(37, 36), (36, 37), (36, 36), (40, 36)] {
        let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, w, h);
        let f = pt(&mesh, &tf, &cam, "exact");
        let r = reference(&mesh, &tf, &cam);
        for (k, (a, b)) in f.image.pixels.iter().zip(&r.pixels).enumerate() {
            for c in 0..4 {
                assert!(
                    (a[c] - b[c]).abs() < 1e-5,
                    "{w}x{h} pixel ({}, {}): {a:?} vs reference {b:?}",
                    k % w as usize,
                    k / w as usize
                );
            }
        }
        assert_eq!(f.counter("tets_discarded"), Some(0.0));
    }
}

/// One tet whose fan edges (class 1 and class 2) run through many pixel centres, with the
/// thick vertex on a centre: per-pixel agreement with the reference (no crack, no double
/// blend inside the fan).
#[test]
fn single_fans_with_edges_through_pixel_centres() {
    let tf = tf(&[(0.0, [0.3, 0.6, 0.9], 2.0), (1.0, [0.3, 0.6, 0.9], 2.0)]);
    // The bounding box is [-4, 4]³ (two far corners padded by a zero-volume tet would change
    // nothing); here the tets span it themselves. L = 8√3, 32 px: p = L/32.
    let z = |v: f64| v;
    let cases: [[DVec3; 4]; 2] = [
        // Class 1 at view (0, 0): (0, 0) inside the triangle.
        [
            DVec3::new(-4.0, -4.0, z(-4.0)),
            DVec3::new(4.0, -4.0, z(1.0)),
            DVec3::new(0.0, 4.0, z(-2.0)),
            DVec3::new(0.0, 0.0, z(4.0)),
        ],
        // Class 2: diagonals of a square cross at the centre.
        [
            DVec3::new(-4.0, -4.0, -4.0),
            DVec3::new(4.0, 4.0, -4.0),
            DVec3::new(-4.0, 4.0, 4.0),
            DVec3::new(4.0, -4.0, 4.0),
        ],
    ];
    for p in cases {
        let mesh = Mesh::with_scalars("fan", p.to_vec(), vec![[0, 1, 2, 3]], "s", vec![0.5; 4])
            .unwrap();
        for (w, h) in [(32, 32), (33, 33), (31, 32)] {
            let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, w, h);
            let f = pt(&mesh, &tf, &cam, "exact");
            let r = reference(&mesh, &tf, &cam);
            for (k, (a, b)) in f.image.pixels.iter().zip(&r.pixels).enumerate() {
                assert!(
                    (a[3] - b[3]).abs() < 1e-5,
                    "{w}x{h} pixel {k}: {a:?} vs {b:?}"
                );
            }
        }
    }
}

#[test]
fn degenerate_tets_render_finite() {
    let v = DVec3::new;
    let pos = vec![
        v(0., 0., 0.),
        v(1., 0., 0.),
        v(0., 1., 0.),
        v(0., 0., 1.),
        v(1., 1., 0.),      // 4: coplanar with 0, 1, 2 (flat tet)
        v(0.5, 0.5, 1e-9),  // 5: sliver apex
        v(1e-9, 1e-9, 1.0), // 6: needle tip near 3
        v(1., 1., 1.),
    ];
    let tets = vec![
        [0, 1, 2, 3], // regular
        [0, 2, 1, 3], // negative orientation
        [0, 1, 2, 4], // flat
        [0, 1, 2, 5], // sliver
        [0, 3, 6, 1], // needle
        [0, 0, 1, 2], // duplicate vertex
        [7, 7, 7, 7], // a point
        [1, 2, 4, 7],
    ];
    let s: Vec<f64> = (0..pos.len()).map(|i| i as f64 / 7.0).collect();
    let mesh = Mesh::with_scalars("degenerate", pos, tets, "s", s).unwrap();
    let tf = smooth_tf();
    for integ in INTEGRATORS {
        for (a, e) in [
            (0.0, 0.0),
            (90.0, 0.0),
            (0.0, 90.0),
            (45.0, 35.264389682754654),
            (30.0, 20.0),
        ] {
            for proj in [Projection::Ortho, Projection::Persp] {
                let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, 48, 40);
                let f = pt(&mesh, &tf, &cam, integ);
                assert!(f
                    .image
                    .pixels
                    .iter()
                    .flatten()
                    .all(|c| (0.0..=1.0 + 1e-6).contains(c)));
            }
        }
    }
}

/// Process CPU time (user + system) in seconds from /proc/self/stat (None elsewhere): on
/// a shared machine, CPU time per frame is steadier than wall time.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Throughput at 512² on a ~511K-tet grid with the stage split, for `partial` and `average`
/// on the f32 fast path and on the f64 `dyn Integrator` path (`-f64`):
/// `cargo test --release -p tetbench-algorithms --lib cpu_pt_throughput -- --ignored --nocapture`.
/// Besides wall time it prints tets per CPU-second over the measured frames.
#[test]
#[ignore]
fn cpu_pt_throughput() {
    let mesh = kuhn_grid([44, 44, 44], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        0.5 + 0.3 * (2.0 * p.x).sin() * (1.5 * p.y).cos() + 0.2 * p.z
    });
    let tf = smooth_tf();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        512,
        512,
    );
    for (integ, fast) in [
        ("partial", true),
        ("partial", false),
        ("average", true),
        ("average", false),
    ] {
        let mut r = CpuPt::new("centroid", integ).unwrap();
        r.set_fast_path(fast);
        r.prepare(&mesh, &tf).unwrap();
        // The counting allocator is not installed in unit tests: the prepared vectors.
        let bytes = r
            .state
            .as_ref()
            .map_or(0, |s| s.pos.capacity() * 12 + s.s.capacity() * 4);
        r.render(&mesh, &cam).unwrap();
        let cpu0 = cpu_seconds();
        let mut frames: Vec<Frame> = (0..5).map(|_| r.render(&mesh, &cam).unwrap()).collect();
        let cpu = cpu_seconds().zip(cpu0).map_or(f64::NAN, |(a, b)| a - b);
        frames.sort_by(|a, b| a.times.total_ms.total_cmp(&b.times.total_ms));
        let f = &frames[frames.len() / 2];
        let t = f.times;
        eprintln!(
            "{integ}{}: {} tets, {} threads: total {:.1} ms (project {:.1}, sort {:.1}, draw {:.1}) \
             = {:.2} M tet/s, {:.2} M tet per CPU-s; prepare bytes {bytes} ({:.1}/tet); {:?}",
            if fast { "" } else { "-f64" },
            mesh.num_tets(),
            rayon::current_num_threads(),
            t.total_ms,
            t.project_ms,
            t.sort_ms,
            t.draw_ms,
            mesh.num_tets() as f64 / t.total_ms / 1e3,
            5.0 * mesh.num_tets() as f64 / cpu / 1e6,
            bytes as f64 / mesh.num_tets() as f64,
            f.counters
        );
    }
}

#[test]
fn registry_and_sorts() {
    let opts = crate::render::RenderOptions::default();
    let r = crate::render::make("cpu-pt", &opts).unwrap();
    assert_eq!(r.describe().integrator, "partial");
    assert_eq!(r.describe().sort, "centroid");
    for sort in ["mpvonc", "bucket:16", "centroid-radix"] {
        let o = crate::render::RenderOptions {
            sort: Some(sort.into()),
            integrator: None,
            ..Default::default()
        };
        assert_eq!(crate::render::make("cpu-pt", &o).unwrap().describe().sort, sort);
    }
    let bad = crate::render::RenderOptions {
        sort: Some("bubble".into()),
        integrator: None,
        ..Default::default()
    };
    let e = crate::render::make("cpu-pt", &bad).err().unwrap();
    assert!(e.to_string().contains("bubble"), "{e}");
}

/// The fast path's span kernel (attributes as the min or max of the fan triangles' planes, in
/// f32 lanes) against its per-pixel kernel (each centre's own triangle, rounded from f64), tile
/// by tile on the same records and bins: the same fragments, and the same colour to f32
/// rounding (measured: max 3.0e-7 here). On the smooth grid, the degenerate tets and a grid
/// seen along its axes (classes 3 and 4), in several views.
#[test]
fn span_kernel_matches_per_pixel_kernel() {
    use super::fast::{DrawTile, Kernel};
    let tf = smooth_tf();
    let flat = kuhn_grid(
        [6, 5, 4],
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
        |p| p.x * 0.7 + p.y * 0.2 + p.z * 0.1,
    );
    let mut worst = 0.0f32;
    for mesh in [smooth_grid(), flat] {
        for (a, e) in VIEWS.into_iter().chain([(0.0, 0.0), (90.0, 0.0)]) {
            let cam = Camera::new(&mesh.bbox(), View::new(a, e), Projection::Ortho, 150, 90);
            let mut r = CpuPt::new("centroid", "partial").unwrap();
            r.prepare(&mesh, &tf).unwrap();
            r.render(&mesh, &cam).unwrap();
            let integ = r.state.as_ref().unwrap().shading.f32().unwrap();
            let sc = &r.scratch;
            let (w, h) = (cam.width, cam.height);
            let ntx = w.div_ceil(TILE);
            let mut frags = 0;
            for k in 0..(ntx * h.div_ceil(TILE)) {
                let run = |kernel| {
                    let mut buf = vec![[0.0f32; 4]; (TILE * TILE) as usize];
                    let n = pulp::Arch::new().dispatch(DrawTile {
                        recs: &sc.fast,
                        items: sc.bins.tile(k as usize),
                        integ,
                        tile: (k % ntx, k / ntx),
                        size: (w, h),
                        kernel,
                        buf: &mut buf,
                    });
                    (buf, n)
                };
                let ((sp, nsp), (pp, npp)) = (run(Kernel::Spans), run(Kernel::PerPixel));
                assert_eq!(nsp, npp, "tile {k} ({a}, {e})");
                frags += nsp;
                for (x, y) in sp.iter().flatten().zip(pp.iter().flatten()) {
                    assert!(x.is_finite());
                    worst = worst.max((x - y).abs());
                }
            }
            assert!(frags > 1000, "({a}, {e}): {frags} fragments");
        }
    }
    eprintln!("span vs per-pixel kernel: max |difference| {worst:.3e}");
    assert!(worst <= 2e-6, "{worst}");
}

/// The order drawn part after part gives the image of one pass over it, bit for bit, on the
/// fast and the f64 paths, in ortho and perspective: each pixel meets the same fragments in the
/// same order.
#[test]
fn parts_of_the_order_render_as_one_pass() {
    let mesh = smooth_grid();
    let tf = smooth_tf();
    for (integrator, projection) in [
        ("partial", Projection::Ortho),
        ("exact", Projection::Ortho),
        ("partial", Projection::Persp),
    ] {
        let camera = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), projection, 96, 80);
        let image = |part: usize| {
            let mut r = CpuPt::new("centroid", integrator).unwrap();
            r.part = part;
            r.prepare(&mesh, &tf).unwrap();
            let frame = r.render(&mesh, &camera).unwrap();
            // A second frame reuses the scratch (tile buffers included) and must not differ.
            let again = r.render(&mesh, &camera).unwrap();
            assert_eq!(frame.image.pixels, again.image.pixels, "{integrator} {projection:?}");
            frame.image.pixels
        };
        let whole = image(PART);
        assert!(mesh.num_tets() > 7 * 1000, "the mesh must span several parts");
        assert_eq!(image(1000), whole, "{integrator} {projection:?}");
        assert_eq!(image(1), whole, "{integrator} {projection:?}");
    }
}
