//! What the walk integrates with. Every crossing is the back of one segment and the front of
//! the next, so the transfer function is evaluated once per crossing ([`Shade::end`]) instead
//! of twice per segment, and the walk is compiled once per integrator kind instead of calling
//! it through a `dyn` pointer. `exact` takes those values through its `segment_eval` (the
//! same arithmetic as `Integrator::segment`, so the same bits). `partial` ([`RcPartial`])
//! finds the transfer function's pieces from a bucket table and evaluates them with
//! precomputed slopes (f64, last bits only against `TransferFunction::eval`), and computes
//! the segment's optics in f32 with `cpu-pt`'s colour kernel, a queue of segments a call: its
//! rounding (~1e-7) is far below `partial`'s own error against `exact` (~1e-4 RMSE).

use crate::optics::{Exact, Integrator, Partial, Segment};
use crate::optics::fast::{colour_lanes_n, segment_from_colours, TAU_MAX};
use crate::tf::TransferFunction;

/// A per-segment integrator as the walk calls it.
pub(super) trait Shade: Sync {
    /// The transfer function's values at one crossing.
    type End: Copy + Default;
    fn end(&self, s: f64) -> Self::End;
    /// The segment between two crossings of optical length `l > 0`.
    fn segment(&self, front: &Self::End, back: &Self::End, l: f64) -> Segment;
    /// The first `q.n` queued segments, each what [`Shade::segment`] gives for it, bit for
    /// bit (`partial` computes them lane-wise); a segment of no length (`l ≤ 0`) is zero, so
    /// that compositing it changes nothing.
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

/// Lanes `partial`'s colour kernel runs on for a queue (see [`PartialLanes`]).
const KERNEL_LANES: usize = 16;

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
    Exact(RcExact),
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
            "exact" => Shader::Exact(RcExact {
                e: Exact::new(tf),
                arch: pulp::Arch::new(),
            }),
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

/// `partial` as the ray caster runs it: the transfer function as a [`LinearTf`] (f64), the
/// segments from [`Partial`]'s Ψ table by `cpu-pt`'s f32 colour kernel.
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

    /// [`colour`] of the TF at `s0` (a queue's first crossing, scalar) and at the first `n`
    /// of `s` (its crossings after that; the lanes past them are anything), as lanes:
    /// `out[c][k]` is channel `c` at `s[k]`. When all of them lie inside the piece of `s0` —
    /// along a ray, most queues — the piece is the one the scalar look-up of `s0` found and
    /// the `lerp` is lane-wise, else each is evaluated alone. The same bits either way: the
    /// piece holding a value is one ([`LinearTf::eval_from`]), and the lanes repeat `lerp`'s
    /// and `colour`'s operations.
    #[inline(always)]
    fn colours<const N: usize>(&self, s0: f64, s: &[f64; N], n: usize) -> ([f32; 4], [[f32; N]; 4]) {
        let last = self.pieces.len() - 1;
        let mut h = u32::MAX;
        let front = colour(s0, self.eval_from(s0, &mut h));
        if let Some(pc) = self.pieces.get(h as usize) {
            // (As `eval_from`'s hint test, lane by lane, or-reduced: vector compares.)
            let mut outside = 0u64;
            for (k, &x) in s.iter().enumerate() {
                let inside = (pc.s <= x) & (x < pc.s_next) & (x > self.s0);
                outside |= !(inside | (k >= n)) as u64;
            }
            if (h as usize != last) & (outside == 0) {
                let (v, m) = (&pc.val, &pc.slope);
                let d: [f64; N] = s.map(|x| x - pc.s);
                let mut out = [[0.0f32; N]; 4];
                for c in 0..3 {
                    out[c] = std::array::from_fn(|k| (v[c] + d[k] * m[c]) as f32);
                }
                // (Finite: every s is inside a piece of finite extent.)
                out[3] = std::array::from_fn(|k| clamp_tau(v[3] + d[k] * m[3]));
                return (front, out);
            }
        }
        let mut out = [[0.0f32; N]; 4];
        for (k, &x) in s.iter().enumerate().take(n) {
            let e = colour(x, self.eval_from(x, &mut h));
            for c in 0..4 {
                out[c][k] = e[c];
            }
        }
        (front, out)
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
    /// The crossing's scalar: the transfer function is evaluated a queue at a time, lane-wise
    /// ([`PartialLanes`]).
    type End = f64;
    /// [`RcPartial::segment`] lane-wise, compiled for the best instruction set of the CPU
    /// (x86-64-v3 where present, by `pulp`'s dispatch).
    #[inline(always)]
    fn segments(&self, q: &Queue<f64>) -> Lanes {
        self.arch.dispatch(PartialLanes { rc: self, q })
    }
    #[inline(always)]
    fn end(&self, s: f64) -> f64 {
        s
    }
    /// `partial`'s f32 segment from the colours at its ends, as `cpu-pt` computes it
    /// ([`segment_from_colours`]): the ray caster's geometry (the walk, the crossings' depths
    /// and scalars, the TF) stays f64, and only the segment's optics are f32, whose rounding
    /// (~1e-7 relative, the f32 exponential's 2e-6 at most) is far inside `partial`'s own error
    /// against `exact` (RMSE ~1e-4 on the NASA grids).
    #[inline(always)]
    fn segment(&self, f: &f64, b: &f64, l: f64) -> Segment {
        let (cf, cb) = (colour(*f, self.tf.eval(*f)), colour(*b, self.tf.eval(*b)));
        let o = segment_from_colours(self.p.table(), cf, cb, l as f32);
        Segment {
            rgb: [o[0] as f64, o[1] as f64, o[2] as f64],
            alpha: o[3] as f64,
        }
    }
}

/// A crossing's TF values as [`RcPartial`] queues them: f32, τ clamped to the f32 tables'
/// largest ([`TAU_MAX`]), NaN for a scalar that is not finite.
#[inline(always)]
fn colour(s: f64, (c, tau): ([f64; 3], f64)) -> [f32; 4] {
    let tau = if s.is_finite() {
        clamp_tau(tau)
    } else {
        f32::NAN
    };
    [c[0] as f32, c[1] as f32, c[2] as f32, tau]
}

/// A finite τ in f32, at most [`TAU_MAX`] (a select, not `min`'s NaN handling).
#[inline(always)]
fn clamp_tau(tau: f64) -> f32 {
    (if tau < TAU_MAX { tau } else { TAU_MAX }) as f32
}

/// [`RcPartial::segment`] over a queue as a `pulp` operation: the TF at the queue's crossings
/// ([`LinearTf::colours`]), in lanes (segment `k`'s front is crossing `k`, its back crossing
/// `k + 1`), and `cpu-pt`'s lane-wise colour kernel ([`colour_lanes_n`], `segment_from_colours`'s operations
/// lane by lane, so its bits). Lanes past `q.n` are computed and ignored.
struct PartialLanes<'a> {
    rc: &'a RcPartial,
    q: &'a Queue<f64>,
}

impl pulp::WithSimd for PartialLanes<'_> {
    type Output = Lanes;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Lanes {
        let q = self.q;
        // Crossing 0 is segment 0's front; crossings 1..=QUEUE are the backs, and the fronts
        // of segments 1.. are the backs shifted by a lane.
        let backs: [f64; QUEUE] = std::array::from_fn(|k| q.ends[k + 1]);
        let (e0, cb) = self.rc.tf.colours(q.ends[0], &backs, q.n);
        let cf: [[f32; QUEUE]; 4] =
            std::array::from_fn(|c| std::array::from_fn(|k| if k == 0 { e0[c] } else { cb[c][k - 1] }));
        // The kernel on KERNEL_LANES lanes, the queue's in the first ones and length 0 (no
        // contribution, not read) in the rest: LLVM's loop vectoriser leaves a loop of fewer
        // than 16 iterations alone, and on 8 lanes the kernel was scalar.
        let pad = |a: &[f32; QUEUE]| -> [f32; KERNEL_LANES] {
            std::array::from_fn(|k| if k < QUEUE { a[k] } else { 0.0 })
        };
        let (cf, cb) = (cf.each_ref().map(pad), cb.each_ref().map(pad));
        let l = pad(&q.l.map(|l| l as f32));
        let mut o = [[0.0f32; KERNEL_LANES]; 4];
        colour_lanes_n(self.rc.p.table(), &cf, &cb, &l, &mut o);
        Lanes {
            rgb: std::array::from_fn(|c| std::array::from_fn(|k| o[c][k] as f64)),
            alpha: std::array::from_fn(|k| o[3][k] as f64),
        }
    }
}

/// `exact` as the ray caster runs it: [`Exact::segment_eval`] on each queued segment, the queue
/// compiled for the best instruction set of the CPU (x86-64-v3 where present, by `pulp`'s
/// dispatch), so that the exponentials of its quadrature run in vector lanes. The same
/// operations on any instruction set (no contraction into FMA), so the same bits.
pub(super) struct RcExact {
    e: Exact,
    arch: pulp::Arch,
}

impl Shade for RcExact {
    type End = Eval;
    #[inline(always)]
    fn end(&self, s: f64) -> Eval {
        let (c, tau) = self.e.tf().eval(s);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn segment(&self, f: &Eval, b: &Eval, l: f64) -> Segment {
        self.e.segment_eval(f.s, (f.c, f.tau), b.s, (b.c, b.tau), l)
    }
    #[inline(always)]
    fn segments(&self, q: &Queue<Eval>) -> Lanes {
        self.arch.dispatch(ExactLanes { rc: self, q })
    }
}

/// [`RcExact::segment`] over a queue as a `pulp` operation.
struct ExactLanes<'a> {
    rc: &'a RcExact,
    q: &'a Queue<Eval>,
}

impl pulp::WithSimd for ExactLanes<'_> {
    type Output = Lanes;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Lanes {
        let (rc, q) = (self.rc, self.q);
        let mut out = Lanes::default();
        for k in 0..q.n {
            if q.l[k] > 0.0 {
                out.set(k, rc.segment(&q.ends[k], &q.ends[k + 1], q.l[k]));
            }
        }
        out
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `partial`'s lane-wise segments are `segment`'s, bit for bit, on every lane of full and
    /// part-filled queues: crossings over the whole TF range and beyond it and crossings close
    /// together (most queues then lie in one piece of the TF), thin and thick segments
    /// (optical depths from 1e-12 to past exp's range), NaN and infinite scalars, and NaN in
    /// the lanes past the queue.
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
            let mut q = Queue::<f64> {
                n: 1 + round % QUEUE,
                ..Default::default()
            };
            let centre = next();
            for k in 0..=QUEUE {
                let s = if k > q.n && round % 5 == 0 {
                    f64::NAN
                } else if round % 7 == 0 && k % 2 == round % 2 {
                    odd[(round / 7 + k) % odd.len()]
                } else if round % 3 == 1 {
                    centre + 0.01 * next()
                } else {
                    next()
                };
                q.ends[k] = rc.end(s);
            }
            for (k, l) in q.l.iter_mut().enumerate() {
                *l = match (round + k) % 11 {
                    0 => 0.0,
                    1 => -1e-9,
                    _ => 10f64.powf(-12.0 + 15.0 * next()),
                };
            }
            let lanes = rc.segments(&q);
            let bits = |g: Segment| [g.rgb[0], g.rgb[1], g.rgb[2], g.alpha].map(f64::to_bits);
            for k in 0..q.n {
                let a = lanes.get(k);
                if q.l[k] > 0.0 {
                    let b = rc.segment(&q.ends[k], &q.ends[k + 1], q.l[k]);
                    assert_eq!(bits(a), bits(b), "round {round}, lane {k}");
                } else {
                    // A segment of no length is zero: compositing it changes nothing.
                    assert_eq!(bits(a), [0; 4], "round {round}, lane {k}: l = {}", q.l[k]);
                }
            }
        }
    }

    /// A TF point at `s` with extinction `tau` (colour from `s`).
    fn tf_point(s: f64, tau: f64) -> crate::tf::TfPoint {
        crate::tf::TfPoint {
            s,
            rgb: [s, 1.0 - s, 0.5],
            tau,
        }
    }

    /// A TF with a repeated point (an empty piece) and a step in τ at 0.3.
    fn stepped_tf() -> TransferFunction {
        let mut tf = TransferFunction::preset("default").unwrap();
        tf.points = [(0.0, 0.0), (0.3, 1.0), (0.3, 5.0), (0.7, 2.0), (1.0, 9.0)]
            .map(|(s, tau)| tf_point(s, tau))
            .to_vec();
        tf
    }

    /// The TF's colours lane-wise are the TF's value by value, bit for bit, on `default` and
    /// on a TF with an empty piece and a step: for runs of scalars inside one piece (the
    /// lane-wise path, taken in most of the cases here), across pieces, at and beyond the
    /// points, with NaN and ±∞, and with anything in the lanes past `n`.
    #[test]
    fn tf_colours_are_the_tf_value_by_value() {
        let stepped = stepped_tf();
        let mut rng = crate::util::rng::Rng::new(17);
        let mut next = || rng.f();
        let odd = [f64::NAN, f64::INFINITY, -f64::INFINITY, 0.0, 0.3, 0.7, 1.0];
        for tf in [TransferFunction::preset("default").unwrap(), stepped] {
            let lt = LinearTf::new(&tf);
            let mut one_piece = 0;
            for round in 0..3000 {
                let n = 1 + round % (QUEUE + 1);
                let centre = 1.2 * next() - 0.1;
                let spread = [1e-6, 1e-3, 0.05, 1.0][round % 4];
                let s: [f64; QUEUE + 1] = std::array::from_fn(|k| match (k >= n, round % 9) {
                    (true, 0) => f64::NAN,
                    (false, 1) if k == n / 2 => odd[round / 9 % odd.len()],
                    _ => centre + spread * next(),
                });
                let pieces: Vec<u32> = s[..n]
                    .iter()
                    .map(|&x| {
                        let mut h = u32::MAX;
                        let _ = lt.eval_from(x, &mut h);
                        h
                    })
                    .collect();
                if pieces[0] != u32::MAX && pieces.iter().all(|&h| h == pieces[0]) {
                    one_piece += 1;
                }
                let backs: [f64; QUEUE] = std::array::from_fn(|k| s[k + 1]);
                let (front, got) = lt.colours(s[0], &backs, n - 1);
                for (k, &x) in s.iter().enumerate().take(n) {
                    let want = colour(x, lt.eval(x));
                    let lane: [f32; 4] = match k {
                        0 => front,
                        _ => std::array::from_fn(|c| got[c][k - 1]),
                    };
                    assert_eq!(lane.map(f32::to_bits), want.map(f32::to_bits), "{} {round} lane {k}: {x}", tf.name);
                }
            }
            assert!(one_piece > 1000, "{}: {one_piece} runs in one piece", tf.name);
        }
    }

    /// The TF from any hint (the right piece, a wrong one, none) is the TF from the bucket
    /// search, bit for bit: on `default`, on a TF with a repeated point (an empty piece) and a
    /// step, and on one point, for values inside, between and beyond the points, NaN and ±∞.
    #[test]
    fn tf_from_a_hint_is_the_tf_from_the_search() {
        let stepped = stepped_tf();
        let mut single = stepped.clone();
        single.points = vec![tf_point(0.4, 3.0)];
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
}
