//! The transfer function's pieces as lines, for [`TfTable::line_over`]: where a tet's scalars
//! lie on one piece of the TF, `cpu-pt` evaluates the TF there as `c0 + c1·s` instead of
//! looking the table up per fragment (see `render/cpu_pt/queue.rs`).

use super::{TfTable, TAU_MAX};
use crate::tf::TransferFunction;

/// One piece of the transfer function as a line in `s`: `[r, g, b, τ] = c0 + c1·s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfLine {
    pub c0: [f32; 4],
    pub c1: [f32; 4],
}

impl TfTable {
    /// The line the table follows over `[s0, s1]`, where the whole range lies on one piece of
    /// the TF inside the table's domain (else `None`): there [`TfTable::eval`] interpolates
    /// between samples of that line, so `c0 + c1·s` is its value up to f32 rounding (each
    /// sample is the TF rounded to f32; the line is the TF's piece computed in f64).
    #[inline]
    pub fn line_over(&self, s0: f32, s1: f32) -> Option<&TfLine> {
        let (x0, x1) = ((s0 - self.lo) * self.scale, (s1 - self.lo) * self.scale);
        // Also false for NaN.
        if !(x0 >= 0.0 && x1 <= self.max && x0 <= x1) {
            return None;
        }
        // The sample intervals of the ends (`max` itself is the last interval's end).
        let last = self.data.len() as u32 - 2;
        let (i0, i1) = ((x0 as u32).min(last), (x1 as u32).min(last));
        // The TF has a few pieces: the run starting last at or before `i0`, by search.
        let k = self.runs.partition_point(|r| r[0] <= i0).checked_sub(1)?;
        (i1 < self.runs[k][1]).then(|| &self.lines[k])
    }
}

/// The lines of [`TfTable`] and the sample intervals each covers (see `TfTable::runs`): each
/// piece of `tf` over the intervals `at(i)..at(i + 1)` it holds unbent, its line in f64
/// rounded to f32.
pub(super) fn pieces(
    tf: &TransferFunction,
    n: usize,
    at: impl Fn(usize) -> f64,
) -> (Vec<TfLine>, Vec<[u32; 2]>) {
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
    (lines, runs)
}
