//! `partial` from colours: the batch kernel for fragments whose transfer function was already
//! evaluated at both ends.
//!
//! `cpu-pt` takes each tet's piece of the TF as a line ([`TfTable::span_over`]) when the tet's
//! scalars lie on one piece (or two lines, where they cross one control point), and then gives
//! each fragment its colours `c0 + c1·s` at both ends
//! instead of its scalars: the two table look-ups per fragment (eight scattered loads, half
//! the time of the lane-wise `partial` kernel) become eight multiply-adds in the rasteriser.
//! [`segment_from_colours`] is `partial`'s [`FastIntegrator::segment`] from that point on, and
//! [`shade_colours`] is it lane-wise with the same operations (the same bits: a test holds
//! them equal).

use super::{exp_neg, finite, psi_at, tau_len, PsiTable, BATCH, PSI_F32_INDEX};

/// A batch of segments given by their colours: `[r, g, b, τ]` at the front (`cf`) and back
/// (`cb`) ends and the length `l`; premultiplied `[r, g, b, α]` out, structure of arrays.
#[derive(Clone, Debug)]
pub struct ColourBatch {
    pub len: usize,
    pub cf: [[f32; BATCH]; 4],
    pub cb: [[f32; BATCH]; 4],
    pub l: [f32; BATCH],
    pub out: [[f32; BATCH]; 4],
}

impl Default for ColourBatch {
    fn default() -> ColourBatch {
        ColourBatch {
            len: 0,
            cf: [[0.0; BATCH]; 4],
            cb: [[0.0; BATCH]; 4],
            l: [0.0; BATCH],
            out: [[0.0; BATCH]; 4],
        }
    }
}

/// `partial`'s segment from the TF's values at its ends (what [`super::FastIntegrator::segment`]
/// computes once it has looked them up): zero unless `l > 0` and both extinctions are finite.
#[inline(always)]
pub fn segment_from_colours(psi: &PsiTable, cf: [f32; 4], cb: [f32; 4], l: f32) -> [f32; 4] {
    if !(l > 0.0 && finite(cf[3]) && finite(cb[3])) {
        return [0.0; 4];
    }
    let (fa, fb) = (tau_len(cf[3], l), tau_len(cb[3], l));
    let zeta = exp_neg(0.5 * (fa + fb));
    let alpha = 1.0 - zeta;
    let pmz = (super::psi_lookup(psi, fa, fb) - zeta).clamp(0.0, alpha);
    [
        cf[0] * alpha + (cb[0] - cf[0]) * pmz,
        cf[1] * alpha + (cb[1] - cf[1]) * pmz,
        cf[2] * alpha + (cb[2] - cf[2]) * pmz,
        alpha,
    ]
}

/// Shades the first `len` segments of `b`, lane-wise ([`segment_from_colours`]'s operations, so
/// its bits), compiled for the best instruction set of the CPU (`pulp`'s dispatch).
pub fn shade_colours(psi: &PsiTable, b: &mut ColourBatch) {
    pulp::Arch::new().dispatch(Lanes { psi, b });
}

struct Lanes<'a> {
    psi: &'a PsiTable,
    b: &'a mut ColourBatch,
}

impl pulp::WithSimd for Lanes<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        colour_lanes(self.psi, self.b)
    }
}

/// [`colour_lanes_n`] over a whole batch.
#[inline(always)]
pub(super) fn colour_lanes(psi: &PsiTable, b: &mut ColourBatch) {
    let ColourBatch { cf, cb, l, out, .. } = b;
    colour_lanes_n(psi, cf, cb, l, out);
}

/// [`segment_from_colours`] over `N` lanes (structure of arrays: `cf[c][k]` is channel `c` of
/// lane `k`'s front colour), in three passes: the arithmetic before the Ψ look-up, the
/// look-ups, the blend (as the lane-wise `partial` kernel, whose first pass, the TF look-ups,
/// is gone). `cpu-pt` calls it on batches of [`BATCH`] fragments, the ray caster on its queue
/// of a ray's segments.
#[inline(always)]
pub(crate) fn colour_lanes_n<const N: usize>(
    psi: &PsiTable,
    cf: &[[f32; N]; 4],
    cb: &[[f32; N]; 4],
    l: &[f32; N],
    out: &mut [[f32; N]; 4],
) {
    // What the unchecked loads and the float index of `psi_at` rely on (the table is
    // `PsiTable::DEFAULT_SIZE`, 512, a side).
    assert!(psi.size() >= 2 && psi.data().len() >= psi.size().pow(2));
    assert!(
        psi.size() <= PSI_F32_INDEX,
        "Ψ table too large for the f32 kernels"
    );
    let m = (psi.size() - 1) as f32;
    // Pass 1 hands its values on in `out`'s planes, each read at lane k before lane k is
    // written: `zeta` in plane 0, NaN for an invalid lane (a valid lane's is finite), the Ψ
    // coordinates in planes 1 and 2. (Five scratch arrays took a `memset` call each to zero,
    // ~1 % of a cpu-pt frame; Ψ keeps one, as the look-ups written to a plane they read were
    // not vectorised.)
    let [or, og, ob, oa] = out;
    // 1. Validity, exp and the Ψ table coordinates γ·(n − 1) (as `psi_lookup`).
    for k in 0..N {
        let valid = l[k] > 0.0 && finite(cf[3][k]) && finite(cb[3][k]);
        // Invalid lanes compute on zeros (their output is 0 anyway), so no index runs wild.
        let (tf, tb, lk) = if valid {
            (cf[3][k], cb[3][k], l[k])
        } else {
            (0.0, 0.0, 0.0)
        };
        let (fa, fb) = (tau_len(tf, lk), tau_len(tb, lk));
        or[k] = if valid {
            exp_neg(0.5 * (fa + fb))
        } else {
            f32::NAN
        };
        og[k] = (1.0 - 1.0 / (1.0 + fa)) * m;
        ob[k] = (1.0 - 1.0 / (1.0 + fb)) * m;
    }
    // 2. Ψ (look-ups).
    let mut ps = [0.0f32; N];
    for k in 0..N {
        ps[k] = psi_at(psi, og[k], ob[k]);
    }
    // 3. The blend.
    for k in 0..N {
        let (zeta, ps) = (or[k], ps[k]);
        let ok = !zeta.is_nan();
        let alpha = 1.0 - zeta;
        let pmz = (ps - zeta).max(0.0).min(alpha);
        let z = |v: f32| if ok { v } else { 0.0 };
        or[k] = z(cf[0][k] * alpha + (cb[0][k] - cf[0][k]) * pmz);
        og[k] = z(cf[1][k] * alpha + (cb[1][k] - cf[1][k]) * pmz);
        ob[k] = z(cf[2][k] * alpha + (cb[2][k] - cf[2][k]) * pmz);
        oa[k] = z(alpha);
    }
}

#[cfg(test)]
mod tests {
    use super::super::{FastIntegrator, TfSpan, TfTable, TF_SAMPLES};
    use super::*;
    use crate::tf::TransferFunction;

    /// The lane-wise kernel gives [`segment_from_colours`]'s bits, which are `partial`'s
    /// [`FastIntegrator::segment`] bits when the colours are the table's; on ordinary
    /// segments and on l ≤ 0, NaN and infinite extinctions.
    #[test]
    fn colour_lanes_are_the_segment() {
        let tf = TransferFunction::preset("default").unwrap();
        let integ = FastIntegrator::new("partial", &tf).unwrap();
        let FastIntegrator::Partial(table, psi) = &integ else {
            unreachable!()
        };
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut b = ColourBatch::default();
        let mut ends = Vec::new();
        for k in 0..BATCH {
            let (sf, sb) = (rnd() * 1.2 - 0.1, rnd() * 1.2 - 0.1);
            let l = match k % 16 {
                0 => 0.0,
                1 => -1.0,
                2 => f32::NAN,
                3 => 1e30,
                _ => rnd() * rnd() * 0.3,
            };
            let (mut cf, cb) = (table.eval(sf), table.eval(sb));
            if k % 16 == 4 {
                cf[3] = f32::INFINITY;
            }
            if k % 16 == 5 {
                cf[3] = f32::NAN;
            }
            for c in 0..4 {
                (b.cf[c][k], b.cb[c][k]) = (cf[c], cb[c]);
            }
            b.l[k] = l;
            ends.push((sf, sb, l, cf, cb));
        }
        b.len = BATCH;
        shade_colours(psi, &mut b);
        for (k, &(sf, sb, l, cf, cb)) in ends.iter().enumerate() {
            let want = segment_from_colours(psi, cf, cb, l);
            let got: [f32; 4] = std::array::from_fn(|c| b.out[c][k]);
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "segment {k}");
            if k % 16 != 4 && k % 16 != 5 {
                let seg = integ.segment(sf, sb, l);
                assert_eq!(got.map(f32::to_bits), seg.map(f32::to_bits), "segment {k}");
            }
        }
    }

    /// Where the table says a range lies on one line, the line is the table to f32 rounding,
    /// on every preset and a TF with a step and points off the samples; where it says the range
    /// crosses one control point, the hinge is the TF itself (in f64) to f32 rounding, also
    /// inside the sample interval around the point, and the table away from it; ranges across
    /// two control points or the step have neither.
    #[test]
    fn tf_spans_are_the_table() {
        let mut tfs: Vec<TransferFunction> = crate::tf::PRESETS
            .iter()
            .map(|p| TransferFunction::preset(p).unwrap())
            .collect();
        let mut step = TransferFunction::preset("default").unwrap();
        step.points[2].s = step.points[1].s;
        step.points[3].s = 0.6180339;
        tfs.push(step);
        // A point exactly on a sample (2048 of 4095 on [0, 1]): its runs touch, with no bent
        // interval between them.
        let mut on_sample = TransferFunction::preset("default").unwrap();
        on_sample.points[2].s = 2048.0 / 4095.0;
        tfs.push(on_sample);
        for tf in &tfs {
            let t = TfTable::new(tf, TF_SAMPLES);
            let (lo, scale) = t.domain();
            let (mut lined, mut hinged, mut worst) = (0, 0, 0.0f32);
            let rel = |got: f32, want: f32| (got - want).abs() / want.abs().max(1.0);
            for k in 0..8000 {
                let s0 = (k % 4000) as f32 / 4000.0 * 1.1 - 0.05;
                // Short ranges, and (the second half) ranges long enough to cross a point.
                let s1 = s0
                    + if k < 4000 {
                        0.002 * (k % 7) as f32
                    } else {
                        0.03
                    };
                let Some(span) = t.span_over(s0, s1) else {
                    continue;
                };
                let crossed = tf.points_between(s0 as f64, s1 as f64);
                let mut at: Vec<f32> = (0..=8).map(|j| s0 + (s1 - s0) * j as f32 / 8.0).collect();
                match span {
                    TfSpan::Line(_) => {
                        lined += 1;
                        assert!(crossed.is_empty(), "{s0} {s1}");
                    }
                    TfSpan::Hinge(h) => {
                        hinged += 1;
                        assert!(crossed.len() <= 1, "{s0} {s1}");
                        assert!(tf.points.iter().any(|p| p.s as f32 == h.at));
                        at.extend([h.at, h.at.next_down(), h.at.next_up()]);
                    }
                }
                for s in at {
                    let v = span.eval(s);
                    let (c, tau) = tf.eval(s as f64);
                    let exact = [c[0], c[1], c[2], tau];
                    // The table interpolates the TF except in a sample interval around a
                    // control point, where it holds the chord.
                    let x = (s - lo) * scale;
                    let (s_a, s_b) = (x.floor() / scale + lo, (x.floor() + 1.0) / scale + lo);
                    let bent = !tf
                        .points_between(s_a as f64 - 1e-6, s_b as f64 + 1e-6)
                        .is_empty();
                    for (ch, &vc) in v.iter().enumerate() {
                        worst = worst.max(rel(vc, exact[ch] as f32));
                        if !bent {
                            worst = worst.max(rel(vc, t.eval(s)[ch]));
                        }
                    }
                }
            }
            assert!(lined > 3000, "{}: {lined}", tf.name);
            // Every TF here but `xray` (one piece over the range) has points to cross.
            if tf.name != "xray" {
                assert!(hinged > 100, "{}: {hinged}", tf.name);
            }
            assert!(worst < 4e-6, "{}: {worst}", tf.name);
            assert!(t.span_over(f32::NAN, 0.5).is_none());
            assert!(t.span_over(0.5, 0.4).is_none());
        }
        // Across two control points, and across the step (two points at one scalar): the table.
        let default = TfTable::new(&tfs[0], TF_SAMPLES);
        assert!(default.span_over(0.2, 0.55).is_none());
        assert!(matches!(
            default.span_over(0.2, 0.3),
            Some(TfSpan::Hinge(_))
        ));
        let stepped = TfTable::new(&tfs[3], TF_SAMPLES);
        assert!(stepped.span_over(0.24, 0.26).is_none());
        assert!(matches!(
            stepped.span_over(0.6, 0.63),
            Some(TfSpan::Hinge(_))
        ));
        let on_sample = TfTable::new(&tfs[4], TF_SAMPLES);
        let Some(TfSpan::Hinge(h)) = on_sample.span_over(0.45, 0.55) else {
            panic!("no hinge across a point on a sample");
        };
        assert_eq!(h.at, (2048.0f64 / 4095.0) as f32);
    }
}
