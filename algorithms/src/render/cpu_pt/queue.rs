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

use super::TILE;
use crate::optics::PsiTable;
use crate::optics_f32::{
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
                let at = simd.splat_f32s(h.at);
                let (bf, bb) = (simd.less_than_f32s(v.sf, at), simd.less_than_f32s(v.sb, at));
                for c in 0..4 {
                    let (d0, d1) = (simd.splat_f32s(h.below.c0[c]), simd.splat_f32s(h.below.c1[c]));
                    let (u0, u1) = (simd.splat_f32s(h.above.c0[c]), simd.splat_f32s(h.above.c1[c]));
                    let end = |below, s| {
                        let (c0, c1) = (simd.select_f32s(below, d0, u0), simd.select_f32s(below, d1, u1));
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

/// Composites shaded fragments (`out[c][k]`: channel c of fragment k) into the tile buffer
/// (`TILE`² pixels) at `pix[k]`, in order: back-to-front "over" (premultiplied),
/// `I ← I_seg + (1 − α_seg)·I`, a product then a sum per channel.
///
/// Four fragments at a time are turned from the batch's planes into pixels by a 4×4 transpose
/// in registers (`glam`'s `Mat4`: SSE2 or NEON), so that each fragment is one 16-byte load, a
/// product, a sum and a store (the scalar loop took 23 instructions a fragment, this ~15; each
/// operation rounds as the scalar one did, so the bits are the same).
#[inline(always)]
fn composite(out: &[[f32; BATCH]; 4], pix: &[u16], buf: &mut [[f32; 4]]) {
    use glam::{Mat4, Vec4, Vec4Swizzles};
    const PIXELS: usize = (TILE * TILE) as usize;
    // The masks below keep every index in the tile (no bounds check a fragment); the pixel
    // indices are below TILE² by construction, so a mask changes none of them.
    const _: () = assert!(PIXELS.is_power_of_two());
    let buf: &mut [[f32; 4]; PIXELS] = buf.try_into().expect("a tile's buffer");
    let over = |buf: &mut [[f32; 4]; PIXELS], p: u16, frag: Vec4| {
        let px = &mut buf[p as usize & (PIXELS - 1)];
        let keep = Vec4::ONE - frag.wwww();
        *px = (frag + keep * Vec4::from_array(*px)).to_array();
    };
    let [r, g, b, a] = out;
    let whole = pix.len() / 4 * 4;
    for (k, p4) in pix[..whole].chunks_exact(4).enumerate() {
        let k = 4 * k;
        let at = |c: &[f32; BATCH]| Vec4::from_slice(&c[k..k + 4]);
        let m = Mat4::from_cols(at(r), at(g), at(b), at(a)).transpose();
        over(buf, p4[0], m.x_axis);
        over(buf, p4[1], m.y_axis);
        over(buf, p4[2], m.z_axis);
        over(buf, p4[3], m.w_axis);
    }
    for (k, &p) in pix.iter().enumerate().skip(whole) {
        over(buf, p, Vec4::new(r[k], g[k], b[k], a[k]));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The transposed composite gives the scalar "over" loop's bits, on a batch whose length is
    /// not a multiple of four and whose fragments hit the same pixels again and again (so that
    /// the order counts).
    #[test]
    fn composite_is_the_scalar_over() {
        let mut rng = crate::pt::tests::Rng::new(11);
        let mut rnd = || rng.f() as f32;
        let px = (TILE * TILE) as usize;
        for n in [0, 1, 3, 4, 5, 23, BATCH] {
            let mut out = [[0.0f32; BATCH]; 4];
            let mut pix = [0u16; BATCH];
            for k in 0..n {
                let a = rnd();
                out[3][k] = a;
                for c in out.iter_mut().take(3) {
                    c[k] = rnd() * a;
                }
                pix[k] = ((rnd() * 7.0) as usize * 1031 % px) as u16;
            }
            let start: Vec<[f32; 4]> = (0..px).map(|_| [rnd(), rnd(), rnd(), rnd()]).collect();
            let mut want = start.clone();
            for k in 0..n {
                let p = &mut want[pix[k] as usize];
                let keep = 1.0 - out[3][k];
                for (c, v) in p.iter_mut().enumerate() {
                    *v = out[c][k] + keep * *v;
                }
            }
            let mut got = start;
            composite(&out, &pix[..n], &mut got);
            let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(bits(&got) == bits(&want), "n = {n}");
        }
    }
}
