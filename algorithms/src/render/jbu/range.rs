//! The range term's distance between two depth-layer vectors (eq. (4) of Callahan & Silva,
//! extended to layer vectors whose crossings do not pair up one to one).
//!
//! A ray's boundary crossings come in entry/exit pairs. Across the image a pair is born with
//! zero separation where the ray grazes the boundary (an oblique silhouette, the rim of a
//! cavity, a thin slit between two parts), and there the image is continuous even though the
//! layer vectors of two neighbouring pixels no longer match index by index. So the distance is
//! the cheapest *alignment* of the two sorted layer lists: matched layers cost their squared
//! difference, and a pair of adjacent layers that the other side lacks costs its own squared
//! separation. A thin slab (separation ≪ σ_r) is thus nearly free and a thick one is a depth
//! edge, as a silhouette in front of the rest of the mesh should be. Only the first `K`
//! crossings are kept: when a side has more, the other side's deeper layers may match its
//! unkept ones and are not charged.

/// Squared range distance between the pixel's layers extrapolated to a sample (`pred`; `rp`
/// unextrapolated, used for its pairs' separations) and the sample's layers (`rq`), given both
/// sides' numbers of boundary crossings `np` and `nq` (of which the first `K` are kept).
///
/// With equal counts it is first the squared Euclidean distance of eq. (4) over the kept
/// layers (missing ones are 1.0 on both sides); only where that exceeds `flat` (a sample the
/// filter would treat as across an edge) is the cheapest [`align`]ment searched, and the
/// smaller is taken. With different counts it is the alignment's cost; where none exists (an
/// odd difference: a ray through an edge or vertex of the boundary) the padded vectors are
/// compared as they are.
#[inline(always)]
pub(super) fn range_d2<const K: usize>(
    pred: &[f32; K],
    rp: &[f32; K],
    np: usize,
    rq: &[f32; 4],
    nq: usize,
    flat: f32,
) -> f32 {
    let plain = || {
        let mut d2 = 0.0;
        for c in 0..K {
            let e = pred[c] - rq[c];
            d2 += e * e;
        }
        d2
    };
    if np == nq {
        return refine_equal::<K>(plain(), flat, pred, rp, np, rq);
    }
    let d2 = align::<K>(pred, rp, np, rq, nq);
    if d2.is_finite() {
        d2
    } else {
        plain()
    }
}

/// [`range_d2`] for equal counts given the plain distance `d2` (the fast path computes it four
/// samples at once).
#[inline(always)]
pub(super) fn refine_equal<const K: usize>(
    d2: f32,
    flat: f32,
    pred: &[f32; K],
    rp: &[f32; K],
    n: usize,
    rq: &[f32; 4],
) -> f32 {
    if d2 <= flat || n < 2 {
        return d2;
    }
    if n <= K {
        // With equal counts and every crossing kept, an alignment other than the plain one
        // drops at least one pair on each side: it cannot cost less than the two closest pairs.
        let close = |v: &[f32]| {
            (1..n)
                .map(|c| (v[c] - v[c - 1]) * (v[c] - v[c - 1]))
                .fold(f32::INFINITY, f32::min)
        };
        if d2 <= close(rp) + close(rq) {
            return d2;
        }
    }
    d2.min(align::<K>(pred, rp, n, rq, n))
}

/// The cheapest alignment of the pixel's kept layers `a` (pair separations from `ap`) with the
/// sample's `b` (counts `na`, `nb`, of which `min(·, K)` are kept): a small dynamic programme
/// over (i, j) = layers of each side consumed, whose steps are a match (cost (a − b)²) or a
/// pair of adjacent layers on one side only (cost its separation squared). A side with more
/// than `K` crossings may leave its last kept layer unmatched (its partner is not kept) and
/// the other side's deeper layers (those at or beyond that last kept one) unmatched, for free.
/// `f32::INFINITY` when no alignment exists.
#[inline(never)]
pub(super) fn align<const K: usize>(
    a: &[f32; K],
    ap: &[f32; K],
    na: usize,
    b: &[f32; 4],
    nb: usize,
) -> f32 {
    let (ka, kb) = (na.min(K), nb.min(K));
    let mut d = [[f32::INFINITY; 5]; 5];
    d[0][0] = 0.0;
    for i in 0..=ka {
        for j in 0..=kb {
            let mut best = d[i][j];
            if i > 0 && j > 0 {
                let e = a[i - 1] - b[j - 1];
                best = best.min(d[i - 1][j - 1] + e * e);
            }
            if i > 1 {
                let s = ap[i - 1] - ap[i - 2];
                best = best.min(d[i - 2][j] + s * s);
            }
            if j > 1 {
                let s = b[j - 1] - b[j - 2];
                best = best.min(d[i][j - 2] + s * s);
            }
            d[i][j] = best;
        }
    }
    let mut best = d[ka][kb];
    if na > K && ka > 0 {
        // a's last kept layer may pair with one of its unkept crossings, and b's layers from
        // j on, if no nearer than it, may match a's unkept ones.
        for j in 0..=kb {
            if j == kb || b[j] >= a[ka - 1] {
                best = best.min(d[ka][j]).min(d[ka - 1][j]);
            }
        }
    }
    if nb > K && kb > 0 {
        for i in 0..=ka {
            if i == ka || a[i] >= b[kb - 1] {
                best = best.min(d[i][kb]).min(d[i][kb - 1]);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d2(p: [f32; 4], np: usize, q: [f32; 4], nq: usize) -> f32 {
        range_d2::<4>(&p, &p, np, &q, nq, 1e-4)
    }

    #[test]
    fn equal_layers_cost_nothing_and_plain_distance_is_kept_when_flat() {
        let p = [0.3, 0.5, 0.7, 0.9];
        assert_eq!(d2(p, 4, p, 4), 0.0);
        let q = [0.301, 0.5, 0.7, 0.9];
        assert!((d2(p, 4, q, 4) - 1e-6).abs() < 1e-9);
    }

    #[test]
    fn a_thin_pair_on_one_side_is_nearly_free_and_a_thick_one_is_an_edge() {
        // Pixel: front, thin slit (0.40, 0.401), back; sample: front, back.
        let p = [0.3, 0.40, 0.401, 0.9];
        let q = [0.3, 0.9, 1.0, 1.0];
        assert!(d2(p, 4, q, 2) < 2e-6);
        // A thick part in front of the sample's layers.
        let p = [0.1, 0.25, 0.3, 0.9];
        assert!(d2(p, 4, q, 2) > 0.02);
    }

    #[test]
    fn pairs_vanishing_on_both_sides_with_equal_counts() {
        // The comb case: a thin slit in front on the pixel, another one behind on the sample.
        let p = [0.346, 0.385, 0.394, 0.441];
        let q = [0.345, 0.441, 0.582, 0.589];
        let plain: f32 = p.iter().zip(&q).map(|(a, b)| (a - b) * (a - b)).sum();
        let d = d2(p, 6, q, 6);
        assert!(d < 1e-3 && d < plain / 10.0, "{d} vs plain {plain}");
    }

    #[test]
    fn unkept_crossings_leave_the_deeper_layers_free() {
        // Pixel: 6 crossings (front, wing pair, fuselage entry) kept 4; sample beside the wing.
        let p = [0.3, 0.35, 0.36, 0.5];
        let q = [0.3, 0.5, 0.6, 0.9];
        assert!(d2(p, 6, q, 4) < 1e-3);
        // The deeper layers must lie at or beyond the last kept one to be free.
        let q = [0.3, 0.32, 0.33, 0.34];
        assert!(d2(p, 6, q, 4) > 1e-3);
    }

    #[test]
    fn background_beside_two_pairs_and_odd_differences() {
        let bg = [1.0; 4];
        let p = [0.3, 0.31, 0.5, 0.52];
        let d = d2(p, 4, bg, 0);
        assert!((d - (0.01f32 * 0.01 + 0.02 * 0.02)).abs() < 1e-7);
        // An odd difference has no alignment: the padded vectors are compared.
        let q = [0.3, 0.31, 0.5, 1.0];
        let plain: f32 = p.iter().zip(&q).map(|(a, b)| (a - b) * (a - b)).sum();
        assert_eq!(d2(p, 4, q, 3), plain);
    }
}
