//! The full pre-integration table over (`s_f`, `s_b`, `l`) that `preint` reads, built from the
//! transfer function with the `exact` integrator.

use rayon::prelude::*;

use super::exact::{integrate_pieces, piece_segment, split_pieces, Piece};
use super::{composite_under, tau_len, valid_input, Segment};
use crate::tf::TransferFunction;

/// Full pre-integration table (Röttger, Kraus & Ertl 2000; Engel, Kraus & Ertl 2001) over
/// (`s_f`, `s_b`, `l`), built from the transfer function with the `exact` integrator. Build one per
/// transfer function (it is immutable).
///
/// **What is stored.** Per node, 4 `f32` channels `[Ĉ_r, Ĉ_g, Ĉ_b, τ̄]`:
/// - `τ̄(s_f, s_b)` = mean extinction along the segment (exact, piecewise-linear integral), so the
///   opacity is recovered exactly as `α = 1 − exp(−τ̄·l)` for any `l` (the optical depth is linear
///   in `l`); this channel does not depend on the `l` node.
/// - `Ĉ = I/α` = the opacity-weighted colour of the exact segment. It is bounded by the colours
///   met, tends to the constant `∫Cτ ds/∫τ ds` as `l → 0` and varies smoothly with `l` (on the
///   scale `1/τ`), so it interpolates far better than `I` itself, whose relative variation is
///   largest for short segments. Where `τ̄ = 0`, `Ĉ` is the mean colour (it is multiplied by
///   `α = 0` anyway).
///
/// A lookup returns `α = −expm1(−τ̄·l)`, `I = Ĉ·α` (trilinear in all four channels).
///
/// **Layout.** `data()[((k·n_s + j)·n_s + i)·4 + c]`: `i` indexes `s_f` (fastest), `j` indexes `s_b`,
/// `k` indexes `l`, `c` the channel; i.e. an RGBA32F 3-D texture of width `n_s` (`s_f`), height
/// `n_s` (`s_b`), depth `n_l` (`l`). [`dims`](Self::dims) = `[n_s, n_s, n_l]`.
///
/// **s axes.** Node `i` is at `s = s_lo + i/(n_s − 1)·(s_hi − s_lo)` with
/// `[s_lo, s_hi] = [min(0, first point s), max(1, last point s)]` clamped to ±1e30
/// ([`TransferFunction::table_domain`], [`s_range`](Self::s_range)), so every transfer-function
/// point lies inside. Scalars outside are clamped to the range (exact only
/// when both ends are on the same side outside, since the TF is constant there).
///
/// **l axis.** Node `k` is at the coordinate `x = k/(n_l − 1)` of the map
/// `x(l) = ln(1 + l/l₀) / ln(1 + l_max/l₀)`, `l₀ = 1e-3`, `l_max = 1` (the diagonal of the bounding
/// box, the longest possible segment): linear below `l₀`, logarithmic above, so consecutive nodes
/// differ by a constant ratio (≈ 12% with 64 nodes) over 1e-3..1 and by ≈ 1.1e-4 below. Lengths
/// beyond `l_max` use the `l_max` node for `Ĉ` (α stays exact).
#[derive(Clone, Debug)]
pub struct PreintTable {
    n_s: usize,
    n_l: usize,
    s_lo: f64,
    s_hi: f64,
    data: Vec<f32>,
}

impl PreintTable {
    pub const DEFAULT_S: usize = 128;
    pub const DEFAULT_L: usize = 64;
    /// `l₀` of the l-axis map.
    pub const L0: f64 = 1e-3;
    /// Largest tabulated `l`.
    pub const L_MAX: f64 = 1.0;

    /// Default resolution 128 × 128 × 64.
    pub fn new(tf: &TransferFunction) -> PreintTable {
        Self::with_size(tf, Self::DEFAULT_S, Self::DEFAULT_L)
    }

    /// `n_s` nodes on each `s` axis and `n_l` on the `l` axis (each raised to at least 2).
    ///
    /// **Build.** The nodes are evenly spaced, so a segment from node `i` to node `j ≠ i` of
    /// length `l` crosses the `d = |j − i|` cells between them, each over length `l/d`, and its
    /// exact integral is the front-to-back composite of those cells' exact integrals (splitting a
    /// linear piece at a node changes nothing). Per plane `k` and per `d` the cells are integrated
    /// once in each direction and every segment of that `d` composited from them: the TF is split
    /// at its points once per cell, so the build costs O(n_l·n_s·(points + n_s)) piece integrals
    /// plus O(n_l·n_s³) composites, not O(n_l·n_s²·points).
    pub fn with_size(tf: &TransferFunction, n_s: usize, n_l: usize) -> PreintTable {
        let (n_s, n_l) = (n_s.max(2), n_l.max(2));
        // Clamped to ±1e30, so the step is finite (±1e308 overflowed it to inf).
        let (s_lo, s_hi) = tf.table_domain();
        let s_at = |i: usize| {
            if i == n_s - 1 {
                s_hi
            } else {
                s_lo + (s_hi - s_lo) * (i as f64 / (n_s - 1) as f64)
            }
        };
        let ls: Vec<f64> = (0..n_l)
            .map(|k| Self::coord_to_l(k as f64 / (n_l - 1) as f64))
            .collect();
        let cells = n_s - 1;
        // Each cell's pieces front to back, walked upwards (`fwd`) and downwards (`bwd`).
        let split = |a: f64, b: f64| {
            let mut v = Vec::new();
            split_pieces(tf, a, b, &mut v);
            v
        };
        let fwd: Vec<Vec<Piece>> = (0..cells).map(|c| split(s_at(c), s_at(c + 1))).collect();
        let bwd: Vec<Vec<Piece>> = (0..cells).map(|c| split(s_at(c + 1), s_at(c))).collect();
        // Per cell: mean extinction and ∫Cτ, ∫C over the cell (per unit share of it), with τ
        // divided by τ_max so that huge extinctions (up to f64::MAX) cannot overflow and
        // subnormal ones are not lost (a reciprocal 1/5e-309 would be inf). Per piece
        // ∫₀¹ τ du = (τ_f + τ_b)/2 and ∫₀¹ Cτ du = (C_f(2τ_f + τ_b) + C_b(τ_f + 2τ_b))/6.
        let max_tau = tf.max_tau();
        let scaled = |t: f64| if max_tau > 0.0 { t / max_tau } else { 0.0 };
        let moments = |pieces: &[Piece]| {
            let (mut tau, mut ct, mut cm) = (0.0, [0.0; 3], [0.0; 3]);
            for p in pieces {
                let (tf_s, tb_s) = (scaled(p.tf), scaled(p.tb));
                tau += p.frac * 0.5 * (tf_s + tb_s);
                for c in 0..3 {
                    ct[c] += p.frac
                        * (p.cf[c] * (2.0 * tf_s + tb_s) + p.cb[c] * (tf_s + 2.0 * tb_s))
                        / 6.0;
                    cm[c] += p.frac * 0.5 * (p.cf[c] + p.cb[c]);
                }
            }
            (tau, ct, cm)
        };
        let cell_moments: Vec<_> = fwd.iter().map(|p| moments(p)).collect();
        // Mean extinction τ̄ and the l → 0 limit c0 of I/α per (i, j), both symmetric in i, j.
        let ends: Vec<(f64, [f64; 3])> = (0..n_s * n_s)
            .into_par_iter()
            .map(|idx| {
                let (i, j) = (idx % n_s, idx / n_s);
                if i == j {
                    let (c, t) = tf.eval(s_at(i));
                    return (t, c);
                }
                let (a, b) = (i.min(j), i.max(j));
                let d = (b - a) as f64;
                let (mut tau_s, mut ct, mut cm) = (0.0, [0.0; 3], [0.0; 3]);
                for (t, ctc, cmc) in &cell_moments[a..b] {
                    tau_s += t / d;
                    for c in 0..3 {
                        ct[c] += ctc[c] / d;
                        cm[c] += cmc[c] / d;
                    }
                }
                let c0 = if tau_s > 0.0 {
                    ct.map(|x| x / tau_s)
                } else {
                    cm
                };
                (tau_s * max_tau, c0)
            })
            .collect();
        let plane = n_s * n_s * 4;
        let mut data = vec![0f32; plane * n_l];
        data.par_chunks_mut(plane).enumerate().for_each(|(k, dst)| {
            let l = ls[k];
            let mut put = |i: usize, j: usize, seg: Segment| {
                let (tau_mean, c0) = ends[j * n_s + i];
                let chat = if seg.alpha > 0.0 {
                    seg.rgb.map(|x| x / seg.alpha)
                } else {
                    c0
                };
                // Ĉ is bounded by the colours met (in [0, 1]); the clamp only catches round-off
                // of subnormal α.
                let chat = if chat.iter().all(|x| x.is_finite()) {
                    chat.map(|x| x.clamp(0.0, 1.0))
                } else {
                    c0
                };
                let e = &mut dst[(j * n_s + i) * 4..(j * n_s + i) * 4 + 4];
                e[..3].copy_from_slice(&chat.map(|x| x as f32));
                // Capped so that f32 interpolation never meets inf − inf (τ·l > ~100 is
                // opaque anyway).
                e[3] = tau_mean.min(1e30) as f32;
            };
            for i in 0..n_s {
                let seg = if l > 0.0 {
                    let (c, t) = tf.eval(s_at(i));
                    piece_segment(c, t, c, t, l)
                } else {
                    Segment::default()
                };
                put(i, i, seg);
            }
            let (mut ef, mut eb) = (
                vec![Segment::default(); cells],
                vec![Segment::default(); cells],
            );
            for d in 1..n_s {
                if l > 0.0 {
                    let lc = l / d as f64;
                    for c in 0..cells {
                        ef[c] = integrate_pieces(&fwd[c], lc);
                        eb[c] = integrate_pieces(&bwd[c], lc);
                    }
                }
                for i in 0..n_s - d {
                    let j = i + d;
                    if l <= 0.0 {
                        put(i, j, Segment::default());
                        put(j, i, Segment::default());
                        continue;
                    }
                    // s_f = s_i < s_b = s_j: cells i..j upwards; and the reverse.
                    let mut up = Segment::default();
                    for seg in &ef[i..j] {
                        composite_under(&mut up, *seg);
                        if up.alpha >= 1.0 {
                            break;
                        }
                    }
                    put(i, j, up);
                    let mut down = Segment::default();
                    for seg in eb[i..j].iter().rev() {
                        composite_under(&mut down, *seg);
                        if down.alpha >= 1.0 {
                            break;
                        }
                    }
                    put(j, i, down);
                }
            }
        });
        PreintTable {
            n_s,
            n_l,
            s_lo,
            s_hi,
            data,
        }
    }

    /// The raw table (layout in the type's documentation).
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// `[n_s (s_f), n_s (s_b), n_l (l)]`, fastest first; 4 channels per node.
    pub fn dims(&self) -> [usize; 3] {
        [self.n_s, self.n_s, self.n_l]
    }

    /// `[s_lo, s_hi]` covered by both `s` axes.
    pub fn s_range(&self) -> [f64; 2] {
        [self.s_lo, self.s_hi]
    }

    /// The l-axis map `x(l) = ln(1 + l/l₀)/ln(1 + l_max/l₀)` (clamped to `[0, 1]`).
    pub fn l_to_coord(l: f64) -> f64 {
        let l = if l.is_nan() {
            0.0
        } else {
            l.clamp(0.0, Self::L_MAX)
        };
        ((l / Self::L0).ln_1p() / (Self::L_MAX / Self::L0).ln_1p()).clamp(0.0, 1.0)
    }

    /// Inverse of [`l_to_coord`](Self::l_to_coord).
    pub fn coord_to_l(x: f64) -> f64 {
        if x >= 1.0 {
            return Self::L_MAX;
        }
        Self::L0 * (x * (Self::L_MAX / Self::L0).ln_1p()).exp_m1()
    }

    /// Trilinear lookup of the four channels, turned into a segment.
    pub fn lookup(&self, sf: f64, sb: f64, l: f64) -> Segment {
        if !valid_input(sf, sb, l) {
            return Segment::default();
        }
        let n_s = self.n_s;
        let scale = (n_s - 1) as f64 / (self.s_hi - self.s_lo);
        let axis = |x: f64, n: usize| -> (usize, f64) {
            let x = x.clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n - 2);
            (i, x - i as f64)
        };
        let (i, ti) = axis((sf - self.s_lo) * scale, n_s);
        let (j, tj) = axis((sb - self.s_lo) * scale, n_s);
        let (k, tk) = axis(Self::l_to_coord(l) * (self.n_l - 1) as f64, self.n_l);
        let d = &self.data;
        let mut v = [0.0f64; 4];
        for (dk, wk) in [(0, 1.0 - tk), (1, tk)] {
            for (dj, wj) in [(0, 1.0 - tj), (1, tj)] {
                for (di, wi) in [(0, 1.0 - ti), (1, ti)] {
                    let w = wk * wj * wi;
                    if w == 0.0 {
                        continue;
                    }
                    let base = (((k + dk) * n_s + j + dj) * n_s + i + di) * 4;
                    for c in 0..4 {
                        v[c] += w * d[base + c] as f64;
                    }
                }
            }
        }
        let alpha = -(-tau_len(v[3], l)).exp_m1();
        Segment {
            rgb: [v[0] * alpha, v[1] * alpha, v[2] * alpha],
            alpha,
        }
    }
}
