//! The composite of `cpu-pt`'s fast path: a batch of shaded fragments into a tile's buffer, in
//! queue order.

use super::TILE;
use crate::optics::fast::BATCH;

/// Pixels of a tile's buffer.
const PIXELS: usize = (TILE * TILE) as usize;
// The masks below keep every index in the tile (no bounds check a fragment); the pixel indices
// are below TILE² by construction, so a mask changes none of them.
const _: () = assert!(PIXELS.is_power_of_two());

/// Composites shaded fragments (`out[c][k]`: channel c of fragment k) into the tile buffer
/// (`TILE`² pixels) at `pix[k]`, in order: back-to-front "over" (premultiplied),
/// `I ← I_seg + (1 − α_seg)·I`, a product then a sum per channel. Compiled for the best
/// instruction set of the CPU (`pulp`'s dispatch): with AVX2, [`composite_v3`].
pub(super) fn composite(out: &[[f32; BATCH]; 4], pix: &[u16], buf: &mut [[f32; 4]]) {
    let buf: &mut [[f32; 4]; PIXELS] = buf.try_into().expect("a tile's buffer");
    pulp::Arch::new().dispatch(Composite { out, pix, buf })
}

struct Composite<'a> {
    out: &'a [[f32; BATCH]; 4],
    pix: &'a [u16],
    buf: &'a mut [[f32; 4]; PIXELS],
}

impl pulp::WithSimd for Composite<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let Composite { out, pix, buf } = self;
        #[cfg(target_arch = "x86_64")]
        if let Some(&v3) = (&simd as &dyn std::any::Any).downcast_ref::<pulp::x86::V3>() {
            let done = composite_v3(v3, out, pix, buf);
            return composite_from(out, pix, buf, done);
        }
        let _ = simd;
        composite_from(out, pix, buf, 0)
    }
}

/// "Over" of one fragment `[r, g, b, α]` onto pixel `p`.
#[inline(always)]
fn over(buf: &mut [[f32; 4]; PIXELS], p: u16, frag: glam::Vec4) {
    use glam::{Vec4, Vec4Swizzles};
    let px = &mut buf[p as usize & (PIXELS - 1)];
    let keep = Vec4::ONE - frag.wwww();
    *px = (frag + keep * Vec4::from_array(*px)).to_array();
}

/// [`composite`] from fragment `start` on, four fragments at a time turned from the batch's
/// planes into pixels by a 4×4 transpose in registers (`glam`'s `Mat4`: SSE2 or NEON), so that
/// each fragment is one 16-byte load, a product, a sum and a store (the scalar loop took 23
/// instructions a fragment, this ~15; each operation rounds as the scalar one did, so the bits
/// are the same).
#[inline(always)]
fn composite_from(
    out: &[[f32; BATCH]; 4],
    pix: &[u16],
    buf: &mut [[f32; 4]; PIXELS],
    start: usize,
) {
    use glam::{Mat4, Vec4};
    let [r, g, b, a] = out;
    let whole = start + (pix.len() - start) / 4 * 4;
    for k in (start..whole).step_by(4) {
        let at = |c: &[f32; BATCH]| Vec4::from_slice(&c[k..k + 4]);
        let m = Mat4::from_cols(at(r), at(g), at(b), at(a)).transpose();
        over(buf, pix[k], m.x_axis);
        over(buf, pix[k + 1], m.y_axis);
        over(buf, pix[k + 2], m.z_axis);
        over(buf, pix[k + 3], m.w_axis);
    }
    for (k, &p) in pix.iter().enumerate().skip(whole) {
        over(buf, p, Vec4::new(r[k], g[k], b[k], a[k]));
    }
}

/// [`composite`] with AVX2, eight fragments at a time: the four planes' 8-lane vectors
/// transposed into four vectors of two queue-neighbours each (`[f0 | f1]`, `[f2 | f3]`, …), and
/// each pair composited at once, its two pixels loaded into one vector and stored back from it
/// (the same operations per channel, so the same bits). Two neighbours on the same pixel (the
/// last fragment of one tet and the first of the next) go one after the other. Returns how many
/// fragments it composited (a multiple of eight; the caller takes the rest).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn composite_v3(
    v3: pulp::x86::V3,
    out: &[[f32; BATCH]; 4],
    pix: &[u16],
    buf: &mut [[f32; 4]; PIXELS],
) -> usize {
    use std::arch::x86_64::{__m128, __m256};
    let x = v3.avx;
    let one = x._mm256_set1_ps(1.0);
    let whole = pix.len() / 8 * 8;
    for (k, p8) in (0..whole).step_by(8).zip(pix.chunks_exact(8)) {
        let plane = |c: &[f32; BATCH]| -> __m256 {
            let v: [f32; 8] = c[k..k + 8].try_into().unwrap();
            bytemuck::cast(v)
        };
        let [r, g, b, a] = out.each_ref().map(plane);
        // [r0 g0 r1 g1 | r4 g4 r5 g5], …, then [r0 g0 b0 a0 | r4 g4 b4 a4], …, then the
        // 128-bit halves regrouped into neighbours.
        let (rg_lo, rg_hi) = (x._mm256_unpacklo_ps(r, g), x._mm256_unpackhi_ps(r, g));
        let (ba_lo, ba_hi) = (x._mm256_unpacklo_ps(b, a), x._mm256_unpackhi_ps(b, a));
        let f04 = x._mm256_shuffle_ps::<0x44>(rg_lo, ba_lo);
        let f15 = x._mm256_shuffle_ps::<0xEE>(rg_lo, ba_lo);
        let f26 = x._mm256_shuffle_ps::<0x44>(rg_hi, ba_hi);
        let f37 = x._mm256_shuffle_ps::<0xEE>(rg_hi, ba_hi);
        let pairs = [
            x._mm256_permute2f128_ps::<0x20>(f04, f15),
            x._mm256_permute2f128_ps::<0x20>(f26, f37),
            x._mm256_permute2f128_ps::<0x31>(f04, f15),
            x._mm256_permute2f128_ps::<0x31>(f26, f37),
        ];
        for (m, frag) in pairs.into_iter().enumerate() {
            let (p, q) = (p8[2 * m], p8[2 * m + 1]);
            let (lo, hi) = (
                x._mm256_castps256_ps128(frag),
                x._mm256_extractf128_ps::<1>(frag),
            );
            let (ip, iq) = (p as usize & (PIXELS - 1), q as usize & (PIXELS - 1));
            if ip == iq {
                let v = |h: __m128| glam::Vec4::from_array(bytemuck::cast(h));
                over(buf, p, v(lo));
                over(buf, q, v(hi));
                continue;
            }
            let px = x._mm256_insertf128_ps::<1>(
                x._mm256_castps128_ps256(bytemuck::cast(buf[ip])),
                bytemuck::cast(buf[iq]),
            );
            // keep = 1 − α (α broadcast in each half), then frag + keep·px.
            let keep = x._mm256_sub_ps(one, x._mm256_permute_ps::<0xFF>(frag));
            let res = x._mm256_add_ps(frag, x._mm256_mul_ps(keep, px));
            buf[ip] = bytemuck::cast(x._mm256_castps256_ps128(res));
            buf[iq] = bytemuck::cast(x._mm256_extractf128_ps::<1>(res));
        }
    }
    whole
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The composite gives the scalar "over" loop's bits, on batches whose length is not a
    /// multiple of four or eight and whose fragments hit the same pixels again and again (so
    /// that the order counts), neighbours on one pixel included.
    #[test]
    fn composite_is_the_scalar_over() {
        let mut rng = crate::util::rng::Rng::new(11);
        let mut rnd = || rng.f() as f32;
        for n in [0, 1, 3, 4, 5, 8, 9, 15, 16, 23, BATCH - 1, BATCH] {
            for spread in [7, 300] {
                let mut out = [[0.0f32; BATCH]; 4];
                let mut pix = [0u16; BATCH];
                for k in 0..n {
                    let a = rnd();
                    out[3][k] = a;
                    for c in out.iter_mut().take(3) {
                        c[k] = rnd() * a;
                    }
                    pix[k] = ((rnd() * spread as f32) as usize * 1031 % PIXELS) as u16;
                }
                let start: Vec<[f32; 4]> = (0..PIXELS).map(|_| [rnd(), rnd(), rnd(), rnd()]).collect();
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
                assert!(bits(&got) == bits(&want), "n = {n}, spread {spread}");
            }
        }
    }
}
