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

/// `TfTable::piece` of an interval on no line.
pub(super) const NO_LINE: u16 = u16::MAX;

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
        let last = self.piece.len() - 1;
        let (i0, i1) = ((x0 as usize).min(last), (x1 as usize).min(last));
        let p = self.piece[i0];
        if p == NO_LINE || self.piece[i1] != p {
            return None;
        }
        self.lines.get(p as usize)
    }
}

/// The lines of [`TfTable`]: per interval of samples `at(i)..at(i + 1)`, its piece of `tf`
/// (see `TfTable::piece`) and each piece's line in f64, rounded to f32.
pub(super) fn pieces(
    tf: &TransferFunction,
    n: usize,
    at: impl Fn(usize) -> f64,
) -> (Vec<u16>, Vec<TfLine>) {
    let mut piece = vec![NO_LINE; n - 1];
    let mut lines: Vec<TfLine> = Vec::new();
    let mut cur = NO_LINE;
    let value = |s: f64| {
        let (c, tau) = tf.eval(s);
        [c[0], c[1], c[2], tau]
    };
    for (i, p) in piece.iter_mut().enumerate() {
        let (a, b) = (at(i), at(i + 1));
        let (va, vb) = (value(a), value(b));
        let bent = !tf.points_between(a, b).is_empty();
        if bent
            || va[3] > TAU_MAX
            || vb[3] > TAU_MAX
            || b <= a
            || b.is_nan()
            || lines.len() >= NO_LINE as usize
        {
            cur = NO_LINE;
            continue;
        }
        // A control point at the interval's start begins a new piece.
        let k = tf.points.partition_point(|q| q.s < a);
        if cur == NO_LINE || tf.points.get(k).is_some_and(|q| q.s == a) {
            let c1: [f64; 4] = std::array::from_fn(|c| (vb[c] - va[c]) / (b - a));
            lines.push(TfLine {
                c0: std::array::from_fn(|c| (va[c] - c1[c] * a) as f32),
                c1: c1.map(|v| v as f32),
            });
            cur = (lines.len() - 1) as u16;
        }
        *p = cur;
    }
    (piece, lines)
}
