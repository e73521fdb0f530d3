//! Turning lattices into irregular meshes without a mesher: graded spacing, curvilinear warps
//! (orientation-preserving maps of the parameter box), orientation-preserving vertex jitter.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use algorithms::mesh::signed_volume6;

/// Geometric grading of `[0, 1]` onto itself: with `n` cells, cell sizes grow geometrically
/// from the start to the end of the interval, the last `ratio` times the first.
/// `ratio = 1` is uniform.
pub fn graded(t: f64, ratio: f64) -> f64 {
    if (ratio - 1.0).abs() < 1e-12 {
        return t;
    }
    (ratio.powf(t) - 1.0) / (ratio - 1.0)
}

/// Symmetric grading of `[0, 1]`: finest at the middle, cells at the ends `ratio` times larger.
pub fn graded_middle(t: f64, ratio: f64) -> f64 {
    if t < 0.5 {
        0.5 - 0.5 * graded(1.0 - 2.0 * t, ratio)
    } else {
        0.5 + 0.5 * graded(2.0 * t - 1.0, ratio)
    }
}

/// Grid coordinates `g(i / cells)` for `i = 0..=cells`.
pub fn coords(cells: usize, g: impl Fn(f64) -> f64) -> Vec<f64> {
    (0..=cells).map(|i| g(i as f64 / cells as f64)).collect()
}

/// A smooth curvilinear warp of `[-1, 1]³`: `p + amp·(sin πy sin πz, sin πz sin πx, sin πx sin πy)`
/// (one-to-one and orientation-preserving for `amp < 1/(2π)`).
pub fn sine_warp(p: DVec3, amp: f64) -> DVec3 {
    let (sx, sy, sz) = ((PI * p.x).sin(), (PI * p.y).sin(), (PI * p.z).sin());
    p + amp * DVec3::new(sy * sz, sz * sx, sx * sy)
}

/// Maps the square `[-1, 1]²` onto the unit disk along rays from the centre
/// (`q ↦ q·‖q‖∞/‖q‖₂`): squares around the centre become circles.
pub fn square_to_disk(q: DVec2) -> DVec2 {
    let l2 = q.length();
    if l2 == 0.0 {
        return q;
    }
    q * (q.x.abs().max(q.y.abs()) / l2)
}

/// Maps the cube `[-1, 1]³` onto the unit ball along rays from the centre
/// (`p ↦ p·‖p‖∞/‖p‖₂`): cube shells become spherical shells.
pub fn cube_to_ball(p: DVec3) -> DVec3 {
    let l2 = p.length();
    if l2 == 0.0 {
        return p;
    }
    p * (p.abs().max_element() / l2)
}

/// A spherical shell from the cube shell `a ≤ ‖p‖∞ ≤ 1`: the cube of half-size `t` goes to
/// the sphere of radius `r_in + (t − a)/(1 − a)·(r_out − r_in)`.
pub fn cube_shell_to_sphere_shell(p: DVec3, a: f64, r_in: f64, r_out: f64) -> DVec3 {
    let t = p.abs().max_element();
    let r = r_in + (t - a) / (1.0 - a) * (r_out - r_in);
    p.normalize_or_zero() * r
}

/// A solid torus (ring radius `big_r`, tube radius `small_r`, axis z) from the parameter box:
/// `u ∈ [0, 1)` around the ring (periodic), `(v, w) ∈ [-1, 1]²` across the tube.
pub fn torus(u: f64, v: f64, w: f64, big_r: f64, small_r: f64) -> DVec3 {
    let d = square_to_disk(DVec2::new(v, w)) * small_r;
    let a = 2.0 * PI * u;
    let rr = big_r + d.x;
    DVec3::new(rr * a.cos(), rr * a.sin(), d.y)
}

/// An annular (O-grid) region around the z axis: `u ∈ [0, 1)` the angle (periodic, or a
/// fraction `sweep` of the full turn), `v ∈ [0, 1]` from radius `r_in` to `r_out`, `w` is z.
pub fn annulus(u: f64, v: f64, w: f64, r_in: f64, r_out: f64, sweep: f64) -> DVec3 {
    let a = 2.0 * PI * sweep * u;
    let r = r_in + v * (r_out - r_in);
    DVec3::new(r * a.cos(), r * a.sin(), w)
}

/// SplitMix64: a well-mixed 64-bit hash, used for per-vertex random numbers that do not depend
/// on the order (or thread) in which vertices are visited.
#[inline]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A uniform number in `[-1, 1)` from (seed, index, stream).
#[inline]
pub fn hash_unit(seed: u64, index: u64, stream: u64) -> f64 {
    let h = splitmix64(splitmix64(seed ^ stream.wrapping_mul(0x632b_e59b_d9b4_e019)) ^ index);
    (h >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Moves each vertex with `movable[v]` by up to `amount` times the length of its shortest edge
/// (a uniform random offset in a cube, from `seed`), keeping every tet positively oriented:
/// a tet whose volume would drop below `min_ratio` (e.g. 0.2) of its volume before the jitter
/// has its vertices put back, repeatedly until no such tet is left. Tets that were not
/// positive before are ignored. Deterministic for a seed (independent of thread count).
/// Returns the number of vertices moved.
pub fn jitter(
    positions: &mut [DVec3],
    tets: &[[u32; 4]],
    movable: &[bool],
    amount: f64,
    min_ratio: f64,
    seed: u64,
) -> usize {
    let n = positions.len();
    let mut shortest = vec![f64::INFINITY; n];
    for t in tets {
        for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
            let (va, vb) = (t[a] as usize, t[b] as usize);
            let l = positions[va].distance(positions[vb]);
            shortest[va] = shortest[va].min(l);
            shortest[vb] = shortest[vb].min(l);
        }
    }
    let mut offset: Vec<DVec3> = (0..n)
        .into_par_iter()
        .map(|v| {
            if !movable[v] || !shortest[v].is_finite() {
                return DVec3::ZERO;
            }
            let r = DVec3::new(
                hash_unit(seed, v as u64, 1),
                hash_unit(seed, v as u64, 2),
                hash_unit(seed, v as u64, 3),
            );
            r * (amount * shortest[v])
        })
        .collect();
    let vol = |p: &dyn Fn(u32) -> DVec3, t: &[u32; 4]| signed_volume6(t.map(p));
    let before: Vec<f64> = tets
        .par_iter()
        .map(|t| vol(&|v| positions[v as usize], t))
        .collect();
    loop {
        let bad: Vec<usize> = (0..tets.len())
            .into_par_iter()
            .filter(|&i| {
                let t = &tets[i];
                if before[i] <= 0.0 || t.iter().all(|&v| offset[v as usize] == DVec3::ZERO) {
                    return false;
                }
                vol(&|v| positions[v as usize] + offset[v as usize], t) < min_ratio * before[i]
            })
            .collect();
        if bad.is_empty() {
            break;
        }
        for i in bad {
            for &v in &tets[i] {
                offset[v as usize] = DVec3::ZERO;
            }
        }
    }
    positions
        .par_iter_mut()
        .zip(offset.par_iter())
        .for_each(|(p, o)| *p += *o);
    offset.iter().filter(|o| **o != DVec3::ZERO).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradings() {
        let c = coords(10, |t| graded(t, 100.0));
        assert_eq!(c[0], 0.0);
        assert!((c[10] - 1.0).abs() < 1e-12);
        let (first, last) = (c[1] - c[0], c[10] - c[9]);
        assert!(((last / first) - 100f64.powf(0.9)).abs() < 1e-6 * last / first);
        let m = coords(10, |t| graded_middle(t, 100.0));
        assert!((m[5] - 0.5).abs() < 1e-12 && m[0].abs() < 1e-12 && (m[10] - 1.0).abs() < 1e-12);
        assert!(m[1] - m[0] > 10.0 * (m[5] - m[4]));
    }

    #[test]
    fn maps() {
        assert!((square_to_disk(DVec2::new(1.0, 1.0)).length() - 1.0).abs() < 1e-12);
        assert!((cube_to_ball(DVec3::new(0.5, -0.5, 0.2)).length() - 0.5).abs() < 1e-12);
        let p = cube_shell_to_sphere_shell(DVec3::new(0.5, 0.5, 0.5), 0.5, 0.3, 1.0);
        assert!((p.length() - 0.3).abs() < 1e-12);
        assert!((torus(0.25, 0.0, 0.0, 1.0, 0.3) - DVec3::Y).length() < 1e-12);
        let h: Vec<f64> = (0..1000).map(|i| hash_unit(1, i, 0)).collect();
        assert!(h.iter().all(|x| (-1.0..1.0).contains(x)));
        let mean = h.iter().sum::<f64>() / 1000.0;
        assert!(mean.abs() < 0.1);
    }
}
