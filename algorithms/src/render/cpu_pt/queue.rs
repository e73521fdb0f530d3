//! The fragment queue of `cpu-pt`'s fast path: fragments wait here, in the order they are
//! rasterised, until a batch is full; then the batch is shaded at once and composited in queue
//! order (the order a per-fragment loop would composite in, so the image is the same).
//!
//! Two kinds of batch:
//! - `partial` queues each fragment's **colours** at both ends ([`ColourBatch`]): for a tet
//!   whose scalars lie on one piece of the transfer function, or on two pieces meeting at one
//!   control point ([`TfTable::span_over`]), they are `c0 + c1·s`, a multiply-add per channel
//!   and lane (at a hinge, `c0` and `c1` chosen per lane by the side of the point); for the
//!   others the table is looked up per fragment;
//! - `average` and `preint` queue the scalars and the length ([`ShadeBatch`]).

use super::composite::composite;
use crate::optics::PsiTable;
use crate::optics::fast::{
    shade_colours, ColourBatch, FastIntegrator, ShadeBatch, TfSpan, TfTable, BATCH,
};

/// See the module documentation.
pub(super) struct Queue<'a> {
    integ: &'a FastIntegrator,
    /// `partial`'s table and Ψ: the queue holds colours.
    colours: Option<(&'a TfTable, &'a PsiTable)>,
    scalars: ShadeBatch,
    col: ColourBatch,
    pix: [u16; BATCH],
    len: usize,
    /// Fragments shaded so far.
    pub(super) frags: u64,
}

/// A vector of lanes the span kernel hands the queue: the ends' scalars and the length, and how
/// many of its lanes are fragments.
#[derive(Clone, Copy)]
pub(super) struct Lanes<V> {
    pub(super) sf: V,
    pub(super) sb: V,
    pub(super) l: V,
    pub(super) count: usize,
}

impl<'a> Queue<'a> {
    pub(super) fn new(integ: &'a FastIntegrator) -> Queue<'a> {
        let colours = match integ {
            FastIntegrator::Partial(t, psi) => Some((t, &**psi)),
            _ => None,
        };
        Queue {
            integ,
            colours,
            scalars: ShadeBatch::default(),
            col: ColourBatch::default(),
            pix: [0; BATCH],
            len: 0,
            frags: 0,
        }
    }

    /// The lines of `tf` over a tet's scalars `s`, when the queue holds colours and they lie on
    /// one piece or two ([`TfTable::span_over`]; `None` otherwise: the table is looked up per
    /// fragment).
    #[inline(always)]
    pub(super) fn span(&self, s: &[f32; 4]) -> Option<TfSpan<'a>> {
        let (tf, _) = self.colours?;
        let lo = s[0].min(s[1]).min(s[2].min(s[3]));
        let hi = s[0].max(s[1]).max(s[2].max(s[3]));
        tf.span_over(lo, hi)
    }

    /// Makes room for `n` more slots (flushing when they do not fit).
    #[inline(always)]
    pub(super) fn reserve(&mut self, n: usize, buf: &mut [[f32; 4]]) {
        if self.len + n > BATCH {
            self.flush(buf);
        }
    }

    /// Queues one fragment at pixel `p` (room for one must have been made).
    #[inline(always)]
    pub(super) fn push(&mut self, span: Option<TfSpan>, sf: f32, sb: f32, l: f32, p: u16) {
        let k = self.len;
        if let Some((tf, _)) = self.colours {
            let (cf, cb, l) = colours(tf, span, sf, sb, l);
            for c in 0..4 {
                self.col.cf[c][k] = cf[c];
                self.col.cb[c][k] = cb[c];
            }
            self.col.l[k] = l;
        } else {
            self.scalars.sf[k] = sf;
            self.scalars.sb[k] = sb;
            self.scalars.l[k] = l;
        }
        self.pix[k] = p;
    }

    /// Advances the queue by `n` slots written with [`Queue::push`] (0 or 1: a pixel outside
    /// the fan is written and not taken).
    #[inline(always)]
    pub(super) fn advance(&mut self, n: usize) {
        self.len += n;
    }

    /// Queues the first `v.count` lanes of a vector, at pixels `p0, p0 + 1, …` (room for the
    /// whole vector must have been made: all its lanes are written).
    #[inline(always)]
    pub(super) fn push_lanes<S: pulp::Simd>(
        &mut self,
        simd: S,
        span: Option<TfSpan>,
        v: Lanes<S::f32s>,
        p0: u16,
    ) {
        let lanes = S::F32_LANES;
        let at = self.len;
        // A whole vector a store: `partial_store` took pulp's masked-store path (a call a
        // store) even for a full vector.
        let put = |dst: &mut [f32; BATCH], x: S::f32s| {
            S::as_mut_simd_f32s(&mut dst[at..at + lanes]).0[0] = x;
        };
        match (self.colours, span) {
            (None, _) => {
                put(&mut self.scalars.sf, v.sf);
                put(&mut self.scalars.sb, v.sb);
                put(&mut self.scalars.l, v.l);
            }
            (Some(_), Some(TfSpan::Line(line))) => {
                for c in 0..4 {
                    let (c0, c1) = (simd.splat_f32s(line.c0[c]), simd.splat_f32s(line.c1[c]));
                    put(&mut self.col.cf[c], simd.mul_add_f32s(c1, v.sf, c0));
                    put(&mut self.col.cb[c], simd.mul_add_f32s(c1, v.sb, c0));
                }
                put(&mut self.col.l, v.l);
            }
            (Some(_), Some(TfSpan::Hinge(h))) => {
                // Each end's line by its side of the point (`TfSpan::eval`'s choice: below
                // where s < at, so a NaN takes the line above and stays NaN).
                let (at, [below, above]) = (simd.splat_f32s(h.at), h.lines);
                let (bf, bb) = (simd.less_than_f32s(v.sf, at), simd.less_than_f32s(v.sb, at));
                for c in 0..4 {
                    let (d0, d1) = (simd.splat_f32s(below.c0[c]), simd.splat_f32s(below.c1[c]));
                    let (u0, u1) = (simd.splat_f32s(above.c0[c]), simd.splat_f32s(above.c1[c]));
                    let end = |lower, s| {
                        let (c0, c1) = (simd.select_f32s(lower, d0, u0), simd.select_f32s(lower, d1, u1));
                        simd.mul_add_f32s(c1, s, c0)
                    };
                    put(&mut self.col.cf[c], end(bf, v.sf));
                    put(&mut self.col.cb[c], end(bb, v.sb));
                }
                put(&mut self.col.l, v.l);
            }
            (Some((tf, _)), None) => {
                if lanes <= 4 {
                    self.table_lanes::<S, 4>(tf, v, at);
                } else if lanes <= 8 {
                    self.table_lanes::<S, 8>(tf, v, at);
                } else {
                    self.table_lanes::<S, 16>(tf, v, at);
                }
            }
        }
        for (j, p) in self.pix[at..at + lanes].iter_mut().enumerate() {
            *p = p0.wrapping_add(j as u16);
        }
        self.len += v.count;
    }

    /// The table's colours at both ends of a vector's lanes, from slot `at` on (all `S`'s
    /// lanes written; `N` ≥ its lanes): [`colours`] lane-wise, without a line.
    #[inline(always)]
    fn table_lanes<S: pulp::Simd, const N: usize>(
        &mut self,
        tf: &TfTable,
        v: Lanes<S::f32s>,
        at: usize,
    ) {
        let lanes = S::F32_LANES.min(N);
        let mut ends = [[0.0f32; N]; 3];
        for (e, x) in ends.iter_mut().zip([v.sf, v.sb, v.l]) {
            S::as_mut_simd_f32s(&mut e[..S::F32_LANES]).0[0] = x;
        }
        let [sf, sb, l] = &ends;
        let (mut cf, mut cb) = ([[0.0f32; N]; 4], [[0.0f32; N]; 4]);
        tf.eval_lanes(sf, &mut cf);
        tf.eval_lanes(sb, &mut cb);
        // A non-finite scalar at either end: no contribution (as `colours`). Length 0 is
        // enough: the colour kernel gives such a segment 0 whatever its colours.
        let mut lv = [0.0f32; N];
        for k in 0..N {
            let ok = sf[k].is_finite() && sb[k].is_finite();
            lv[k] = if ok { l[k] } else { 0.0 };
        }
        for c in 0..4 {
            self.col.cf[c][at..at + lanes].copy_from_slice(&cf[c][..lanes]);
            self.col.cb[c][at..at + lanes].copy_from_slice(&cb[c][..lanes]);
        }
        self.col.l[at..at + lanes].copy_from_slice(&lv[..lanes]);
    }

    /// Shades the queued fragments and composites them into `buf` in queue order.
    #[inline]
    pub(super) fn flush(&mut self, buf: &mut [[f32; 4]]) {
        let n = self.len;
        if n == 0 {
            return;
        }
        let out = if let Some((_, psi)) = self.colours {
            self.col.len = n;
            shade_colours(psi, &mut self.col);
            &self.col.out
        } else {
            self.scalars.len = n;
            self.integ.shade_batch(&mut self.scalars);
            &self.scalars.out
        };
        composite(out, &self.pix[..n], buf);
        self.frags += n as u64;
        self.len = 0;
    }
}

/// A fragment's colours at both ends and its length: from the tet's lines when it has them,
/// else from the table (a non-finite scalar gives length 0: no contribution, as `segment`).
#[inline(always)]
fn colours(tf: &TfTable, span: Option<TfSpan>, sf: f32, sb: f32, l: f32) -> ([f32; 4], [f32; 4], f32) {
    match span {
        Some(t) => (t.eval(sf), t.eval(sb), l),
        None if sf.is_finite() && sb.is_finite() => (tf.eval(sf), tf.eval(sb), l),
        None => ([0.0; 4], [0.0; 4], 0.0),
    }
}
