//! What the walk integrates with. Every crossing is the back of one segment and the front of
//! the next, so the transfer function is evaluated once per crossing ([`Shade::end`]) instead
//! of twice per segment; `partial` and `exact` take those values through their
//! `segment_eval` (the same arithmetic as `Integrator::segment`, so the same bits), and the
//! walk is compiled once per integrator kind instead of calling it through a `dyn` pointer.
//! `partial` takes two shortcuts that change only last bits ([`RcPartial`]): the transfer
//! function's pieces are found from a bucket table and evaluated with precomputed slopes, and a
//! segment calls `expm1` once.

use crate::optics::{gamma_of_depth, Exact, Integrator, Partial, Segment};
use crate::tf::TransferFunction;

/// A per-segment integrator as the walk calls it.
pub(super) trait Shade: Sync {
    /// The transfer function's values at one crossing.
    type End: Copy + Default;
    fn end(&self, s: f64) -> Self::End;
    /// [`Shade::end`] for the next crossing of a walk, with `hint` carried from its previous
    /// one (`partial`: the piece of the TF it was in, which the next crossing is usually in
    /// too). The same value as `end(s)`.
    #[inline(always)]
    fn end_next(&self, s: f64, hint: &mut u32) -> Self::End {
        let _ = hint;
        self.end(s)
    }
    /// The segment between two crossings of optical length `l > 0`.
    fn segment(&self, front: &Self::End, back: &Self::End, l: f64) -> Segment;
    /// The first `q.n` queued segments, each what [`Shade::segment`] gives for it, bit for
    /// bit (`partial` computes them lane-wise); a segment of no length (`l ≤ 0`, which the
    /// caller does not composite) may be anything.
    #[inline(always)]
    fn segments(&self, q: &Queue<Self::End>) -> Lanes {
        let mut out = Lanes::default();
        for k in 0..q.n {
            if q.l[k] > 0.0 {
                let seg = self.segment(&q.ends[k], &q.ends[k + 1], q.l[k]);
                out.set(k, seg);
            }
        }
        out
    }
}

/// Segments a ray queues before it shades them at once ([`Shade::segments`]).
pub(super) const QUEUE: usize = 8;

/// A ray's queued segments as the run of crossings they join: segment `k` runs from
/// `ends[k]` to `ends[k + 1]` with optical length `l[k]`. Consecutive segments share their
/// crossing, so each crossing is stored once (`ends[n]` is the front of the segment to come).
#[derive(Clone, Copy, Default)]
pub(super) struct Queue<E> {
    pub(super) ends: [E; QUEUE + 1],
    pub(super) l: [f64; QUEUE],
    pub(super) n: usize,
}

/// Shaded segments, lane by lane: colour (premultiplied) and opacity.
#[derive(Clone, Copy, Default)]
pub(super) struct Lanes {
    pub(super) rgb: [[f64; QUEUE]; 3],
    pub(super) alpha: [f64; QUEUE],
}

impl Lanes {
    #[inline(always)]
    fn set(&mut self, k: usize, seg: Segment) {
        for c in 0..3 {
            self.rgb[c][k] = seg.rgb[c];
        }
        self.alpha[k] = seg.alpha;
    }

    /// Segment `k`.
    #[inline(always)]
    pub(super) fn get(&self, k: usize) -> Segment {
        Segment {
            rgb: [self.rgb[0][k], self.rgb[1][k], self.rgb[2][k]],
            alpha: self.alpha[k],
        }
    }
}

/// The integrator a ray caster was prepared with.
pub(super) enum Shader {
    Partial(RcPartial),
    Exact(Exact),
    /// Any other integrator, through its trait (average, preint).
    Other(Box<dyn Integrator>),
}

impl Shader {
    pub(super) fn new(name: &str, tf: &TransferFunction) -> crate::error::Result<Shader> {
        let i = crate::optics::integrator(name, tf)?;
        Ok(match name {
            "partial" => Shader::Partial(RcPartial {
                tf: LinearTf::new(tf),
                p: Partial::new(tf),
                arch: pulp::Arch::new(),
            }),
            "exact" => Shader::Exact(Exact::new(tf)),
            _ => Shader::Other(i),
        })
    }
}

/// A crossing's scalar and the transfer function's colour and extinction there.
#[derive(Clone, Copy, Default)]
pub(super) struct Eval {
    s: f64,
    c: [f64; 3],
    tau: f64,
}

/// `partial` as the ray caster runs it: [`Partial`]'s Ψ table, with the transfer function
/// as a [`LinearTf`].
pub(super) struct RcPartial {
    p: Partial,
    tf: LinearTf,
    /// The instruction set [`PartialLanes`] runs on, detected once.
    arch: pulp::Arch,
}

/// Number of buckets of [`LinearTf`]'s piece index.
const BUCKETS: usize = 256;

/// A piecewise-linear transfer function laid out for evaluation without a search or a
/// division: per piece its start, the next piece's start, its value there and its slope, and
/// per bucket of `[s₀, s_last]` the piece that holds the previous bucket's start (so that
/// rounding of the bucket can only leave the walk forward to go, one or two steps). The same
/// function as [`TransferFunction::eval`] up to the rounding of `a + (s − s_a)·slope` against
/// `a + (b − a)·((s − s_a)/(s_b − s_a))`.
pub(super) struct LinearTf {
    /// Per point: its piece (to the next point; the last one's ends at +∞).
    pieces: Vec<Piece>,
    /// A fixed array, so that the look-up needs no bounds check.
    bucket: Box<[u32; BUCKETS]>,
    s0: f64,
    inv_w: f64,
}

/// One piece of a [`LinearTf`], in one record: where it starts and ends, rgb and τ at its start
/// and their slopes.
#[derive(Clone, Copy)]
struct Piece {
    s: f64,
    s_next: f64,
    val: [f64; 4],
    slope: [f64; 4],
}

impl LinearTf {
    fn new(tf: &TransferFunction) -> LinearTf {
        let p = &tf.points;
        let n = p.len();
        let val: Vec<[f64; 4]> = p.iter().map(|q| [q.rgb[0], q.rgb[1], q.rgb[2], q.tau]).collect();
        let pieces = (0..n)
            .map(|k| {
                let slope = if k + 1 < n && p[k + 1].s > p[k].s {
                    let ds = p[k + 1].s - p[k].s;
                    std::array::from_fn(|c| (val[k + 1][c] - val[k][c]) / ds)
                } else {
                    [0.0; 4]
                };
                Piece {
                    s: p[k].s,
                    s_next: p.get(k + 1).map_or(f64::INFINITY, |q| q.s),
                    val: val[k],
                    slope,
                }
            })
            .collect();
        let (s0, s1) = (p[0].s, p[n - 1].s);
        let w = (s1 - s0) / BUCKETS as f64;
        let inv_w = if w > 0.0 && w.is_finite() { 1.0 / w } else { 0.0 };
        // The last point at or before the previous bucket's start.
        let bucket = Box::new(std::array::from_fn(|b| {
            let lo = s0 + (b.saturating_sub(1)) as f64 * w;
            (0..n).rev().find(|&k| p[k].s <= lo).unwrap_or(0) as u32
        }));
        LinearTf {
            pieces,
            bucket,
            s0,
            inv_w,
        }
    }

    /// [`TransferFunction::eval`]: colour and τ at `s` (clamped at the ends; NaN is the first
    /// point's).
    #[inline(always)]
    fn eval(&self, s: f64) -> ([f64; 3], f64) {
        self.eval_from(s, &mut 0)
    }

    /// [`LinearTf::eval`], trying piece `hint` first, which is then set to the piece `s` is in.
    /// The pieces tile `[s₀, ∞)` (each ends where the next starts), so a piece with
    /// `start ≤ s < next start` is the one piece the bucket search finds: the same value.
    #[inline(always)]
    fn eval_from(&self, s: f64, hint: &mut u32) -> ([f64; 3], f64) {
        let n = self.pieces.len();
        let last = n - 1;
        if let Some(pc) = self.pieces.get(*hint as usize) {
            // s > s₀ and s < s_last as below: the hint's piece is not the last one.
            // (`&`, not `&&`: one branch, not four.)
            if (*hint as usize != last) & (pc.s <= s) & (s < pc.s_next) & (s > self.s0) {
                return Self::lerp(pc, s);
            }
        }
        let k = if s.is_nan() || s <= self.s0 || n == 1 {
            return self.point(0);
        } else if s >= self.pieces[last].s {
            return self.point(last);
        } else {
            // s ∈ (s₀, s_last): the bucket is in range (0 ≤ x ≤ BUCKETS, so `as i32` is the
            // `as usize` it replaces, in one conversion); walk forward to the piece of s.
            let b = (((s - self.s0) * self.inv_w) as i32).clamp(0, BUCKETS as i32 - 1);
            let mut k = self.bucket[b as usize] as usize;
            while s >= self.pieces[k].s_next {
                k += 1;
            }
            k
        };
        *hint = k as u32;
        Self::lerp(&self.pieces[k], s)
    }

    /// Piece `pc` at `s`: its value at its start plus `(s − start)` times its slope.
    #[inline(always)]
    fn lerp(pc: &Piece, s: f64) -> ([f64; 3], f64) {
        let (v, m, d) = (&pc.val, &pc.slope, s - pc.s);
        (
            [v[0] + d * m[0], v[1] + d * m[1], v[2] + d * m[2]],
            v[3] + d * m[3],
        )
    }

    #[inline]
    fn point(&self, k: usize) -> ([f64; 3], f64) {
        let v = &self.pieces[k].val;
        ([v[0], v[1], v[2]], v[3])
    }
}

impl Shade for RcPartial {
    type End = Eval;
    /// [`RcPartial::segment`] lane-wise, compiled for the best instruction set of the CPU
    /// (x86-64-v3 where present, by `pulp`'s dispatch).
    #[inline(always)]
    fn segments(&self, q: &Queue<Eval>) -> Lanes {
        self.arch.dispatch(PartialLanes { rc: self, q })
    }
    #[inline(always)]
    fn end(&self, s: f64) -> Eval {
        let (c, tau) = self.tf.eval(s);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn end_next(&self, s: f64, hint: &mut u32) -> Eval {
        let (c, tau) = self.tf.eval_from(s, hint);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn segment(&self, f: &Eval, b: &Eval, l: f64) -> Segment {
        // `Integrator::segment`'s input check (l > 0 is the caller's).
        if !(f.s.is_finite() && b.s.is_finite()) {
            return Segment::default();
        }
        // `Partial::segment_eval` with one libm call instead of two: α = 1 − ζ, ζ = exp(−g) (g
        // the segment's optical depth), rather than −expm1(−g). The two differ by the rounding
        // of 1 − ζ, ≤ 1.2e-16 absolute (relative only for thin segments, where α ≈ g ≪ 1 and
        // the pixel's error is that absolute one), far inside `partial`'s own error; glibc's
        // `expm1` has a division on its critical path and was a fifth of the frame's time, and
        // its `exp` a call and an errno wrapper: ζ comes from the inline [`exp_neg`].
        let (fa, fb) = (f.tau * l, b.tau * l);
        let zeta = exp_neg(0.5 * (fa + fb));
        let alpha = 1.0 - zeta;
        let pmz = clamp(self.p.table().lookup(fa, fb) - zeta, 0.0, alpha);
        Segment::from_partial(f.c, b.c, alpha, pmz)
    }
}

/// [`RcPartial::segment`] over a queue as a `pulp` operation. Its passes repeat `segment`'s
/// operations one for one (Rust contracts nothing into an FMA), so each lane has `segment`'s
/// bits: the validity test becomes a select (invalid lanes compute on zeros and give zeros),
/// and the table look-ups, which vectorise into slow gathers, have a scalar pass of their own.
/// Lanes past `q.n` are computed and ignored.
struct PartialLanes<'a> {
    rc: &'a RcPartial,
    q: &'a Queue<Eval>,
}

impl pulp::WithSimd for PartialLanes<'_> {
    type Output = Lanes;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Lanes {
        let q = self.q;
        // 0. The queue's crossings, transposed into lanes (so that the passes vectorise):
        //    segment k's front is crossing k, its back crossing k + 1.
        let mut s = [0.0; QUEUE + 1];
        let mut t = [0.0; QUEUE + 1];
        let mut c = [[0.0; QUEUE + 1]; 3];
        for (k, e) in q.ends.iter().enumerate() {
            (s[k], t[k]) = (e.s, e.tau);
            for (ch, v) in c.iter_mut().zip(e.c) {
                ch[k] = v;
            }
        }
        let front = |a: &[f64; QUEUE + 1]| -> [f64; QUEUE] { std::array::from_fn(|k| a[k]) };
        let back = |a: &[f64; QUEUE + 1]| -> [f64; QUEUE] { std::array::from_fn(|k| a[k + 1]) };
        let (sf, sb, tf, tb) = (front(&s), back(&s), front(&t), back(&t));
        let cf = c.each_ref().map(front);
        let cb = c.each_ref().map(back);
        // 1. The optical depths of the ends, ζ, α and the Ψ table's coordinates.
        let mut ok = [0.0; QUEUE];
        let (mut zeta, mut alpha) = ([0.0; QUEUE], [0.0; QUEUE]);
        let (mut gf, mut gb) = ([0.0; QUEUE], [0.0; QUEUE]);
        for k in 0..QUEUE {
            let valid = sf[k].abs() < f64::INFINITY && sb[k].abs() < f64::INFINITY;
            ok[k] = if valid { 1.0 } else { 0.0 };
            let l = if valid { q.l[k] } else { 0.0 };
            let (fa, fb) = (tf[k] * l, tb[k] * l);
            zeta[k] = exp_neg(0.5 * (fa + fb));
            alpha[k] = 1.0 - zeta[k];
            gf[k] = gamma_of_depth(fa);
            gb[k] = gamma_of_depth(fb);
        }
        // 2. The look-ups.
        let table = self.rc.p.table();
        let psi = table.lookup_gamma_lanes(&gf, &gb);
        // 3. Ψ − ζ and the segment.
        let mut out = Lanes::default();
        for k in 0..QUEUE {
            let valid = ok[k] != 0.0;
            let pmz = clamp(psi[k] - zeta[k], 0.0, alpha[k]);
            // `Segment::from_partial`'s expression, spelled per lane: called per lane, it left
            // a third more of this pass scalar.
            for c in 0..3 {
                let v = cf[c][k] * alpha[k] + (cb[c][k] - cf[c][k]) * pmz;
                out.rgb[c][k] = if valid { v } else { 0.0 };
            }
            out.alpha[k] = if valid { alpha[k] } else { 0.0 };
        }
        out
    }
}

impl Shade for Exact {
    type End = Eval;
    #[inline(always)]
    fn end(&self, s: f64) -> Eval {
        let (c, tau) = self.tf().eval(s);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn segment(&self, f: &Eval, b: &Eval, l: f64) -> Segment {
        self.segment_eval(f.s, (f.c, f.tau), b.s, (b.c, b.tau), l)
    }
}

impl Shade for Box<dyn Integrator> {
    type End = f64;
    #[inline(always)]
    fn end(&self, s: f64) -> f64 {
        s
    }
    #[inline(always)]
    fn segment(&self, f: &f64, b: &f64, l: f64) -> Segment {
        Integrator::segment(self.as_ref(), *f, *b, l)
    }
}

/// `x.clamp(lo, hi)` (the same value for every `x`, NaN included) without its check of
/// `lo ≤ hi`, whose panic path keeps the lanes from vectorising.
#[inline(always)]
fn clamp(x: f64, lo: f64, hi: f64) -> f64 {
    let x = if x < lo { lo } else { x };
    if x > hi {
        hi
    } else {
        x
    }
}

/// `exp(−g)` for `g ≥ 0` (NaN gives NaN), within 3 ulp of libm's: `g = k·ln 2 + r` with
/// `|r| ≤ ln 2 / 2` (ln 2 split in a high part with 32 significant bits, exact times `k`, and a
/// low part), `e^{−r}` by its Taylor polynomial of degree 13 (the remainder `r¹⁴/14!` is below
/// 2e-19) in Estrin's scheme, and `2^{−k}` assembled in the exponent bits. Inline and without
/// a call, a division or a branch (the out-of-range inputs are selects), for the ray caster's one
/// exponential a segment; [`PartialLanes`] vectorises it.
#[inline(always)]
pub(super) fn exp_neg(g: f64) -> f64 {
    const LN2_HI: f64 = 0.693_147_180_369_123_8; // 0x3FE62E42FEE00000
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const INV_LN2: f64 = std::f64::consts::LOG2_E;
    /// 2⁵²: `t + 2⁵² − 2⁵²` rounds `0 ≤ t < 2⁵¹` to an integer, exactly.
    const TWO52: f64 = 4_503_599_627_370_496.0;
    // exp(−708) ≈ 3e-308; beyond it, and for +∞, the result is 0 to the pixel (NaN stays): those
    // lanes compute on 0 and are replaced at the end.
    // (Each test a select of its own: `||`, nested `else if` or `max` keep LLVM from
    // vectorising the function.)
    let (nan, big) = (g.is_nan(), g >= 708.0);
    let g0 = if (g < 708.0) & (g > 0.0) { g } else { 0.0 };
    // k = ⌊g/ln 2 + 1/2⌋ (round to nearest, g ≥ 0): the integer nearest `t`, less one where that
    // is above `t` (what `t as i64` gives, without a conversion AVX2 lacks).
    let t = g0 * INV_LN2 + 0.5;
    let near = (t + TWO52) - TWO52;
    let kf = if near > t { near - 1.0 } else { near };
    // −r = −(g − k·ln 2), so e^{−g} = 2^{−k}·e^{x}, x = k·ln 2 − g ∈ [−0.35, 0.35].
    let x = (kf * LN2_HI - g0) + kf * LN2_LO;
    // Taylor coefficients 1/n!, n = 0..13, in Estrin's scheme.
    const C: [f64; 14] = [
        1.0,
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    let x2 = x * x;
    let x4 = x2 * x2;
    let x8 = x4 * x4;
    let p01 = C[0] + C[1] * x;
    let p23 = C[2] + C[3] * x;
    let p45 = C[4] + C[5] * x;
    let p67 = C[6] + C[7] * x;
    let p89 = C[8] + C[9] * x;
    let p1011 = C[10] + C[11] * x;
    let p1213 = C[12] + C[13] * x;
    let q0 = p01 + p23 * x2;
    let q1 = p45 + p67 * x2;
    let q2 = p89 + p1011 * x2;
    let lo = q0 + q1 * x4;
    let hi = q2 + p1213 * x4;
    let e = lo + hi * x8;
    // 2^{−k}, k ∈ [0, 1022]: a normal number; k is the low bits of kf + 2⁵².
    let k = (kf + TWO52).to_bits() - TWO52.to_bits();
    let r = e * f64::from_bits((1023 - k) << 52);
    let r = if big { 0.0 } else { r };
    if nan {
        g
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `partial`'s lane-wise segments are `segment`'s, bit for bit, on every lane of full and
    /// part-filled queues: crossings over the whole TF range and beyond it, thin and thick
    /// segments (optical depths from 1e-12 to past exp's range), NaN and infinite scalars.
    #[test]
    fn partial_segments_are_the_scalar_segments_bit_for_bit() {
        let tf = TransferFunction::preset("default").unwrap();
        let Shader::Partial(rc) = Shader::new("partial", &tf).unwrap() else {
            panic!("partial is RcPartial");
        };
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let odd = [f64::NAN, f64::INFINITY, -f64::INFINITY, -0.5, 1.5, 0.0, 1.0];
        for round in 0..4000 {
            let mut q = Queue::<Eval> {
                n: 1 + round % QUEUE,
                ..Default::default()
            };
            for k in 0..=QUEUE {
                let s = if round % 7 == 0 && k % 2 == round % 2 {
                    odd[(round / 7 + k) % odd.len()]
                } else {
                    next()
                };
                q.ends[k] = rc.end(s);
            }
            for l in &mut q.l {
                *l = 10f64.powf(-12.0 + 15.0 * next());
            }
            let lanes = rc.segments(&q);
            for k in 0..q.n {
                let (a, b) = (lanes.get(k), rc.segment(&q.ends[k], &q.ends[k + 1], q.l[k]));
                let bits = |g: Segment| [g.rgb[0], g.rgb[1], g.rgb[2], g.alpha].map(f64::to_bits);
                assert_eq!(bits(a), bits(b), "round {round}, lane {k}");
            }
        }
    }

    /// The TF from any hint (the right piece, a wrong one, none) is the TF from the bucket
    /// search, bit for bit: on `default`, on a TF with a repeated point (an empty piece) and a
    /// step, and on one point, for values inside, between and beyond the points, NaN and ±∞.
    #[test]
    fn tf_from_a_hint_is_the_tf_from_the_search() {
        let pt = |s: f64, tau: f64| crate::tf::TfPoint {
            s,
            rgb: [s, 1.0 - s, 0.5],
            tau,
        };
        let mut stepped = TransferFunction::preset("default").unwrap();
        stepped.points = vec![pt(0.0, 0.0), pt(0.3, 1.0), pt(0.3, 5.0), pt(0.7, 2.0), pt(1.0, 9.0)];
        let mut single = stepped.clone();
        single.points = vec![pt(0.4, 3.0)];
        for tf in [TransferFunction::preset("default").unwrap(), stepped, single] {
            let lt = LinearTf::new(&tf);
            let mut xs: Vec<f64> = (0..=2000).map(|i| -0.1 + 1.2 * i as f64 / 2000.0).collect();
            xs.extend(tf.points.iter().map(|p| p.s));
            xs.extend([f64::NAN, f64::INFINITY, -f64::INFINITY, 0.3f64.next_up(), 0.3f64.next_down()]);
            let bits = |(c, t): ([f64; 3], f64)| [c[0], c[1], c[2], t].map(f64::to_bits);
            let mut carried = u32::MAX;
            for &x in &xs {
                let want = bits(lt.eval(x));
                assert_eq!(bits(lt.eval_from(x, &mut carried)), want, "{} at {x}", tf.name);
                for h in 0..lt.pieces.len() as u32 + 2 {
                    let mut hint = h;
                    assert_eq!(bits(lt.eval_from(x, &mut hint)), want, "{} at {x}, hint {h}", tf.name);
                }
            }
        }
    }

    #[test]
    fn exp_neg_is_within_3_ulp_of_libm() {
        let mut worst = 0.0f64;
        let mut g = 0.0f64;
        let mut check = |g: f64| {
            let (a, b) = (exp_neg(g), (-g).exp());
            let ulp = (b.to_bits() as i64 - a.to_bits() as i64).abs() as f64;
            worst = worst.max(if b == 0.0 { a.abs() } else { ulp });
        };
        while g < 707.0 {
            check(g);
            check(g * 1.000_000_1 + 1e-300);
            g = g * 1.001 + 1e-9;
        }
        for g in [0.0, 1e-300, 1e-17, 1e-9, 0.346, 0.347, 0.5, 1.0, 10.0, 700.0, 707.9] {
            check(g);
        }
        assert!(worst <= 3.0, "{worst} ulp");
        assert_eq!(exp_neg(-1.0), 1.0);
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(f64::INFINITY), 0.0);
        assert_eq!(exp_neg(800.0), 0.0);
        assert!(exp_neg(f64::NAN).is_nan());
    }
}
