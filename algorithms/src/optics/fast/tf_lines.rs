//! The transfer function's pieces as lines, for [`TfTable::span_over`]: where a tet's scalars
//! lie on one piece of the TF, or on two pieces meeting at one control point, `cpu-pt`
//! evaluates the TF there as `c0 + c1·s` (the hinge's line chosen by the side of the point)
//! instead of looking the table up per fragment (see `render/cpu_pt/queue.rs`).

use super::{TfTable, TAU_MAX};
use crate::tf::TransferFunction;

/// One piece of the transfer function as a line in `s`: `[r, g, b, τ] = c0 + c1·s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfLine {
    pub c0: [f32; 4],
    pub c1: [f32; 4],
}

/// Two pieces of the transfer function meeting at one control point `at`: `lines[0]` for
/// `s < at`, `lines[1]` from `at` on. Across the point this is the TF itself (to f32 rounding),
/// where the table holds, in the one sample interval around `at`, the chord between its two
/// samples (off the TF by up to `|Δslope|·Δs/4`, [`super`]'s module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfHinge<'a> {
    pub at: f32,
    /// Consecutive lines of the table (one reference, so that a [`TfSpan`] is two words).
    pub lines: &'a [TfLine; 2],
}

/// The transfer function over a tet's scalar range, as `cpu-pt` evaluates it per fragment.
#[derive(Clone, Copy, Debug)]
pub enum TfSpan<'a> {
    /// The range lies on one piece.
    Line(&'a TfLine),
    /// The range crosses one control point, and the pieces on either side are lines.
    Hinge(TfHinge<'a>),
}

impl TfSpan<'_> {
    /// `[r, g, b, τ]` at `s`: `c0 + c1·s` of the line `s` lies on (a product, then a sum).
    #[inline(always)]
    pub fn eval(&self, s: f32) -> [f32; 4] {
        let t = match self {
            TfSpan::Line(t) => t,
            TfSpan::Hinge(h) if s < h.at => &h.lines[0],
            TfSpan::Hinge(h) => &h.lines[1],
        };
        std::array::from_fn(|c| t.c0[c] + t.c1[c] * s)
    }
}

impl TfTable {
    /// The TF over `[s0, s1]` as lines, where the whole range lies inside the table's domain
    /// and on one piece of the TF ([`TfSpan::Line`]: there [`TfTable::eval`] interpolates
    /// between samples of that line, so `c0 + c1·s` is its value up to f32 rounding; each
    /// sample is the TF rounded to f32, the line is the TF's piece computed in f64), or on two
    /// pieces with one control point between them ([`TfSpan::Hinge`]); else `None` (the
    /// table is looked up).
    // Always inlined: out of line (with a hinge, `Option<TfSpan>` is returned through memory)
    // it was compiled for the SSE2 baseline, outside the draw's dispatch.
    #[inline(always)]
    pub fn span_over(&self, s0: f32, s1: f32) -> Option<TfSpan<'_>> {
        let (x0, x1) = ((s0 - self.lo) * self.scale, (s1 - self.lo) * self.scale);
        // Also false for NaN.
        if !(x0 >= 0.0 && x1 <= self.max && x0 <= x1) {
            return None;
        }
        // The sample intervals of the ends (`max` itself is the last interval's end).
        let last = self.data.len() as u32 - 2;
        let (i0, i1) = ((x0 as u32).min(last), (x1 as u32).min(last));
        // The TF has a few pieces: the run starting last at or before `i0`, by search. (A
        // table of each sample interval's run saved 7.4 M of post's 1 209 M draw instructions
        // for 16 KB more per renderer, which its bytes per tet showed; a branch-free count
        // over the runs saved 2 M.)
        let k = self.runs.partition_point(|r| r[0] <= i0).checked_sub(1)?;
        if i1 < self.runs[k][1] {
            return Some(TfSpan::Line(&self.lines[k]));
        }
        // Past run k: the hinge to run k + 1, if there is one (then `i0` is in run k or in
        // the one bent interval between them) and the range ends in run k + 1.
        let at = *self.joins.get(k)?;
        (!at.is_nan() && i1 < self.runs[k + 1][1]).then(|| {
            TfSpan::Hinge(TfHinge {
                at,
                lines: self.lines[k..k + 2].try_into().expect("a run after run k"),
            })
        })
    }
}

/// The lines of [`TfTable`] and the sample intervals each covers (see `TfTable::runs`): each
/// piece of `tf` over the intervals `at(i)..at(i + 1)` it holds unbent, its line in f64
/// rounded to f32; and between each two consecutive runs the control point that joins them
/// (NaN where none does: see [`joins`]).
pub(super) fn pieces(
    tf: &TransferFunction,
    n: usize,
    at: impl Fn(usize) -> f64,
) -> (Vec<TfLine>, Vec<[u32; 2]>, Vec<f32>) {
    let mut lines: Vec<TfLine> = Vec::new();
    let mut runs: Vec<[u32; 2]> = Vec::new();
    // Whether the last interval was on the last line.
    let mut on_line = false;
    let value = |s: f64| {
        let (c, tau) = tf.eval(s);
        [c[0], c[1], c[2], tau]
    };
    for i in 0..n - 1 {
        let (a, b) = (at(i), at(i + 1));
        let (va, vb) = (value(a), value(b));
        let bent = !tf.points_between(a, b).is_empty();
        if bent || va[3] > TAU_MAX || vb[3] > TAU_MAX || b <= a || b.is_nan() {
            on_line = false;
            continue;
        }
        // A control point at the interval's start begins a new piece.
        let k = tf.points.partition_point(|q| q.s < a);
        if !on_line || tf.points.get(k).is_some_and(|q| q.s == a) {
            let c1: [f64; 4] = std::array::from_fn(|c| (vb[c] - va[c]) / (b - a));
            lines.push(TfLine {
                c0: std::array::from_fn(|c| (va[c] - c1[c] * a) as f32),
                c1: c1.map(|v| v as f32),
            });
            runs.push([i as u32, i as u32]);
            on_line = true;
        }
        if let Some(r) = runs.last_mut() {
            r[1] = i as u32 + 1;
        }
    }
    let joins = joins(tf, &runs, at);
    (lines, runs, joins)
}

/// The point joining runs k and k + 1 of [`pieces`] into a hinge, entry k: where the second
/// starts at the sample the first ends at (a control point on that sample began a new piece)
/// or one interval later (a control point strictly inside that interval bent it), and exactly
/// one control point lies between (closed), with τ not capped at either sample; NaN otherwise
/// (two points in one interval, a step, a gap of τ beyond [`TAU_MAX`]). (The point alone, not
/// the hinge's two lines again: those were ~216 bytes more a renderer.)
fn joins(tf: &TransferFunction, runs: &[[u32; 2]], at: impl Fn(usize) -> f64) -> Vec<f32> {
    (1..runs.len())
        .map(|k| {
            let (end, start) = (runs[k - 1][1] as usize, runs[k][0] as usize);
            if start > end + 1 {
                return None;
            }
            let (a, b) = (at(end), at(start));
            let mut inside = tf.points.iter().filter(|p| a <= p.s && p.s <= b);
            let (Some(p), None) = (inside.next(), inside.next()) else {
                return None;
            };
            let capped = |s: f64| tf.eval(s).1 > TAU_MAX;
            if capped(a) || capped(b) {
                return None;
            }
            Some(p.s as f32)
        })
        .map(|p| p.unwrap_or(f32::NAN))
        .collect()
}
