//! f32 fast paths of the table-based integrators, for per-fragment use by `cpu-pt`.
//!
//! [`FastIntegrator`] is an enum (no dynamic dispatch; the hot call inlines into the
//! rasterizer's loop) holding f32 copies of what `average`, `partial` and `preint` read:
//! - the transfer function sampled at [`TF_SAMPLES`] points over `[s_lo, s_hi]` =
//!   `[min(0, first point s), max(1, last point s)]`, linearly interpolated (constant beyond the
//!   range, like the TF itself). The TF is piecewise linear, so this is exact but in the one
//!   sample interval around each control point, where the error is at most
//!   `|Δslope|·Δs/4` with `Δs = (s_hi − s_lo)/4095` (`cpu-pt`'s `partial` takes a tet whose
//!   scalars lie on one piece, or on two across one point, from the pieces' lines instead
//!   ([`TfTable::span_over`]), which are the TF there also around the point);
//! - `partial`'s Ψ table ([`PsiTable`], already f32) and `preint`'s [`PreintTable`] (f32);
//! - exp by [`exp_neg`] (2^y by a polynomial; relative error ≤ 2e-6 for x ≤ 20, from rounding
//!   x·log2 e in f32; absolute error ≤ 2e-7).
//!
//! `exact` has no fast path (it is the ground truth and stays in f64). The fast paths agree with
//! the f64 integrators of [`crate::optics`] to ~1e-6 per segment away from TF control points;
//! `cpu_pt`'s tests bound the image difference.

use std::sync::Arc;

use crate::optics::{PreintTable, PsiTable};
use crate::tf::TransferFunction;

mod colour;
mod tf_lanes;
mod tf_lines;
pub(crate) use colour::colour_lanes_n;
pub use colour::{segment_from_colours, shade_colours, ColourBatch};
use tf_lines::pieces;
pub use tf_lines::{TfHinge, TfLine, TfSpan};

/// Samples of the transfer-function table.
pub const TF_SAMPLES: usize = 4096;

/// The transfer function as an f32 table of `[r, g, b, τ]`.
#[derive(Clone, Debug)]
pub struct TfTable {
    lo: f32,
    scale: f32,
    max: f32,
    data: Vec<[f32; 4]>,
    /// The pieces of the TF the table follows as lines, and beside each line the sample
    /// intervals `first..end` it covers (in order, disjoint; an interval with a control point
    /// strictly inside, where the table bends, or with τ capped, is on none).
    lines: Vec<TfLine>,
    runs: Vec<[u32; 2]>,
    /// Entry k: the control point where runs k and k + 1 meet as a hinge (NaN where they
    /// do not).
    joins: Vec<f32>,
}

impl TfTable {
    pub fn new(tf: &TransferFunction, n: usize) -> TfTable {
        let n = n.max(2);
        // Clamped to ±1e30: the step stays finite and the bounds survive f32.
        let (lo, hi) = tf.table_domain();
        let at = |i: usize| {
            if i == n - 1 {
                hi
            } else {
                lo + (hi - lo) * i as f64 / (n - 1) as f64
            }
        };
        let data: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let s = at(i);
                let (c, tau) = tf.eval(s);
                // τ beyond f32 range would interpolate to inf − inf = NaN; any τ·l above ~100 is
                // opaque anyway, so cap it (colours are validated to be finite).
                [
                    c[0] as f32,
                    c[1] as f32,
                    c[2] as f32,
                    tau.min(TAU_MAX) as f32,
                ]
            })
            .collect();
        let (lines, runs, joins) = pieces(tf, n, at);
        TfTable {
            lo: lo as f32,
            scale: ((n - 1) as f64 / (hi - lo)) as f32,
            max: (n - 1) as f32,
            data,
            lines,
            runs,
            joins,
        }
    }

    /// The samples, `[r, g, b, τ]` at `lo + i / scale` (for upload to the GPU).
    pub fn data(&self) -> &[[f32; 4]] {
        &self.data
    }

    /// `(lo, scale)`: sample `i` is at `s = lo + i / scale`.
    pub fn domain(&self) -> (f32, f32) {
        (self.lo, self.scale)
    }

    /// `[r, g, b, τ]` at `s` (finite).
    #[inline(always)]
    pub fn eval(&self, s: f32) -> [f32; 4] {
        let x = ((s - self.lo) * self.scale).clamp(0.0, self.max);
        let i = (x as i32 as usize).min(self.data.len() - 2);
        let t = x - i as f32;
        let (a, b) = (self.data[i], self.data[i + 1]);
        [
            a[0] + (b[0] - a[0]) * t,
            a[1] + (b[1] - a[1]) * t,
            a[2] + (b[2] - a[2]) * t,
            a[3] + (b[3] - a[3]) * t,
        ]
    }
}

/// The largest extinction the f32 table holds.
pub(crate) const TAU_MAX: f64 = 1e30;

/// `exp(−x)` for `x ≥ 0` (a NaN gives a finite value in [0, 1]; +∞ gives ≈ 1e-38): relative
/// error ≤ 2e-6 for x ≤ 20 (the rounding of x·log2 e), absolute ≤ 2e-7; exactly 1 at 0.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    // 2^y, y = −x·log2(e) ∈ [−126, 0], split y = n + f, f ∈ [−0.5, 0.5].
    let y = (-x * std::f32::consts::LOG2_E).max(-126.0);
    // Round to nearest by the 1.5·2^23 trick (f32::round is a libm call on baseline x86-64).
    let t = y + 12_582_912.0;
    let n = t - 12_582_912.0;
    let f = y - n;
    // Cephes exp2f polynomial: 2^f ≈ 1 + f·P(f).
    let p = ((((1.535_336_2e-4 * f + 1.339_887_4e-3) * f + 9.618_437e-3) * f + 5.550_332_5e-2) * f
        + 2.402_264_8e-1)
        * f
        + 6.931_472e-1;
    let m = 1.0 + f * p;
    // `n as i32` from the bits of `t = 1.5·2²³ + n` (for |n| < 2²², n + 2²² is its mantissa):
    // one integer subtraction, where the saturating `as i32` had no vector form and left a
    // dozen scalar instructions a lane in the batch kernels. Wrapping: a negative x (never
    // passed by `segment`, but computed in the batch kernels' ignored lanes) must not trap in
    // debug builds.
    let ni = (t.to_bits() as i32).wrapping_sub(0x4B40_0000);
    let e = (ni.wrapping_add(127) as u32) << 23;
    m * f32::from_bits(e)
}

/// `τ·l` with `0·∞ = 0`.
#[inline(always)]
fn tau_len(tau: f32, l: f32) -> f32 {
    if tau == 0.0 {
        0.0
    } else {
        tau * l
    }
}

/// An f32 integrator; see the module documentation.
#[derive(Clone, Debug)]
pub enum FastIntegrator {
    Average(TfTable),
    Partial(TfTable, Arc<PsiTable>),
    Preint(Arc<PreintTable>),
}

impl FastIntegrator {
    /// The fast path for `name` (`average`, `partial`, `preint`), `None` for the others
    /// (`exact`). `partial` uses the shared Ψ table and `preint` the table of
    /// [`crate::optics::Preint::new`], as the f64 integrators do.
    pub fn new(name: &str, tf: &TransferFunction) -> Option<FastIntegrator> {
        Some(match name {
            "average" => FastIntegrator::Average(TfTable::new(tf, TF_SAMPLES)),
            "partial" => FastIntegrator::Partial(TfTable::new(tf, TF_SAMPLES), PsiTable::shared()),
            "preint" => {
                FastIntegrator::Preint(Arc::new(crate::optics::Preint::new(tf).table().clone()))
            }
            _ => return None,
        })
    }

    /// Premultiplied `[r, g, b, α]` of one segment (same contract as
    /// [`crate::optics::Integrator::segment`]: `l ≤ 0`, NaN or non-finite ends give 0).
    #[inline(always)]
    pub fn segment(&self, sf: f32, sb: f32, l: f32) -> [f32; 4] {
        if !(sf.is_finite() && sb.is_finite() && l > 0.0) {
            return [0.0; 4];
        }
        match self {
            FastIntegrator::Average(tf) => {
                let c = tf.eval(0.5 * sf + 0.5 * sb);
                let alpha = 1.0 - exp_neg(tau_len(c[3], l));
                [c[0] * alpha, c[1] * alpha, c[2] * alpha, alpha]
            }
            FastIntegrator::Partial(tf, psi) => {
                let (cf, cb) = (tf.eval(sf), tf.eval(sb));
                let (fa, fb) = (tau_len(cf[3], l), tau_len(cb[3], l));
                let zeta = exp_neg(0.5 * (fa + fb));
                let alpha = 1.0 - zeta;
                let pmz = (psi_lookup(psi, fa, fb) - zeta).clamp(0.0, alpha);
                [
                    cf[0] * alpha + (cb[0] - cf[0]) * pmz,
                    cf[1] * alpha + (cb[1] - cf[1]) * pmz,
                    cf[2] * alpha + (cb[2] - cf[2]) * pmz,
                    alpha,
                ]
            }
            FastIntegrator::Preint(t) => preint_lookup(t, sf, sb, l),
        }
    }
}

/// Fragments per shading batch ([`ShadeBatch`]).
pub const BATCH: usize = 256;

/// A batch of segments to shade, structure of arrays: `len` ends and lengths in, premultiplied
/// `[r, g, b, α]` out (`out[c][k]` is channel c of segment k).
#[derive(Clone, Debug)]
pub struct ShadeBatch {
    pub len: usize,
    pub sf: [f32; BATCH],
    pub sb: [f32; BATCH],
    pub l: [f32; BATCH],
    pub out: [[f32; BATCH]; 4],
}

impl Default for ShadeBatch {
    fn default() -> ShadeBatch {
        ShadeBatch {
            len: 0,
            sf: [0.0; BATCH],
            sb: [0.0; BATCH],
            l: [0.0; BATCH],
            out: [[0.0; BATCH]; 4],
        }
    }
}

impl FastIntegrator {
    /// Shades the first `len` segments of `b`: the definition, [`FastIntegrator::segment`] per
    /// segment.
    pub fn shade_batch_scalar(&self, b: &mut ShadeBatch) {
        for k in 0..b.len.min(BATCH) {
            let o = self.segment(b.sf[k], b.sb[k], b.l[k]);
            for (c, v) in o.into_iter().enumerate() {
                b.out[c][k] = v;
            }
        }
    }

    /// Shades the first `len` segments of `b`; the same values, bit for bit, as
    /// [`FastIntegrator::shade_batch_scalar`]. `average` and `partial` run branch-free
    /// lane-wise kernels compiled for the best instruction set of the CPU (x86-64-v3 where
    /// present, chosen at run time by `pulp`'s dispatch); `preint` runs the scalar definition.
    /// (The compiler keeps the lanes scalar because of the table look-ups; an explicit AVX2
    /// kernel with gathers gave the same bits but was ~8 % slower per frame on an AMD EPYC,
    /// whose gathers are microcoded: docs/performance.md.)
    #[inline]
    pub fn shade_batch(&self, b: &mut ShadeBatch) {
        match self {
            FastIntegrator::Preint(_) => self.shade_batch_scalar(b),
            _ => pulp::Arch::new().dispatch(Lanes { integ: self, b }),
        }
    }
}

/// The lane-wise kernels as a `pulp` operation: `with_simd` is inlined into a function compiled
/// with the target features of the dispatched instruction set, and so is everything it calls.
struct Lanes<'a> {
    integ: &'a FastIntegrator,
    b: &'a mut ShadeBatch,
}

impl pulp::WithSimd for Lanes<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        match self.integ {
            FastIntegrator::Average(tf) => average_lanes(tf, self.b),
            FastIntegrator::Partial(tf, psi) => partial_lanes(tf, psi, self.b),
            FastIntegrator::Preint(_) => self.integ.shade_batch_scalar(self.b),
        }
    }
}

// The lane-wise kernels below repeat `segment`'s arithmetic operation for operation (Rust does
// not contract a·b + c into an FMA, so vectorising them changes no bit); they run over the whole
// batch (lanes past `len` are computed and ignored) without branches: the validity test of
// `segment` becomes a select, `clamp` becomes max/min (the same on the values that reach it:
// never NaN in a valid lane), and indices stay i32. `shade_batch_matches_scalar` checks it.

/// `x.is_finite()` as a compare (false for NaN).
#[inline(always)]
fn finite(x: f32) -> bool {
    x.abs() < f32::INFINITY
}

/// [`TfTable::eval`], lane-wise.
#[inline(always)]
fn tf_lanes(tf: &TfTable, s: f32) -> [f32; 4] {
    let last = (tf.data.len() - 2) as i32;
    let x = ((s - tf.lo) * tf.scale).max(0.0).min(tf.max);
    let i = (x as i32).clamp(0, last);
    let t = x - i as f32;
    // SAFETY: 0 ≤ i ≤ len − 2 (the table has ≥ 2 samples). Unchecked, so that the loop has no
    // panic path and vectorises (gathers).
    let (a, b) = unsafe {
        (
            *tf.data.get_unchecked(i as usize),
            *tf.data.get_unchecked(i as usize + 1),
        )
    };
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
        a[3] + (b[3] - a[3]) * t,
    ]
}

#[inline(always)]
fn average_lanes(tf: &TfTable, b: &mut ShadeBatch) {
    assert!(tf.data.len() >= 2);
    let ShadeBatch { sf, sb, l, out, .. } = b;
    let [or, og, ob, oa] = out;
    for k in 0..BATCH {
        let (f, bk, lk) = (sf[k], sb[k], l[k]);
        let valid = finite(f) && finite(bk) && lk > 0.0;
        // Invalid lanes compute on zeros (their output is 0 anyway), so no index runs wild.
        let (f, bk, lk) = if valid { (f, bk, lk) } else { (0.0, 0.0, 0.0) };
        let c = tf_lanes(tf, 0.5 * f + 0.5 * bk);
        let alpha = 1.0 - exp_neg(tau_len(c[3], lk));
        let z = |v: f32| if valid { v } else { 0.0 };
        or[k] = z(c[0] * alpha);
        og[k] = z(c[1] * alpha);
        ob[k] = z(c[2] * alpha);
        oa[k] = z(alpha);
    }
}

/// `partial`: the TF looked up at both ends (a loop of look-ups of its own: gathers cost more
/// than scalar loads on the CPUs measured), then [`colour::colour_lanes`], whose loops are
/// arithmetic the compiler vectorises. Invalid lanes get zeros and length 0 (output 0).
#[inline(always)]
fn partial_lanes(tf: &TfTable, psi: &PsiTable, b: &mut ShadeBatch) {
    // What the unchecked loads rely on.
    assert!(tf.data.len() >= 2);
    let mut c = ColourBatch::default();
    for k in 0..BATCH {
        let (f, bk, lk) = (b.sf[k], b.sb[k], b.l[k]);
        let valid = finite(f) && finite(bk) && lk > 0.0;
        let (f, bk, lk) = if valid { (f, bk, lk) } else { (0.0, 0.0, 0.0) };
        let (cf, cb) = (tf_lanes(tf, f), tf_lanes(tf, bk));
        for ch in 0..4 {
            c.cf[ch][k] = cf[ch];
            c.cb[ch][k] = cb[ch];
        }
        c.l[k] = lk;
    }
    colour::colour_lanes(psi, &mut c);
    b.out = c.out;
}

/// The bilinear part of [`psi_lookup`] at table coordinates `ga`, `gb` (γ·(n − 1)), for a
/// table of at most [`PSI_F32_INDEX`] entries a side.
#[inline(always)]
fn psi_at(t: &PsiTable, ga: f32, gb: f32) -> f32 {
    let n = t.size();
    let top = (n - 2) as f32;
    let (x, y) = (floor_in(ga, top), floor_in(gb, top));
    // The row-major index y·n + x, a float below n² ≤ 2²³ (so exact), as an integer: the
    // index as 64-bit integer products was a scalar multiply and add a lane (2.5 % of a post
    // draw's instructions).
    let r0 = float_index(y * n as f32 + x) as usize;
    let (ti, tj) = (ga - x, gb - y);
    // The next row as a slice of its own, so that both rows are read at index r0 (as r0 + n,
    // each lane's second row took an address addition of its own).
    // SAFETY: x, y ≤ n − 2, so r0 + n + 1 ≤ n² − 1 < data.len() (asserted by the caller).
    let (d0, d1) = (t.data(), unsafe { t.data().get_unchecked(n..) });
    let g0 = |k: usize| unsafe { *d0.get_unchecked(k) };
    let g1 = |k: usize| unsafe { *d1.get_unchecked(k) };
    let v0 = g0(r0) + (g0(r0 + 1) - g0(r0)) * ti;
    let v1 = g1(r0) + (g1(r0 + 1) - g1(r0)) * ti;
    v0 + (v1 - v0) * tj
}

/// `(g as i32).clamp(0, top)` as a float (`top` a whole number), the same value for every g
/// (NaN included: 0): the saturating `as i32` and the integer clamp have no vector form (they
/// were a quarter of the colour kernel); two float selects do.
#[inline(always)]
fn floor_in(g: f32, top: f32) -> f32 {
    let x = g.floor();
    let x = if x > 0.0 { x } else { 0.0 };
    if x < top {
        x
    } else {
        top
    }
}

/// The whole number `x` (0 ≤ x < 2²³) as an integer, from its bits by the 2²³ trick: a vector
/// addition and subtraction, where `as u32` is a scalar conversion a lane.
#[inline(always)]
fn float_index(x: f32) -> u32 {
    (x + 8_388_608.0).to_bits() - 8_388_608f32.to_bits()
}

/// The largest Ψ table side [`psi_at`] takes: its index, a float, is exact below 2²³.
pub(crate) const PSI_F32_INDEX: usize = 2896;

/// Bilinear Ψ at the end depths `fa`, `fb` (≥ 0), as [`PsiTable::lookup`].
#[inline(always)]
fn psi_lookup(t: &PsiTable, fa: f32, fb: f32) -> f32 {
    let n = t.size();
    let m = (n - 1) as f32;
    // γ = x/(1 + x) = 1 − 1/(1 + x): 1 at x = ∞ without a test.
    let coord = |x: f32| {
        let g = (1.0 - 1.0 / (1.0 + x)) * m;
        let i = (g as i32 as usize).min(n - 2);
        (i, g - i as f32)
    };
    let (i, ti) = coord(fa);
    let (j, tj) = coord(fb);
    let d = t.data();
    let r0 = &d[j * n + i..j * n + i + 2];
    let r1 = &d[(j + 1) * n + i..(j + 1) * n + i + 2];
    let v0 = r0[0] + (r0[1] - r0[0]) * ti;
    let v1 = r1[0] + (r1[1] - r1[0]) * ti;
    v0 + (v1 - v0) * tj
}

/// Trilinear lookup as [`PreintTable::lookup`], in f32.
#[inline(always)]
fn preint_lookup(t: &PreintTable, sf: f32, sb: f32, l: f32) -> [f32; 4] {
    let [n_s, _, n_l] = t.dims();
    let [s_lo, s_hi] = t.s_range();
    let scale = ((n_s - 1) as f64 / (s_hi - s_lo)) as f32;
    let axis = |x: f32, n: usize| {
        let x = x.clamp(0.0, (n - 1) as f32);
        let i = (x as i32 as usize).min(n - 2);
        (i, x - i as f32)
    };
    let (i, ti) = axis((sf - s_lo as f32) * scale, n_s);
    let (j, tj) = axis((sb - s_lo as f32) * scale, n_s);
    let lc = (l.min(PreintTable::L_MAX as f32) / PreintTable::L0 as f32).ln_1p()
        * (1.0 / (PreintTable::L_MAX / PreintTable::L0).ln_1p()) as f32;
    let (k, tk) = axis(lc * (n_l - 1) as f32, n_l);
    let d = t.data();
    let mut v = [0.0f32; 4];
    for (dk, wk) in [(0, 1.0 - tk), (1, tk)] {
        for (dj, wj) in [(0, 1.0 - tj), (1, tj)] {
            let w = wk * wj;
            let base = (((k + dk) * n_s + j + dj) * n_s + i) * 4;
            let e = &d[base..base + 8];
            for c in 0..4 {
                v[c] += w * (e[c] + (e[4 + c] - e[c]) * ti);
            }
        }
    }
    let alpha = 1.0 - exp_neg(tau_len(v[3], l));
    [v[0] * alpha, v[1] * alpha, v[2] * alpha, alpha]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_matches_exp() {
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            let x = k as f32 * 1e-4; // 0..20
            let e = (-(x as f64)).exp();
            let r = ((exp_neg(x) as f64 - e) / e).abs();
            worst = worst.max(r);
        }
        assert!(worst < 2e-6, "worst relative error {worst:e}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(f32::INFINITY), exp_neg(1e9));
        assert!(exp_neg(1e9) < 1e-37);
    }

    /// The vectorised batch kernels give the scalar definition's bits, on ordinary segments and
    /// on the edge cases (l ≤ 0, NaN and infinite ends, huge lengths, s outside the TF range).
    #[test]
    fn shade_batch_matches_scalar() {
        let tf = TransferFunction::preset("default").unwrap();
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let special = [
            0.0,
            -0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            1e30,
            1e-30,
        ];
        for name in ["average", "partial", "preint"] {
            let integ = FastIntegrator::new(name, &tf).unwrap();
            for round in 0..40 {
                let mut b = ShadeBatch {
                    len: if round % 5 == 4 {
                        1 + round % BATCH
                    } else {
                        BATCH
                    },
                    ..Default::default()
                };
                for k in 0..BATCH {
                    b.sf[k] = 1.4 * rnd() - 0.2;
                    b.sb[k] = 1.4 * rnd() - 0.2;
                    b.l[k] = rnd() * rnd() * if round % 3 == 0 { 50.0 } else { 0.05 };
                    if round % 2 == 1 && k % 7 == 0 {
                        let v = special[k / 7 % special.len()];
                        match k % 3 {
                            0 => b.sf[k] = v,
                            1 => b.sb[k] = v,
                            _ => b.l[k] = v,
                        }
                    }
                }
                let mut scalar = b.clone();
                integ.shade_batch_scalar(&mut scalar);
                // The portable lane-wise kernels (the fallback where AVX2 is missing) too.
                let mut lanes = b.clone();
                if !matches!(integ, FastIntegrator::Preint(_)) {
                    pulp::Arch::new().dispatch(Lanes {
                        integ: &integ,
                        b: &mut lanes,
                    });
                } else {
                    integ.shade_batch_scalar(&mut lanes);
                }
                integ.shade_batch(&mut b);
                for c in 0..4 {
                    for k in 0..b.len {
                        assert_eq!(lanes.out[c][k].to_bits(), scalar.out[c][k].to_bits());
                    }
                }
                for c in 0..4 {
                    for k in 0..b.len {
                        assert_eq!(
                            b.out[c][k].to_bits(),
                            scalar.out[c][k].to_bits(),
                            "{name} channel {c} segment {k}: ({}, {}, {})",
                            b.sf[k],
                            b.sb[k],
                            b.l[k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn tf_table_matches_tf() {
        let tf = TransferFunction::preset("default").unwrap();
        let t = TfTable::new(&tf, TF_SAMPLES);
        for k in 0..=2000 {
            let s = -0.2 + 1.4 * k as f64 / 2000.0;
            let (c, tau) = tf.eval(s);
            let v = t.eval(s as f32);
            for ch in 0..3 {
                assert!((v[ch] as f64 - c[ch]).abs() < 1e-3, "s {s}");
            }
            assert!((v[3] as f64 - tau).abs() < 1e-2 * tau.max(1.0), "s {s}");
        }
    }
}
