//! Tests of the visibility sorts on small generated meshes.

use glam::DVec3;

use super::bucket::slab;
use super::centroid::farthest_first;
use super::radix::{radix_sort_hi32, radix_sort_into};
use super::*;
use crate::camera::{fibonacci_views, Camera, Projection, View};
use crate::io::split::{hex_corner, hex_split_pattern};
use crate::io::Split;

/// A grid of n[0]×n[1]×n[2] unit cubes with corner at the origin, 6 Kuhn tets per cube
/// (conforming), interior vertices moved by up to ±`jitter` per axis (deterministic), cubes for
/// which `keep(i, j, k)` is false left out.
fn kuhn_grid(n: [usize; 3], jitter: f64, keep: impl Fn(usize, usize, usize) -> bool) -> Mesh {
    let idx = |i: usize, j: usize, k: usize| (i + (n[0] + 1) * (j + (n[1] + 1) * k)) as u32;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = || {
        // splitmix64 → [-1, 1)
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    let mut pos = Vec::new();
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                let mut p = DVec3::new(i as f64, j as f64, k as f64);
                let interior = i > 0 && i < n[0] && j > 0 && j < n[1] && k > 0 && k < n[2];
                if interior && jitter > 0.0 {
                    p += jitter * DVec3::new(rnd(), rnd(), rnd());
                }
                pos.push(p);
            }
        }
    }
    let mut tets = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                if !keep(i, j, k) {
                    continue;
                }
                let c: [u32; 8] = std::array::from_fn(|q| {
                    let [x, y, z] = hex_corner(q);
                    idx(i + x, j + y, k + z)
                });
                for t in hex_split_pattern(Split::Six, false) {
                    tets.push(t.map(|v| c[v]));
                }
            }
        }
    }
    let s = vec![0.0; pos.len()];
    Mesh::with_scalars("grid", pos, tets, "s", s).unwrap()
}

fn camera(mesh: &Mesh, view: View, projection: Projection) -> Camera {
    Camera::new(&mesh.bbox(), view, projection, 64, 64)
}

fn run(sort: &mut dyn Sort, mesh: &Mesh, cam: &Camera) -> (Vec<u32>, SortStats) {
    let mut order = Vec::new();
    let stats = sort.sort(mesh, cam, &mut order).unwrap();
    assert_permutation(&order, mesh.num_tets(), &sort.name());
    (order, stats)
}

fn assert_permutation(order: &[u32], n: usize, what: &str) {
    assert_eq!(order.len(), n, "{what}: length");
    let mut seen = vec![false; n];
    for &t in order {
        assert!(!seen[t as usize], "{what}: tet {t} twice");
        seen[t as usize] = true;
    }
}

fn prepared(name: &str, mesh: &Mesh) -> Box<dyn Sort> {
    let mut s = make(name).unwrap();
    s.prepare(mesh).unwrap();
    s
}

#[test]
fn names_and_bad_names() {
    for &n in SORTS {
        assert_eq!(make(n).unwrap().name(), n);
    }
    assert_eq!(make("bucket:20").unwrap().name(), "bucket");
    assert_eq!(make("bucket:1").unwrap().name(), "bucket:1");
    assert_eq!(make("bucket:4096").unwrap().name(), "bucket:4096");
    for bad in [
        "bucket:0",
        "bucket:4097",
        "bucket:x",
        "bucket:",
        "quick",
        "",
    ] {
        let e = make(bad).err().expect(bad);
        assert!(matches!(e, Error::Input(_)), "{bad}: {e}");
        if bad == "quick" {
            assert!(
                e.to_string().contains("centroid-radix, bucket, mpvonc"),
                "{e}"
            );
        }
    }
}

#[test]
fn every_sort_returns_a_permutation() {
    let convex = kuhn_grid([4, 3, 3], 0.1, |_, _, _| true);
    let l_shape = kuhn_grid([4, 3, 3], 0.1, |i, j, _| i < 2 || j < 1);
    let names = [
        "centroid",
        "centroid-par",
        "centroid-radix",
        "bucket",
        "bucket:1",
        "bucket:4096",
        "mpvonc",
    ];
    for mesh in [&convex, &l_shape] {
        for name in names {
            let mut s = prepared(name, mesh);
            for view in fibonacci_views(7) {
                for proj in [Projection::Ortho, Projection::Persp] {
                    run(s.as_mut(), mesh, &camera(mesh, view, proj));
                }
            }
        }
    }
    // Sorting another mesh than the prepared one is refused, not a panic.
    let mut s = prepared("mpvonc", &convex);
    let cam = camera(&l_shape, View::default(), Projection::Ortho);
    assert!(s.sort(&l_shape, &cam, &mut Vec::new()).is_err());
}

#[test]
fn key_order_is_total_with_ties_and_signed_zeros() {
    let keys = [
        0.0f32,
        -0.0,
        1.5,
        -1.5,
        0.0,
        -0.0,
        1.5,
        f32::MIN_POSITIVE / 4.0,
        -f32::MIN_POSITIVE / 4.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        3.0e-39,
        1.5,
        -7.25,
        f32::MAX,
        -f32::MAX,
    ];
    // Expected: descending total order, ties by index.
    let mut pairs: Vec<(f32, u32)> = keys
        .iter()
        .enumerate()
        .map(|(i, &k)| (k, i as u32))
        .collect();
    pairs.sort_unstable_by(farthest_first);
    let std_order: Vec<u32> = pairs.iter().map(|p| p.1).collect();
    assert_eq!(&std_order[..2], &[9, 14]);
    // +0.0 (indices 0, 4) before -0.0 (1, 5).
    let p = |t: u32| std_order.iter().position(|&x| x == t).unwrap();
    assert!(p(0) < p(4) && p(4) < p(1) && p(1) < p(5));
    assert!(p(2) < p(6) && p(6) < p(12));
    let mut packed: Vec<u64> = keys
        .iter()
        .enumerate()
        .map(|(i, &k)| ((desc_bits(k) as u64) << 32) | i as u64)
        .collect();
    radix_sort_hi32(&mut packed, &mut Vec::new());
    let radix_order: Vec<u32> = packed.iter().map(|&x| x as u32).collect();
    assert_eq!(radix_order, std_order);
    let mut via_u64 = Vec::new();
    sort_desc_by_key(
        keys.iter().enumerate().map(|(i, &k)| (i as u32, k)),
        &mut via_u64,
    );
    assert_eq!(via_u64, std_order);
    // Random keys with many repeats, radix against std.
    let mut x = 12345u32;
    let keys: Vec<f32> = (0..5000)
        .map(|_| {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            ((x >> 20) as f32 - 2048.0) * 0.125
        })
        .collect();
    let mut pairs: Vec<(f32, u32)> = keys
        .iter()
        .enumerate()
        .map(|(i, &k)| (k, i as u32))
        .collect();
    pairs.sort_unstable_by(farthest_first);
    let mut packed: Vec<u64> = keys
        .iter()
        .enumerate()
        .map(|(i, &k)| ((desc_bits(k) as u64) << 32) | i as u64)
        .collect();
    radix_sort_hi32(&mut packed, &mut Vec::new());
    assert!(pairs.iter().zip(&packed).all(|(p, &q)| p.1 == q as u32));
}

#[test]
fn centroid_sorts_agree_exactly() {
    // Unjittered, integer coordinates, odd nz: many equal keys, and at view (0, 0) keys of
    // +0.0 and -0.0 side by side.
    let mesh = kuhn_grid([4, 4, 3], 0.0, |_, _, _| true);
    let mut sorts: Vec<Box<dyn Sort>> = ["centroid", "centroid-par", "centroid-radix"]
        .iter()
        .map(|n| prepared(n, &mesh))
        .collect();
    let cents = centroids(&mesh);
    let mut views = fibonacci_views(50);
    views.push(View::new(0.0, 0.0));
    views.push(View::new(90.0, 0.0));
    for proj in [Projection::Ortho, Projection::Persp] {
        for &view in &views {
            let cam = camera(&mesh, view, proj);
            let (a, _) = run(sorts[0].as_mut(), &mesh, &cam);
            let (b, _) = run(sorts[1].as_mut(), &mesh, &cam);
            let (c, _) = run(sorts[2].as_mut(), &mesh, &cam);
            assert_eq!(a, b, "{view:?} {proj:?}");
            assert_eq!(a, c, "{view:?} {proj:?}");
            // Farthest first, ties by index.
            let kf = KeyFn::for_camera(&cam);
            for w in a.windows(2) {
                let (k0, k1) = (kf.key(&cents[w[0] as usize]), kf.key(&cents[w[1] as usize]));
                assert!(k0.total_cmp(&k1).is_gt() || (k0.to_bits() == k1.to_bits() && w[0] < w[1]));
            }
        }
    }
    // The test does meet signed zeros and ties.
    let cam = camera(&mesh, View::new(0.0, 0.0), Projection::Ortho);
    let kf = KeyFn::for_camera(&cam);
    let keys: Vec<f32> = cents.iter().map(|c| kf.key(c)).collect();
    assert!(keys.iter().any(|k| k.to_bits() == 0));
    assert!(keys.iter().any(|k| k.to_bits() == 0x8000_0000));
}

#[test]
fn bucket_is_index_order_with_one_slab_and_centroid_order_at_slab_granularity() {
    let mesh = kuhn_grid([5, 4, 3], 0.2, |_, _, _| true);
    let n = mesh.num_tets();
    let mut one = prepared("bucket:1", &mesh);
    let mut centroid = prepared("centroid", &mesh);
    let cents = centroids(&mesh);
    for view in fibonacci_views(10) {
        for proj in [Projection::Ortho, Projection::Persp] {
            let cam = camera(&mesh, view, proj);
            let (o, _) = run(one.as_mut(), &mesh, &cam);
            assert!(o.iter().enumerate().all(|(i, &t)| i == t as usize));
            let kf = KeyFn::Axis(f32x3(cam.forward));
            let keys: Vec<f32> = cents.iter().map(|c| kf.key(c)).collect();
            let lo = keys.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = keys.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            for slabs in [2, 20, 4096] {
                let mut b = prepared(&format!("bucket:{slabs}"), &mesh);
                let (order, _) = run(b.as_mut(), &mesh, &cam);
                let sl = |t: u32| slab(keys[t as usize], lo, hi, slabs);
                // Slabs back to front, index order inside a slab.
                assert!(order
                    .windows(2)
                    .all(|w| (sl(w[0]), w[0]) < (sl(w[1]), w[1])));
                assert_eq!(sl(order[0]), 0);
                if proj == Projection::Ortho {
                    // Centroid order regrouped by slab (stable) is the bucket order.
                    let (mut c, _) = run(centroid.as_mut(), &mesh, &cam);
                    assert!(c.windows(2).all(|w| sl(w[0]) <= sl(w[1])));
                    c.sort_by_key(|&t| (sl(t), t));
                    assert_eq!(c, order);
                }
            }
        }
    }
    assert!(n > 300);
}

#[test]
fn mpvonc_is_a_visibility_order_on_a_convex_grid() {
    let mesh = kuhn_grid([6, 5, 4], 0.15, |_, _, _| true);
    assert!(mesh.is_convex());
    assert_eq!(mesh.negative_tets() + mesh.degenerate_tets(), 0);
    let mut s = prepared("mpvonc", &mesh);
    let mut centroid = prepared("centroid", &mesh);
    let mut centroid_bad = 0;
    for proj in [Projection::Ortho, Projection::Persp] {
        for view in fibonacci_views(50) {
            let cam = camera(&mesh, view, proj);
            let (order, stats) = run(s.as_mut(), &mesh, &cam);
            assert_eq!(
                (stats.cycles, stats.cells_in_cycles, stats.forced),
                (0, 0, 0),
                "{view:?} {proj:?}"
            );
            assert!(stats.sources > 0 && stats.edges > 0);
            assert_eq!(
                face_violations(&mesh, &cam, &order, 1e-5),
                0,
                "{view:?} {proj:?}"
            );
            let (c, _) = run(centroid.as_mut(), &mesh, &cam);
            centroid_bad += face_violations(&mesh, &cam, &c, 1e-5);
        }
    }
    // The check has teeth: the centroid order breaks some face constraints on this grid.
    assert!(centroid_bad > 0);
}

#[test]
fn mpvonc_honours_face_constraints_on_a_non_convex_mesh() {
    // A U: the middle of the top removed.
    let mesh = kuhn_grid([6, 4, 3], 0.1, |i, j, _| j < 2 || !(2..4).contains(&i));
    assert!(!mesh.is_convex());
    let mut s = prepared("mpvonc", &mesh);
    for proj in [Projection::Ortho, Projection::Persp] {
        for view in fibonacci_views(20) {
            let cam = camera(&mesh, view, proj);
            let (order, stats) = run(s.as_mut(), &mesh, &cam);
            assert_eq!(stats.cycles, 0);
            assert_eq!(
                face_violations(&mesh, &cam, &order, 1e-5),
                0,
                "{view:?} {proj:?}"
            );
        }
    }
}

#[test]
fn mpvonc_skips_faces_parallel_to_the_view() {
    // Unjittered grid seen along +z: the faces in planes x = const, y = const and the diagonal
    // planes containing z are parallel to the view direction and give no constraint.
    let mesh = kuhn_grid([2, 2, 2], 0.0, |_, _, _| true);
    let mut s = prepared("mpvonc", &mesh);
    let cam = camera(&mesh, View::new(0.0, 0.0), Projection::Ortho);
    let (order, stats) = run(s.as_mut(), &mesh, &cam);
    assert!(stats.unconstrained_faces > 0);
    assert_eq!(stats.cycles, 0);
    assert_eq!(face_violations(&mesh, &cam, &order, 1e-5), 0);
}

#[test]
fn mpvonc_reports_a_forced_cycle_and_still_emits_every_tet() {
    // Three tets around the edge PQ (along y) with apexes at angles 0°, 60°, 120° about it: the
    // third tet overlaps the other two, so its two shared faces have both tets on one side; the
    // middle apex lies far out, so the faces are oriented away from the lower-index tet, and
    // views from azimuths in (120°, 180°) orient the three faces into a cycle. A fourth tet
    // glued to the first lies outside the cycle.
    let at = |deg: f64, y: f64| {
        let a = deg.to_radians();
        DVec3::new(a.sin(), y, a.cos())
    };
    let pos = vec![
        DVec3::new(0.0, -1.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        at(0.0, 0.0),
        at(60.0, 0.0) * 3.0,
        at(120.0, 0.0),
        DVec3::new(1.0, 1.0, 2.0),
    ];
    let tets = vec![[0, 1, 2, 3], [0, 1, 3, 4], [0, 1, 4, 2], [1, 2, 3, 5]];
    let mesh = Mesh::with_scalars("cycle", pos, tets, "s", vec![0.0; 6]).unwrap();
    let mut s = prepared("mpvonc", &mesh);
    let mut found = 0;
    for proj in [Projection::Ortho, Projection::Persp] {
        for k in 0..36 {
            let cam = camera(&mesh, View::new(k as f64 * 10.0 + 5.0, 3.0), proj);
            let (_, stats) = run(s.as_mut(), &mesh, &cam);
            if stats.cycles > 0 {
                assert_eq!(
                    (stats.cycles, stats.cells_in_cycles),
                    (1, 3),
                    "{k} {proj:?}"
                );
                assert!(stats.forced >= 1);
                found += 1;
            }
        }
    }
    assert!(
        found >= 8,
        "only {found} views oriented the faces into a cycle"
    );
}

/// Throughput on a 600K-tet Kuhn grid, release only:
/// `cargo test --release -p tetbench-algorithms --lib sort::tests::throughput -- --ignored --nocapture`
#[test]
#[ignore]
fn throughput() {
    let t0 = std::time::Instant::now();
    let mesh = kuhn_grid([50, 50, 40], 0.1, |_, _, _| true);
    let n = mesh.num_tets();
    println!("mesh: {n} tets, built in {:.2?}", t0.elapsed());
    let views = fibonacci_views(7);
    for name in [
        "centroid",
        "centroid-par",
        "centroid-radix",
        "bucket",
        "mpvonc",
    ] {
        let t = std::time::Instant::now();
        let mut s = prepared(name, &mesh);
        let setup = t.elapsed();
        for proj in [Projection::Ortho, Projection::Persp] {
            let mut order = Vec::new();
            let mut times = Vec::new();
            let mut cycles = 0;
            for &view in &views {
                let cam = camera(&mesh, view, proj);
                let t = std::time::Instant::now();
                let st = s.sort(&mesh, &cam, &mut order).unwrap();
                times.push(t.elapsed().as_secs_f64());
                cycles += st.cycles;
            }
            times.sort_by(f64::total_cmp);
            let med = times[times.len() / 2];
            println!(
                "{name:>15} {:>5}: median {:7.2} ms over {} views = {:6.1} M tets/s (prepare {:.0?}, cycles {cycles})",
                proj.name(),
                med * 1e3,
                times.len(),
                n as f64 / med / 1e6,
                setup
            );
        }
    }
}

/// The order the radix sort writes from its last moving pass is the sorted pairs' tets: with
/// keys that differ in every digit, in the first digit only, in the last only (so that the
/// first or the last pass writes it), and in none (no pass moves: the tets in index order).
#[test]
fn radix_order_from_the_last_pass_is_the_sorted_pairs() {
    let mut x = 2024u32;
    let mut rnd = move || {
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        x
    };
    // Per case, the key bits kept from a random number and the constant the rest is set to.
    let cases = [
        ("every digit", u32::MAX, 0),
        ("first digit", 0x7ff, 0x5555_5000),
        ("last digit", 0xffc0_0000, 0x0012_3456),
        ("no digit", 0, 0x1234_5678),
    ];
    // Sizes that leave the counting pass's sets of four a remainder of 0, 1, 2 and 3 keys.
    for (name, mask, rest) in cases {
        for n in [0u64, 1, 3, 2998, 2999, 3000] {
            let packed: Vec<u64> = (0..n)
                .map(|i| ((((rnd() & mask) | rest) as u64) << 32) | i)
                .collect();
            let mut want = packed.clone();
            want.sort_unstable();
            let want: Vec<u32> = want.iter().map(|&p| p as u32).collect();
            let (mut v, mut order) = (packed, vec![7u32; 5]);
            radix_sort_into(&mut v, &mut Vec::new(), Some(&mut order));
            assert_eq!(order, want, "{name}, {n} keys");
        }
    }
}
