//! Exhaustive tests of the truth table, the thick vertex and the fill rule.

use super::*;
use crate::camera::{Camera, Projection, View};
use crate::mesh::Aabb;
use crate::util::rng::Rng;

#[test]
fn table_has_the_papers_case_counts() {
    let mut count = [0usize; 6];
    for c in TABLE.iter() {
        count[c.class as usize] += 1;
    }
    // Wylie's 14 (8 class 1 + 6 class 2), PTINT's 24 class-3 and 12 class-4 cases, one
    // all-collinear entry and 30 sign patterns no four points have.
    assert_eq!(count, [30, 8, 6, 24, 12, 1]);
    for c in TABLE.iter() {
        assert_eq!(Case::unpack(c.pack()), *c);
        let expect = match c.class {
            1 => 3,
            2 => 4,
            3 => 2,
            4 => 1,
            _ => 0,
        };
        assert_eq!(c.ntri, expect);
        if c.drawn() {
            assert_eq!(c.side_a & c.side_b, 0);
            assert!(c.side_a.count_ones() <= c.side_b.count_ones());
            // The fan visits each silhouette vertex once (closed fans repeat the first).
            let n = c.ntri as usize + 1;
            let mut seen = 0u8;
            for k in 0..n {
                seen |= 1 << c.fan[k];
            }
            let closed = c.class <= 2;
            assert_eq!(closed, c.fan[0] == c.fan[n - 1]);
            let silhouette = match c.class {
                1 => c.side_b,
                2 => c.side_a | c.side_b,
                3 => 15 & !c.side_a,
                _ => 15 & !c.side_a & !c.side_b | c.side_a,
            };
            let fan_set = if c.class == 4 { seen | c.side_a } else { seen };
            assert_eq!(fan_set, silhouette, "{c:?}");
        }
    }
    // The all-zero pattern is index 1 + 3 + 9 + 27 = 40.
    assert_eq!(TABLE[40].class, CLASS_COLLINEAR);
}

#[test]
fn wgsl_table_round_trips() {
    let w = table_wgsl();
    assert!(w.contains("const PT_TABLE: array<u32, 81>"));
    let vals: Vec<u32> = w
        .split("0x")
        .skip(1)
        .map(|s| u32::from_str_radix(&s[..8], 16).unwrap())
        .collect();
    assert_eq!(vals.len(), 81);
    for (v, c) in vals.iter().zip(TABLE.iter()) {
        assert_eq!(Case::unpack(*v), *c);
    }
}

/// Whether snapped point `p`, moved by (+ε, −ε²), is inside triangle (a, b, c) of either
/// orientation (false for a degenerate triangle). Written independently of the rasterizer.
fn inside_perturbed(a: [i64; 2], b: [i64; 2], c: [i64; 2], p: [i64; 2]) -> bool {
    let o = orient(a, b, c);
    if o == 0 {
        return false;
    }
    let (b, c) = if o > 0 { (b, c) } else { (c, b) };
    [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| {
        let e = orient(u, v, p);
        // Derivative of orient(u, v, p + (ε, −ε²)) in ε, then ε².
        let (dx, dy) = (v[0] - u[0], v[1] - u[1]);
        e > 0 || (e == 0 && (-dy > 0 || (dy == 0 && -dx > 0)))
    })
}

/// Per-pixel coverage of the fan of snapped points `q` in a `n`×`n` window: checks that every
/// centre inside the convex hull is covered once and no other is.
fn check_coverage(q: [[i64; 2]; 4], n: i64) -> usize {
    let t = tests(&q);
    let idx = table_index(&t);
    let c = &TABLE[idx];
    assert_ne!(c.class, CLASS_IMPOSSIBLE, "impossible pattern for {q:?}");
    let v = q.map(|q| ProjVertex {
        q,
        ..Default::default()
    });
    let th = classify(&v, false, 1.0);
    let g = FanGeometry::new(q, &th);
    let mut cover = vec![0u32; (n * n) as usize];
    raster_fan(&g, [0, 0, n - 1, n - 1], |fr| {
        assert!(fr.lx >= 0.0 && fr.ly >= 0.0 && fr.lx + fr.ly <= 1.0 + 1e-12);
        cover[(fr.j * n + fr.i) as usize] += 1;
    });
    let mut covered = 0;
    for j in 0..n {
        for i in 0..n {
            let p = [pixel_centre(i), pixel_centre(j)];
            let hull = (0..4).any(|k| {
                let o: Vec<usize> = (0..4).filter(|&m| m != k).collect();
                inside_perturbed(q[o[0]], q[o[1]], q[o[2]], p)
            });
            let got = cover[(j * n + i) as usize];
            let want = (hull && c.drawn()) as u32;
            assert_eq!(got, want, "pixel ({i}, {j}) of {q:?}, case {c:?}");
            covered += got as usize;
        }
    }
    covered
}

#[test]
fn every_possible_pattern_occurs_and_every_fan_tiles_its_silhouette() {
    // All configurations of four points on a 4×4 lattice of pixel centres 2 px apart (with
    // many edges through other centres): every sign pattern they give is a possible entry,
    // every possible entry is met, and coverage is exactly the hull.
    let mut met = [false; 81];
    let mut drawn_px = 0;
    let pts: Vec<[i64; 2]> = (0..16)
        .map(|k| [pixel_centre(1 + 2 * (k % 4)), pixel_centre(1 + 2 * (k / 4))])
        .collect();
    for code in 0..16usize.pow(4) {
        let q = [
            pts[code % 16],
            pts[code / 16 % 16],
            pts[code / 256 % 16],
            pts[code / 4096],
        ];
        let idx = table_index(&tests(&q));
        met[idx] = true;
        // Coverage on a subset (the full set is 65536 rasterisations).
        if code % 7 == 0 {
            drawn_px += check_coverage(q, 9);
        }
    }
    for (i, c) in TABLE.iter().enumerate() {
        assert_eq!(met[i], c.class != CLASS_IMPOSSIBLE, "entry {i}: {c:?}");
    }
    assert!(drawn_px > 10_000);
}

#[test]
fn random_fans_cover_each_centre_once() {
    let mut rng = Rng::new(7);
    for it in 0..3000 {
        // Random points; some snapped onto centres, edges or each other.
        let mut q = [[0i64; 2]; 4];
        for v in q.iter_mut() {
            *v = match it % 3 {
                0 => [rng.int(12 * SUBPIXEL as u64), rng.int(12 * SUBPIXEL as u64)],
                1 => [
                    pixel_centre(rng.int(12)) + rng.int(3) - 1,
                    pixel_centre(rng.int(12)),
                ],
                _ => [rng.int(7) * SUBPIXEL / 2, rng.int(7) * SUBPIXEL / 2],
            };
        }
        check_coverage(q, 12);
    }
}

/// Brute force: the interval of the ray `o + t·d` inside the (non-flat) tet `p`, with the
/// scalars there, from barycentric coordinates affine in `t`.
fn ray_tet(o: DVec3, d: DVec3, p: &[DVec3; 4], s: &[f64; 4]) -> Option<(f64, f64, f64, f64)> {
    let m = glam::DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    if m.determinant().abs() < 1e-12 {
        return None;
    }
    let inv = m.inverse();
    let b0 = inv * (o - p[0]);
    let bd = inv * d;
    let lam0 = [1.0 - b0.x - b0.y - b0.z, b0.x, b0.y, b0.z];
    let lamd = [-bd.x - bd.y - bd.z, bd.x, bd.y, bd.z];
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    let tol = 1e-9;
    for k in 0..4 {
        // lam0 + t·lamd ≥ −tol
        if lamd[k].abs() < 1e-14 {
            if lam0[k] < -tol {
                return None;
            }
            continue;
        }
        let t = (-tol - lam0[k]) / lamd[k];
        if lamd[k] > 0.0 {
            t0 = t0.max(t);
        } else {
            t1 = t1.min(t);
        }
    }
    if t0 > t1 + 1e-9 {
        return None;
    }
    let at = |t: f64| (0..4).map(|k| (lam0[k] + t * lamd[k]) * s[k]).sum::<f64>();
    Some((t0, t1, at(t0), at(t1)))
}

/// Classifies a tet given in pixel units, seen along −z in ortho (depth = −z), against the
/// brute-force intersection of the ray through the thick vertex. Points must have x, y on the
/// snapping grid so the projection is exact.
fn check_exact_ortho(p: [DVec3; 4], s: [f64; 4]) -> u8 {
    let v: [ProjVertex; 4] = std::array::from_fn(|k| ProjVertex {
        q: [snap(p[k].x), snap(p[k].y)],
        z: -p[k].z,
        p: p[k],
        s: s[k],
    });
    for k in 0..4 {
        assert_eq!(v[k].q[0] as f64, p[k].x * SUBPIXEL as f64);
        assert_eq!(v[k].q[1] as f64, p[k].y * SUBPIXEL as f64);
    }
    let th = classify(&v, false, 1.0);
    let c = th.entry();
    assert_ne!(c.class, CLASS_IMPOSSIBLE);
    // The fast path's classification gives the same entry and the same bits.
    let (case, ends) = classify_ortho(&v.map(|v| v.q), &v.map(|v| v.z), &p, &s, 1.0);
    assert_eq!(case, th.case, "{p:?}");
    if c.drawn() {
        let want = [th.sf, th.sb, th.l];
        assert_eq!(ends.map(f64::to_bits), want.map(f64::to_bits), "{p:?}");
    }
    let flat = glam::DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0])
        .determinant()
        .abs()
        < 1e-12;
    if !c.drawn() {
        assert!(flat, "collinear projection of a non-flat tet {p:?}");
        return c.class;
    }
    for x in [th.sf, th.sb, th.zf, th.zb, th.l, th.x, th.y] {
        assert!(x.is_finite(), "{th:?}");
    }
    assert!(th.zf <= th.zb && th.l >= 0.0);
    if flat {
        // The ray meets a flat (non edge-on) tet in a point.
        assert!(th.l < 1e-9, "{p:?} {th:?}");
        return c.class;
    }
    let o = DVec3::new(th.x / SUBPIXEL as f64, th.y / SUBPIXEL as f64, 1e3);
    let (t0, t1, s0, s1) = ray_tet(o, DVec3::NEG_Z, &p, &s)
        .unwrap_or_else(|| panic!("thick ray misses the tet {p:?} {th:?}"));
    let scale = 1.0 + p.iter().map(|q| q.length()).fold(0.0, f64::max);
    let tol = 1e-7 * scale;
    assert!(
        (th.l - (t1 - t0)).abs() < tol,
        "l {} vs {} {p:?}",
        th.l,
        t1 - t0
    );
    assert!((th.zf - (t0 - 1e3)).abs() < tol && (th.zb - (t1 - 1e3)).abs() < tol);
    assert!(
        (th.sf - s0).abs() < 1e-7 && (th.sb - s1).abs() < 1e-7,
        "{th:?} {s0} {s1}"
    );
    c.class
}

#[test]
fn thick_vertex_matches_brute_force_on_random_and_degenerate_tets() {
    let mut rng = Rng::new(11);
    let mut classes = [0usize; 6];
    let mut cases = [false; 81];
    let grid = |rng: &mut Rng, n: u64| rng.int(n) as f64 / 2.0;
    for it in 0..40_000 {
        let p: [DVec3; 4] = std::array::from_fn(|_| match it % 4 {
            // Generic: x, y on a fine grid, any z.
            0 => DVec3::new(
                rng.int(4000) as f64 / 64.0,
                rng.int(4000) as f64 / 64.0,
                rng.f() * 50.0 - 25.0,
            ),
            // A small lattice: faces and edges parallel to the view axis, coincident
            // projections, flat tets.
            1 => DVec3::new(grid(&mut rng, 4), grid(&mut rng, 4), grid(&mut rng, 4)),
            2 => DVec3::new(grid(&mut rng, 3), grid(&mut rng, 3), rng.f() * 3.0),
            _ => DVec3::new(grid(&mut rng, 6), grid(&mut rng, 6), grid(&mut rng, 8)),
        });
        let s: [f64; 4] = std::array::from_fn(|_| rng.f());
        let c = check_exact_ortho(p, s);
        classes[c as usize] += 1;
        let q = p.map(|v| [snap(v.x), snap(v.y)]);
        cases[table_index(&tests(&q))] = true;
    }
    // Every possible entry was met by a tet checked against the brute force.
    for (i, c) in TABLE.iter().enumerate() {
        assert_eq!(cases[i], c.class != CLASS_IMPOSSIBLE, "entry {i} {c:?}");
    }
    assert!(classes[1..6].iter().all(|&n| n > 100), "{classes:?}");
}

#[test]
fn constructed_degenerate_tets() {
    let s = [0.1, 0.4, 0.7, 1.0];
    let v = DVec3::new;
    // Class 3: vertex 3 above the middle of edge 0–1 (face 0-1-3 parallel to the view axis).
    assert_eq!(
        check_exact_ortho(
            [v(0., 0., 0.), v(4., 0., 1.), v(1., 3., 0.), v(2., 0., 3.)],
            s
        ),
        3
    );
    // Class 4: edge 0–3 parallel to the view axis.
    assert_eq!(
        check_exact_ortho(
            [v(1., 1., 0.), v(4., 0., 1.), v(0., 3., 0.), v(1., 1., 2.)],
            s
        ),
        4
    );
    // Flat tet seen edge-on: discarded.
    assert_eq!(
        check_exact_ortho(
            [v(0., 0., 0.), v(1., 1., 1.), v(2., 2., 0.), v(3., 3., 5.)],
            s
        ),
        CLASS_COLLINEAR
    );
    // Flat tet seen face-on: drawn with l = 0.
    assert_eq!(
        check_exact_ortho(
            [v(0., 0., 1.), v(4., 0., 1.), v(0., 4., 1.), v(1., 1., 1.)],
            s
        ),
        1
    );
    // Duplicate vertices: a needle (three coincident) and a point.
    let needle = [v(1., 1., 0.), v(1., 1., 0.), v(1., 1., 0.), v(3., 2., 1.)];
    assert_eq!(check_exact_ortho(needle, s), CLASS_COLLINEAR);
    let point = [v(1., 1., 0.); 4];
    assert_eq!(check_exact_ortho(point, s), CLASS_COLLINEAR);
    // Negative orientation: same result as the positive one with two vertices swapped.
    let a = [v(0., 0., 0.), v(4., 0., 1.), v(1., 3., 0.), v(1., 1., 3.)];
    let b = [a[1], a[0], a[2], a[3]];
    assert_eq!(
        check_exact_ortho(a, s),
        check_exact_ortho(b, [s[1], s[0], s[2], s[3]])
    );
}

#[test]
fn thick_vertex_through_the_camera_ortho_and_persp() {
    let bbox = Aabb {
        min: DVec3::splat(-1.0),
        max: DVec3::splat(1.0),
    };
    let l = bbox.diagonal();
    let mut rng = Rng::new(5);
    let mut checked = 0;
    for it in 0..4000 {
        let proj = if it % 2 == 0 {
            Projection::Ortho
        } else {
            Projection::Persp
        };
        let view = View::new(rng.f() * 360.0, rng.f() * 180.0 - 90.0);
        let cam = Camera::new(&bbox, view, proj, 128, 96);
        let p: [DVec3; 4] =
            std::array::from_fn(|_| DVec3::new(rng.f(), rng.f(), rng.f()) * 1.6 - 0.8);
        // Move each vertex along the view axis's ray family so that it projects exactly onto
        // its snapped position (at the same depth): the brute force then sees the same tet.
        let p = p.map(|p| {
            let (x, y, z) = cam.project(p);
            let (qx, qy) = (snap(x) as f64, snap(y) as f64);
            let r = cam.ray_at(qx / SUBPIXEL as f64, qy / SUBPIXEL as f64);
            let t = match proj {
                Projection::Ortho => z,
                Projection::Persp => z / r.dir.dot(cam.forward),
            };
            r.origin + t * r.dir
        });
        let vol = (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]);
        if vol.abs() < 0.02 {
            continue;
        }
        let s: [f64; 4] = std::array::from_fn(|_| rng.f());
        let v: [ProjVertex; 4] = std::array::from_fn(|k| ProjVertex::project(&cam, p[k], s[k]));
        let t = tests(&v.map(|v| v.q));
        let big = t.iter().map(|x| x.abs()).max().unwrap() as f64;
        if t.iter().any(|&x| (x.abs() as f64) < 1e-3 * big) {
            continue;
        }
        let th = classify(&v, proj == Projection::Persp, 1.0 / l);
        let ray = cam.ray_at(th.x / SUBPIXEL as f64, th.y / SUBPIXEL as f64);
        let (t0, t1, s0, s1) = ray_tet(ray.origin, ray.dir, &p, &s).expect("thick ray misses");
        let tol = 1e-8;
        assert!(
            (th.l - (t1 - t0) / l).abs() < tol,
            "{proj:?} l {} vs {}",
            th.l,
            (t1 - t0) / l
        );
        assert!((th.sf - s0).abs() < 1e-7 && (th.sb - s1).abs() < 1e-7);
        checked += 1;
    }
    assert!(checked > 1000, "{checked}");
}

/// The fragments of [`raster_fan_rows`], tested per pixel.
fn span_fragments(g: &FanGeometry, clip: [i64; 4]) -> Vec<Fragment> {
    let mut out = Vec::new();
    raster_fan_rows(g.case, &g.q, clip, |s| {
        assert!(s.i0 <= s.i1 && s.i0 >= clip[0] && s.i1 <= clip[2]);
        for (k, i) in (s.i0..=s.i1).enumerate() {
            if s.covers(k as i64) {
                out.push(Fragment {
                    i,
                    j: s.j,
                    tri: s.tri,
                    lx: s.lx + k as f64 * s.dlx,
                    ly: s.ly + k as f64 * s.dly,
                });
            }
        }
    });
    out
}

/// The row rasteriser covers exactly the centres the per-pixel one does, in the same
/// triangles, with the same barycentric weights (to rounding), on lattice, random and
/// clipped fans.
#[test]
fn span_rasteriser_matches_per_pixel_rasteriser() {
    let mut rng = Rng::new(11);
    let mut total = 0;
    for it in 0..1500 {
        let mut q = [[0i64; 2]; 4];
        for v in q.iter_mut() {
            *v = match it % 4 {
                0 => [rng.int(40 * SUBPIXEL as u64), rng.int(40 * SUBPIXEL as u64)],
                1 => [
                    pixel_centre(rng.int(12)) + rng.int(3) - 1,
                    pixel_centre(rng.int(12)),
                ],
                2 => [rng.int(7) * SUBPIXEL / 2, rng.int(7) * SUBPIXEL / 2],
                _ => [
                    rng.int(3000 * SUBPIXEL as u64) - 1000 * SUBPIXEL,
                    rng.int(3000 * SUBPIXEL as u64) - 1000 * SUBPIXEL,
                ],
            };
        }
        let v = q.map(|q| ProjVertex {
            q,
            ..Default::default()
        });
        let th = classify(&v, false, 1.0);
        let g = FanGeometry::new(q, &th);
        let clips = [
            [0, 0, 40, 40],
            [3, 5, 9, 7],
            [rng.int(20), rng.int(20), 20 + rng.int(20), 20 + rng.int(20)],
            [-5, -5, 2000, 2000],
        ];
        for clip in clips {
            let mut want = Vec::new();
            raster_fan(&g, clip, |f| want.push(f));
            let got = span_fragments(&g, clip);
            assert_eq!(got.len(), want.len(), "{q:?} clip {clip:?}");
            for (a, b) in got.iter().zip(&want) {
                assert_eq!((a.i, a.j, a.tri), (b.i, b.j, b.tri), "{q:?} clip {clip:?}");
                assert!((a.lx - b.lx).abs() < 1e-9 && (a.ly - b.ly).abs() < 1e-9);
            }
            total += got.len();
        }
    }
    assert!(total > 30_000, "{total}");
}

/// `got` (in row order) holds the centres of `want` (in any order), in the same triangles,
/// with the same weights to 1e-9; `what` names the case.
pub(crate) fn assert_same_fragments(
    mut want: Vec<Fragment>,
    got: &[Fragment],
    what: &dyn std::fmt::Debug,
) {
    want.sort_by_key(|f| (f.j, f.i));
    assert_eq!(got.len(), want.len(), "{what:?}");
    for (a, b) in got.iter().zip(&want) {
        assert_eq!((a.i, a.j, a.tri), (b.i, b.j, b.tri), "{what:?}");
        assert!(
            (a.lx - b.lx).abs() < 1e-9 && (a.ly - b.ly).abs() < 1e-9,
            "{a:?} {b:?}"
        );
    }
}

/// Four snapped points of kind `mode`: 0 random in 40×40 pixels, 1 near pixel centres of a
/// 12×12 block, 2 and 3 on coarse lattices (shared coordinates, collinear triples: classes 3
/// and 4), 4 random over thousands of pixels.
pub(crate) fn fan_points(rng: &mut Rng, mode: usize) -> [[i64; 2]; 4] {
    std::array::from_fn(|_| match mode {
        0 => [rng.int(40 * SUBPIXEL as u64), rng.int(40 * SUBPIXEL as u64)],
        1 => [
            pixel_centre(rng.int(12)) + rng.int(3) - 1,
            pixel_centre(rng.int(12)),
        ],
        2 => [rng.int(7) * SUBPIXEL / 2, rng.int(7) * SUBPIXEL / 2],
        3 => [rng.int(5) * SUBPIXEL, rng.int(5) * SUBPIXEL],
        _ => [
            rng.int(3000 * SUBPIXEL as u64) - 1000 * SUBPIXEL,
            rng.int(3000 * SUBPIXEL as u64) - 1000 * SUBPIXEL,
        ],
    })
}

/// The whole-tet rasteriser covers exactly the centres the per-triangle one does, in the same
/// triangles, with the same barycentric weights (to rounding), on lattice, random, degenerate
/// (shared coordinates, collinear triples: classes 3 and 4) and clipped fans.
#[test]
fn tet_rasteriser_matches_per_pixel_rasteriser() {
    let mut rng = Rng::new(23);
    let mut total = 0;
    let mut classes = [0usize; 6];
    for it in 0..2500 {
        // Large fans (thousands of pixels) in one case of 25: they dominate the time.
        let q = fan_points(&mut rng, if it % 25 == 24 { 4 } else { it % 4 });
        let v = q.map(|q| ProjVertex {
            q,
            ..Default::default()
        });
        let th = classify(&v, false, 1.0);
        let g = FanGeometry::new(q, &th);
        classes[g.case.class as usize] += 1;
        let clips = [
            [0, 0, 40, 40],
            [3, 5, 9, 7],
            [rng.int(20), rng.int(20), 20 + rng.int(20), 20 + rng.int(20)],
            [-5, -5, 2000, 2000],
        ];
        for clip in clips {
            let mut want = Vec::new();
            raster_fan(&g, clip, |f| want.push(f));
            let mut got = Vec::new();
            if let Some(r) = TetRaster::new(g.case, &q, clip) {
                tet_raster::assert_spans_are_rows(r);
                r.fragments(|f| got.push(f));
            }
            assert_same_fragments(want, &got, &(q, clip));
            total += got.len();
        }
    }
    assert!(total > 30_000, "{total}");
    // Every drawn class occurs.
    assert!(classes[1..=4].iter().all(|&n| n > 20), "{classes:?}");
}

/// The same at the ends of the snapped range (|x| up to 2³⁰, `MAX_PIXEL_COORD`), where the
/// rows' f64 estimate of each silhouette bound (`first_positive`) has the least room and the
/// edge values are largest: fans of a few hundred thousand pixels, seen through small clips.
#[test]
fn tet_rasteriser_matches_per_pixel_rasteriser_at_extreme_coordinates() {
    let max = 1i64 << 30;
    let mut rng = Rng::new(29);
    let mut total = [0usize; 4];
    for it in 0..400 {
        let near = |rng: &mut Rng| rng.int(200 * SUBPIXEL as u64) - 100 * SUBPIXEL;
        let q: [[i64; 2]; 4] = std::array::from_fn(|_| match it % 4 {
            // Anywhere in the range, on its ends, or near the clip.
            0 => std::array::from_fn(|_| rng.int(2 * max as u64 + 1) - max),
            1 => std::array::from_fn(|_| [-max, max][rng.int(2) as usize]),
            2 => std::array::from_fn(|_| near(&mut rng)),
            // Near the clip across, at an end along: edges as steep as the range allows
            // (|Δx/Δy| up to 2³¹ snapped units), whose row-to-row step needs every bit.
            _ => {
                let end = [-max, max][rng.int(2) as usize];
                if rng.int(2) == 0 {
                    [near(&mut rng), end]
                } else {
                    [end, near(&mut rng)]
                }
            }
        });
        let v = q.map(|q| ProjVertex {
            q,
            ..Default::default()
        });
        let g = FanGeometry::new(q, &classify(&v, false, 1.0));
        let (x, y) = (rng.int(60) - 30, rng.int(60) - 30);
        for clip in [[x, y, x + 24, y + 24], [-3, -3, 3, 3]] {
            let mut want = Vec::new();
            raster_fan(&g, clip, |f| want.push(f));
            let mut got = Vec::new();
            if let Some(r) = TetRaster::new(g.case, &q, clip) {
                tet_raster::assert_spans_are_rows(r);
                r.fragments(|f| got.push(f));
            }
            want.sort_by_key(|f: &Fragment| (f.j, f.i));
            assert_eq!(got.len(), want.len(), "{q:?} clip {clip:?}");
            for (a, b) in got.iter().zip(&want) {
                assert_eq!((a.i, a.j, a.tri), (b.i, b.j, b.tri), "{q:?} clip {clip:?}");
            }
            total[it % 4] += got.len();
        }
    }
    // Every kind of tet covers centres of the clips.
    assert!(total.iter().all(|&n| n > 1000), "{total:?}");
}
