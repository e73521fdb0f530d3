//! The reference ray caster against closed forms and symmetries.

use algorithms::camera::{Camera, Projection, View};
use algorithms::glam::DVec3;
use algorithms::io::split::split_structured;
use algorithms::io::Split;
use algorithms::render::raycast::RayCaster;
use algorithms::render::Renderer;
use algorithms::tf::{TfPoint, TransferFunction};
use algorithms::Mesh;

/// A box grid of nx×ny×nz cubes split 6 per cube (Kuhn, the readers' structured split), with
/// scalars from `f`.
fn kuhn_grid(n: [usize; 3], lo: DVec3, hi: DVec3, f: impl Fn(DVec3) -> f64) -> Mesh {
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
    let tets = split_structured("grid", dims, &pos, Split::Six).unwrap();
    let s = pos.iter().map(|p| f(*p)).collect();
    Mesh::with_scalars("grid", pos, tets, "s", s).unwrap()
}

/// The mesh mirrored in x = 0 and merged with itself: exactly symmetric, connectivity included.
fn mirrored(half: &Mesh) -> Mesh {
    let n = half.num_vertices();
    let mut pos = half.positions().to_vec();
    let mut s = half.scalars().to_vec();
    let mut map = vec![0u32; n];
    for (i, p) in half.positions().iter().enumerate() {
        if p.x == 0.0 {
            map[i] = i as u32;
        } else {
            map[i] = pos.len() as u32;
            pos.push(DVec3::new(-p.x, p.y, p.z));
            s.push(half.scalars()[i]);
        }
    }
    let mut tets = half.tets().to_vec();
    for t in half.tets() {
        tets.push([
            map[t[0] as usize],
            map[t[2] as usize],
            map[t[1] as usize],
            map[t[3] as usize],
        ]);
    }
    Mesh::with_scalars("mirrored", pos, tets, "s", s).unwrap()
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

fn render(
    mesh: &Mesh,
    tf: &TransferFunction,
    view: View,
    proj: Projection,
    w: u32,
    h: u32,
) -> Vec<[f64; 4]> {
    let mut rc = RayCaster::new("exact", "reference");
    rc.prepare(mesh, tf).unwrap();
    let cam = Camera::new(&mesh.bbox(), view, proj, w, h);
    let (px, stats) = rc.render_f64(mesh, &cam).unwrap();
    assert_eq!(stats.lost, 0, "lost rays");
    assert_eq!(stats.fallbacks, 0, "walks with no consistent exit face");
    assert!(px.iter().flatten().all(|c| c.is_finite()));
    px
}

/// Chord length of a ray through an axis-aligned box (slab method).
fn chord(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return 0.0;
            }
            continue;
        }
        let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t1 - t0).max(0.0)
}

#[test]
fn constant_tau_box_matches_closed_form_in_ortho_and_persp() {
    let (lo, hi) = (DVec3::new(-1.0, -0.5, -0.75), DVec3::new(1.0, 0.5, 0.75));
    let mesh = kuhn_grid([3, 2, 2], lo, hi, |_| 0.5);
    let tau = 7.0;
    let t = tf(&[(0.0, [0.2, 0.6, 1.0], tau)]);
    let l = mesh.diagonal();
    for proj in [Projection::Ortho, Projection::Persp] {
        for view in [
            View::new(0.0, 0.0),
            View::new(33.0, 21.0),
            View::new(-120.0, -60.0),
        ] {
            let (w, h) = (41, 31);
            let px = render(&mesh, &t, view, proj, w, h);
            let cam = Camera::new(&mesh.bbox(), view, proj, w, h);
            let c = mesh.bbox().center();
            let mut hit = 0;
            for j in 0..h {
                for i in 0..w {
                    let r = cam.pixel_ray(i, j);
                    let ch = chord(r.origin + c, r.dir, lo, hi);
                    let want = 1.0 - (-tau * ch / l).exp();
                    let got = px[(j * w + i) as usize];
                    assert!(
                        (got[3] - want).abs() < 1e-9,
                        "{proj:?} {view:?} ({i},{j}): alpha {} vs {want}",
                        got[3]
                    );
                    assert!((got[2] - want).abs() < 1e-9);
                    assert!((got[0] - 0.2 * want).abs() < 1e-9);
                    hit += (ch > 0.0) as usize;
                }
            }
            assert!(hit > (w * h / 8) as usize, "{hit} rays hit");
        }
    }
}

#[test]
fn ray_through_a_vertex_shared_by_many_tets_is_neither_lost_nor_doubled() {
    // A 2×2×2 grid: the centre vertex is shared by 8 cubes (48 tets). With an odd image size
    // the centre pixel's ray passes exactly through it; at view (0, 0) many rays also run
    // along edges and faces.
    let (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
    let mesh = kuhn_grid([2, 2, 2], lo, hi, |_| 0.0);
    let tau = 3.0;
    let t = tf(&[(0.0, [1.0; 3], tau)]);
    let l = mesh.diagonal();
    for view in [
        View::new(0.0, 0.0),
        View::new(45.0, 35.264389682754654),
        View::new(10.0, 20.0),
        View::new(90.0, 0.0),
    ] {
        for proj in [Projection::Ortho, Projection::Persp] {
            let n = 21;
            let px = render(&mesh, &t, view, proj, n, n);
            let cam = Camera::new(&mesh.bbox(), view, proj, n, n);
            for j in 0..n {
                for i in 0..n {
                    let r = cam.pixel_ray(i, j);
                    let want = 1.0 - (-tau * chord(r.origin, r.dir, lo, hi) / l).exp();
                    let got = px[(j * n + i) as usize][3];
                    assert!(
                        (got - want).abs() < 1e-9,
                        "{view:?} {proj:?} pixel ({i},{j}): {got} vs {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn mirrored_views_of_a_mirror_symmetric_field_give_mirrored_images() {
    let half = kuhn_grid(
        [3, 3, 3],
        DVec3::new(0.0, -1.0, -1.0),
        DVec3::new(1.5, 1.0, 1.0),
        |p| (p.x * p.x + 0.4 * p.y + 0.3 * (3.0 * p.z).sin()).clamp(0.0, 10.0) / 3.0,
    );
    let mesh = mirrored(&half);
    assert_eq!(mesh.adjacency().nonmanifold_faces, 0);
    let t = tf(&[
        (0.0, [0.0, 0.0, 1.0], 0.5),
        (0.3, [0.0, 1.0, 0.0], 6.0),
        (0.7, [1.0, 0.5, 0.0], 2.0),
        (1.0, [1.0, 1.0, 1.0], 9.0),
    ]);
    let (w, h) = (48, 40);
    for (az, el) in [(30.0, 15.0), (75.0, -40.0)] {
        for proj in [Projection::Ortho, Projection::Persp] {
            let a = render(&mesh, &t, View::new(az, el), proj, w, h);
            let b = render(&mesh, &t, View::new(-az, el), proj, w, h);
            let mut worst = 0.0f64;
            for j in 0..h {
                for i in 0..w {
                    let pa = a[(j * w + i) as usize];
                    let pb = b[(j * w + (w - 1 - i)) as usize];
                    for c in 0..4 {
                        worst = worst.max((pa[c] - pb[c]).abs());
                    }
                }
            }
            assert!(
                worst < 1e-6,
                "({az},{el}) {proj:?}: mirrored images differ by {worst}"
            );
            assert!(a.iter().any(|p| p[3] > 0.1));
        }
    }
}

#[test]
fn a_mesh_translated_by_1e6_renders_like_the_original_and_twice_identically() {
    let mesh = kuhn_grid(
        [4, 3, 2],
        DVec3::new(-1.0, -0.7, -0.4),
        DVec3::new(1.0, 0.7, 0.4),
        |p| (0.5 + 0.4 * (2.0 * p.x).sin() * p.y.cos()).clamp(0.0, 1.0),
    );
    let off = DVec3::new(1e6, -1e6, 1e6);
    let moved = Mesh::with_scalars(
        "moved",
        mesh.positions().iter().map(|p| *p + off).collect(),
        mesh.tets().to_vec(),
        "s",
        mesh.scalars().to_vec(),
    )
    .unwrap();
    let t = tf(&[
        (0.0, [0.1, 0.2, 0.9], 1.0),
        (0.5, [0.9, 0.9, 0.1], 8.0),
        (1.0, [1.0, 0.2, 0.1], 3.0),
    ]);
    for proj in [Projection::Ortho, Projection::Persp] {
        let v = View::new(20.0, 30.0);
        let a = render(&mesh, &t, v, proj, 32, 32);
        let b = render(&moved, &t, v, proj, 32, 32);
        let worst = a
            .iter()
            .zip(&b)
            .flat_map(|(p, q)| (0..4).map(move |c| (p[c] - q[c]).abs()))
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "{proj:?}: translated mesh differs by {worst}");
        let again = render(&mesh, &t, v, proj, 32, 32);
        assert!(a
            .iter()
            .zip(&again)
            .all(|(p, q)| p.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits())));
    }
}

#[test]
fn non_convex_mesh_is_re_entered() {
    // Two boxes with a gap between them along x: rays along x cross both.
    let a = kuhn_grid(
        [2, 2, 2],
        DVec3::new(-2.0, -1.0, -1.0),
        DVec3::new(-0.5, 1.0, 1.0),
        |_| 0.0,
    );
    let b = kuhn_grid(
        [2, 2, 2],
        DVec3::new(0.5, -1.0, -1.0),
        DVec3::new(2.0, 1.0, 1.0),
        |_| 0.0,
    );
    let n = a.num_vertices() as u32;
    let pos: Vec<DVec3> = a.positions().iter().chain(b.positions()).copied().collect();
    let tets: Vec<[u32; 4]> = a
        .tets()
        .iter()
        .copied()
        .chain(b.tets().iter().map(|t| t.map(|v| v + n)))
        .collect();
    let np = pos.len();
    let mesh = Mesh::with_scalars("two", pos, tets, "s", vec![0.0; np]).unwrap();
    assert!(!mesh.is_convex());
    let tau = 2.0;
    let t = tf(&[(0.0, [1.0; 3], tau)]);
    let l = mesh.diagonal();
    let view = View::new(90.0, 10.0);
    let px = render(&mesh, &t, view, Projection::Ortho, 25, 25);
    let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 25, 25);
    let mut both = 0;
    for j in 0..25 {
        for i in 0..25 {
            let r = cam.pixel_ray(i, j);
            let ca = chord(
                r.origin,
                r.dir,
                DVec3::new(-2.0, -1.0, -1.0),
                DVec3::new(-0.5, 1.0, 1.0),
            );
            let cb = chord(
                r.origin,
                r.dir,
                DVec3::new(0.5, -1.0, -1.0),
                DVec3::new(2.0, 1.0, 1.0),
            );
            both += (ca > 0.0 && cb > 0.0) as usize;
            let want = 1.0 - (-tau * (ca + cb) / l).exp();
            let got = px[(j * 25 + i) as usize][3];
            assert!((got - want).abs() < 1e-9, "({i},{j}) {got} vs {want}");
        }
    }
    assert!(both > 50);
}
