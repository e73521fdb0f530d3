//! The tets of `cpu-pt`'s fast path whose pixel box holds only a few centres: each centre is
//! tested on its own, with no row set-up.
//!
//! Half of the tets of a grid like `post` at 512² cover one pixel centre or none, yet
//! [`TetRaster`](super::TetRaster) sets each up for rows: the silhouette edges' exact bounds
//! (an f64 estimate and two integer tests each) and the stepping of every edge from row to row.
//! A box of a few centres needs none of that: per centre, the fan edges `F_k + b_k` give the
//! bits `β_k` and the silhouette edges their signs, and triangle k holds the centre iff
//! `β_k ∧ ¬β_{k+1}` and its silhouette edge is positive — [`raster_fan`](super::raster_fan)'s
//! three tests of triangle k, the fan edges evaluated once (see `tet_raster.rs` for why
//! `¬β_{k+1}` is its third test). The same centres, triangles and weights as `raster_fan`
//! (test: `small_tet_matches_per_pixel_rasteriser`).

use super::raster::Edge;
use super::tet_raster::{fan_bits, fan_dirs, normalisers, silhouette_edge, wedge, MAX_FAN};
use super::{pixel_box_in, pixel_centre, Case, Fragment};

/// How a tet fits [`SmallTet::set_up`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fit {
    /// No centre inside the clip, or a class that is not drawn: nothing to draw.
    Empty,
    /// A box of at most the centres asked for, every fan triangle valid: set up.
    Small,
    /// A larger box, or a fan triangle that is not valid: the caller rasterises it by rows.
    Large,
}

/// A tet set up for its centres one by one: columns `ia..ia + w`, rows `ja..ja + h`.
#[derive(Clone, Copy, Debug, Default)]
pub struct SmallTet {
    pub ia: i64,
    pub ja: i64,
    pub w: i64,
    pub h: i64,
    /// Fan edges k ≤ ntri: `F_k + b_k` at centre (ia, ja), steps per column and per row, and
    /// `b_k` (as [`TetRaster`](super::TetRaster)'s).
    g: [i64; MAX_FAN],
    gst: [i64; MAX_FAN],
    gsr: [i64; MAX_FAN],
    pub gbias: [i64; MAX_FAN],
    /// Silhouette edge of each fan triangle, biased, at (ia, ja), and its steps.
    sil: [i64; 4],
    sst: [i64; 4],
    ssr: [i64; 4],
    /// Barycentric normalisers per triangle (as [`TetRaster`](super::TetRaster)'s).
    pub inv_x: [f64; 4],
    pub inv_y: [f64; 4],
    /// Bit k for each of the fan's triangles.
    valid: u32,
}

impl SmallTet {
    /// Sets up the tet of table entry `c` with snapped vertices `q` in the inclusive pixel
    /// rectangle `clip` when its box there holds at most `max_centres` centres. (In place: the
    /// draw keeps one, and a returned value of this size was copied by `memcpy`.)
    #[inline(always)]
    pub fn set_up(&mut self, c: &Case, q: &[[i64; 2]; 4], clip: [i64; 4], max_centres: i64) -> Fit {
        match pixel_box_in(q, clip) {
            Some(bx) => self.set_up_in(c, q, bx, max_centres),
            None => Fit::Empty,
        }
    }

    /// [`SmallTet::set_up`] for the tet's pixel box within the clip, `bx` (not empty), which the
    /// caller has found ([`pixel_box_i32`](super::pixel_box_i32)).
    #[inline(always)]
    pub fn set_up_in(
        &mut self,
        c: &Case,
        q: &[[i64; 2]; 4],
        bx: [i64; 4],
        max_centres: i64,
    ) -> Fit {
        if !c.drawn() {
            return Fit::Empty;
        }
        let [ia, ja, ib, jb] = bx;
        let (w, h) = (ib - ia + 1, jb - ja + 1);
        if w * h > max_centres {
            return Fit::Large;
        }
        let n = c.ntri as usize;
        let p = [pixel_centre(ia), pixel_centre(ja)];
        let t = self;
        for tri in 0..n {
            [t.sil[tri], t.sst[tri], t.ssr[tri]] = silhouette_edge(c, q, tri).stepped(p);
        }
        // (A box with no centre inside the silhouette queues its centres and advances past
        // none. The draw leaves such boxes out before this, [`hull_misses_centres_in`], which
        // replaced a test of the centres against these silhouette edges here.)
        let dirs = fan_dirs(c, q);
        (t.ia, t.ja, t.w, t.h, t.valid) = (ia, ja, w, h, (1 << n) - 1);
        // (Fan edges past n and their steps stay 0: their bits are never set. The silhouette
        // slots past n are masked by `valid`.)
        t.g = [0; MAX_FAN];
        t.gst = [0; MAX_FAN];
        t.gsr = [0; MAX_FAN];
        for k in 0..=n {
            let e = Edge::new(q[c.fan[k] as usize], dirs[k]);
            [t.g[k], t.gst[k], t.gsr[k]] = e.stepped(p);
            t.gbias[k] = e.bias;
        }
        for tri in 0..n {
            let (n_x, n_y) = normalisers(c, q, &dirs, tri);
            if n_y <= 0 || n_x <= 0 {
                return Fit::Large;
            }
            t.inv_x[tri] = 1.0 / n_x as f64;
            t.inv_y[tri] = 1.0 / n_y as f64;
        }
        Fit::Small
    }

    /// Centre `(ia + di, ja + dj)`: its fan triangle as one bit (bit k: triangle k; 0 where it
    /// is in none) and the unbiased fan edges `F` there.
    #[inline(always)]
    pub fn centre(&self, di: i64, dj: i64) -> (u32, [i64; MAX_FAN]) {
        let g: [i64; MAX_FAN] =
            std::array::from_fn(|k| self.g[k] + di * self.gst[k] + dj * self.gsr[k]);
        let mut inside = 0u32;
        for k in 0..4 {
            inside |= ((self.sil[k] + di * self.sst[k] + dj * self.ssr[k] > 0) as u32) << k;
        }
        let f = std::array::from_fn(|k| g[k] - self.gbias[k]);
        (wedge(fan_bits(&g), self.valid) & inside, f)
    }

    /// Calls `f` for every centre covered, as [`raster_fan`](super::raster_fan) would (the same
    /// centres, triangles and weights; the order is by rows).
    pub fn fragments(&self, mut f: impl FnMut(Fragment)) {
        for dj in 0..self.h {
            for di in 0..self.w {
                let (hit, g) = self.centre(di, dj);
                if hit != 0 {
                    let tri = hit.trailing_zeros() as usize;
                    f(Fragment {
                        i: self.ia + di,
                        j: self.ja + dj,
                        tri,
                        lx: -(g[tri + 1] as f64) * self.inv_x[tri],
                        ly: g[tri] as f64 * self.inv_y[tri],
                    });
                }
            }
        }
    }
}

/// Whether no centre of the inclusive pixel box `bx` (columns `bx[0]..=bx[2]`, rows
/// `bx[1]..=bx[3]`) lies in the closed convex hull of the four snapped points `q`: for the draw,
/// which skips such a tet before its set-up (on `post` at 512², 89 844 of 197 947 few-centre
/// tets covered no centre). `bx` must lie in the pixel box of `q` ([`pixel_box`]), and that box
/// must hold at most 4 centres (a tile's part of a larger tet is not asked about: see below).
/// A `bx` of more than 4 centres is not tested (`false`); an empty one has none (`true`).
///
/// Conservative, never wrong the other way: a centre that [`raster_fan`](super::raster_fan)
/// covers is in a closed fan triangle, which lies in the silhouette, the hull of `q`. The hull
/// of four points is the union of the four triangles of three of them (Carathéodory), and a
/// centre is in one iff [`in_closed_triangle`] holds for the signs of its six orientations.
/// Exact: every vertex is within 5 pixels of every centre of a pixel box of at most 4 (the box
/// is the centres between the vertices' extremes), |x| < 5·2¹² < 2¹⁵, so an orientation, a
/// difference of two products of such coordinates, is below 2³¹: exact in i32.
///
/// [`pixel_box`]: super::pixel_box
///
/// This is the definition; [`hull_misses_centres_in`] is the same in AVX2 where there is AVX2.
#[inline(always)]
pub fn hull_misses_centres(q: &[[i64; 2]; 4], bx: [i64; 4]) -> bool {
    let (ia, ja, w, h) = (bx[0], bx[1], bx[2] - bx[0] + 1, bx[3] - bx[1] + 1);
    if w < 1 || h < 1 {
        return true;
    }
    if w * h > 4 {
        return false;
    }
    let (x0, y0) = centred(q, ia, ja);
    for dj in 0..h as i32 {
        for di in 0..w as i32 {
            let (ox, oy) = (di << super::SUBPIXEL_BITS, dj << super::SUBPIXEL_BITS);
            let (x, y) = (x0.map(|v| v - ox), y0.map(|v| v - oy));
            debug_assert!(
                x.iter().chain(&y).all(|v| v.abs() < 1 << 15),
                "{q:?} {ia} {ja}"
            );
            // o(i, j, p) = (q_j − q_i) × (p − q_i) = x_i·y_j − y_i·x_j with p at the origin.
            let o = |i: usize, j: usize| x[i] * y[j] - y[i] * x[j];
            let o = [o(0, 1), o(0, 2), o(0, 3), o(1, 2), o(1, 3), o(2, 3)];
            let (mut pos, mut neg) = (0u32, 0u32);
            for (m, &v) in o.iter().enumerate() {
                pos |= ((v > 0) as u32) << m;
                neg |= ((v < 0) as u32) << m;
            }
            if in_closed_triangle(pos, neg) {
                return false;
            }
        }
    }
    true
}

/// The vertices' coordinates relative to the centre of pixel `(ia, ja)`, as i32 (see
/// [`hull_misses_centres`] for why they fit).
#[inline(always)]
fn centred(q: &[[i64; 2]; 4], ia: i64, ja: i64) -> ([i32; 4], [i32; 4]) {
    let p = [pixel_centre(ia), pixel_centre(ja)];
    (
        q.map(|v| (v[0] - p[0]) as i32),
        q.map(|v| (v[1] - p[1]) as i32),
    )
}

/// Whether a point is in one of the closed triangles (0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)
/// of four points, from the signs of its orientations o(i, j, p), i < j, in the order 01, 02,
/// 03, 12, 13, 23 (bit m of `pos`: pair m's is > 0; of `neg`: < 0). It is in the closed
/// triangle (i, j, k) iff o(i, j), o(j, k) and o(k, i) = −o(i, k) are all ≥ 0 or all ≤ 0 (a
/// flat triangle passes only points on its line, which is conservative for the hull).
const fn in_closed_triangle(pos: u32, neg: u32) -> bool {
    // Per triangle, the pairs taken with + (o(i, j), o(j, k)) and the one taken with −.
    const PLUS: [u32; 4] = [0b00_1001, 0b01_0001, 0b10_0010, 0b10_1000];
    const MINUS: [u32; 4] = [0b00_0010, 0b00_0100, 0b00_0100, 0b01_0000];
    let mut t = 0;
    while t < 4 {
        let (a, b) = (PLUS[t], MINUS[t]);
        if (neg & a) | (pos & b) == 0 || (pos & a) | (neg & b) == 0 {
            return true;
        }
        t += 1;
    }
    false
}

/// [`in_closed_triangle`] for every `pos | neg << 6`, one bit each (512 bytes, in the binary).
#[cfg(target_arch = "x86_64")]
static IN_TRIANGLE: [u64; 64] = {
    let mut t = [0u64; 64];
    let mut i = 0;
    while i < 4096 {
        if in_closed_triangle(i & 63, i >> 6) {
            t[(i >> 6) as usize] |= 1 << (i & 63);
        }
        i += 1;
    }
    t
};

/// [`hull_misses_centres`] on `simd`: with AVX2 the six orientations of a centre are one
/// vector and its signs two masks, ~15 instructions a centre where the scalar form took ~120
/// (post at 512²: 47.1 M a frame, as much as it saved the draw), and no branch; otherwise the
/// scalar form. Takes the points as i32, as the fast path's records hold them. The same
/// answers (`hull_test_misses_only_empty_boxes`).
#[inline(always)]
pub fn hull_misses_centres_in<S: pulp::Simd>(simd: S, q: &[[i32; 2]; 4], bx: [i64; 4]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let Some(&v3) = (&simd as &dyn std::any::Any).downcast_ref::<pulp::x86::V3>() {
        return hull_misses_centres_v3(v3, q, bx);
    }
    let _ = simd;
    hull_misses_centres(&q.map(|p| p.map(i64::from)), bx)
}

/// Whether centre `[di, dj]` of [`hull_misses_centres_v3`]'s box is in the hull, as bit 0: its
/// orientations from those at the first centre, `o0`, and their steps `dy`, `dx`. (A function,
/// not a closure: a closure does not inherit the caller's target features, and left out of line
/// each intrinsic in it was a call: the project stage ran 3.2× slower.)
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn centre_in_hull_v3(
    v3: pulp::x86::V3,
    o0: std::arch::x86_64::__m256i,
    dy: std::arch::x86_64::__m256i,
    dx: std::arch::x86_64::__m256i,
    [di, dj]: [i32; 2],
) -> u64 {
    use std::arch::x86_64::__m256i;
    let x2 = v3.avx2;
    // (`BOX_CENTRES` holds the offsets in snapped units.)
    let (sx, sy) = (di, dj);
    let splat = |a: i32| -> __m256i { bytemuck::cast([a; 8]) };
    let o = x2._mm256_add_epi32(o0, x2._mm256_mullo_epi32(dy, splat(sx)));
    let o = x2._mm256_add_epi32(o, x2._mm256_mullo_epi32(dx, splat(sy)));
    let zero = splat(0);
    let pos = v3
        .avx
        ._mm256_movemask_ps(bytemuck::cast(x2._mm256_cmpgt_epi32(o, zero))) as u32;
    let neg = v3
        .avx
        ._mm256_movemask_ps(bytemuck::cast(x2._mm256_cmpgt_epi32(zero, o))) as u32;
    // (Lanes 6 and 7 are 0, so each mask is below 64; saying so spares a bounds check.)
    let i = (pos & 63) | (neg & 63) << 6;
    IN_TRIANGLE[(i >> 6) as usize] >> (i & 63)
}

/// The centres `[di, dj]` of a `w`×`h` box of at most four, at index `(w − 1)·4 + h − 1`, by
/// rows, padded to four with the first (a larger box's entry is four times the first), as
/// offsets from the first in snapped units.
#[cfg(target_arch = "x86_64")]
const BOX_CENTRES: [[[i32; 2]; 4]; 16] = {
    let mut t = [[[0; 2]; 4]; 16];
    let mut w = 1;
    while w <= 4 {
        let mut h = 1;
        while h <= 4 {
            let mut k = 0;
            while k < w * h && w * h <= 4 {
                let s = 1 << super::SUBPIXEL_BITS;
                t[((w - 1) * 4 + h - 1) as usize][k as usize] = [k % w * s, k / w * s];
                k += 1;
            }
            h += 1;
        }
        w += 1;
    }
    t
};

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn hull_misses_centres_v3(v3: pulp::x86::V3, q: &[[i32; 2]; 4], bx: [i64; 4]) -> bool {
    use std::arch::x86_64::__m256i;
    let (ia, ja, w, h) = (bx[0], bx[1], bx[2] - bx[0] + 1, bx[3] - bx[1] + 1);
    // No branch on the box: in the visibility order its shape and each centre's answer are
    // coin tosses (asked by the project stage of every tet, a form with such branches grew
    // the stage's wall time by 12 % for 2 % more instructions). Every box is computed as one
    // of at most four centres (a larger one's values, wrapped in i32, are discarded) and the
    // answer chosen by its size.
    let (empty, few) = (w < 1 || h < 1, w * h <= 4);
    let x2 = v3.avx2;
    let lanes = |a: [i32; 8]| -> __m256i { bytemuck::cast(a) };
    // The points relative to the first centre, x0 y0 x1 y1 … (wrapping: exact where it
    // matters, see `hull_misses_centres`).
    let (px, py) = (pixel_centre(ia) as i32, pixel_centre(ja) as i32);
    let v = x2._mm256_sub_epi32(bytemuck::cast(*q), lanes([px, py, px, py, px, py, px, py]));
    // Lanes m < 6 for pair (i, j) of 01, 02, 03, 12, 13, 23: x_i, y_j, y_i, x_j (x_i in lane
    // 2i, y_i in 2i + 1). Lanes 6 and 7 compute x0·y0 − y0·x0 = 0, which sets neither mask.
    let (xi, yj) = (
        lanes([0, 0, 0, 2, 2, 4, 0, 0]),
        lanes([3, 5, 7, 5, 7, 7, 1, 1]),
    );
    let (yi, xj) = (
        lanes([1, 1, 1, 3, 3, 5, 1, 1]),
        lanes([2, 4, 6, 4, 6, 6, 0, 0]),
    );
    let (axi, ayj) = (
        x2._mm256_permutevar8x32_epi32(v, xi),
        x2._mm256_permutevar8x32_epi32(v, yj),
    );
    let (ayi, axj) = (
        x2._mm256_permutevar8x32_epi32(v, yi),
        x2._mm256_permutevar8x32_epi32(v, xj),
    );
    // At the first centre, and per centre δ (snapped units) from it, o(p + δ) = o(p) +
    // δx·(y_i − y_j) + δy·(x_j − x_i): each sum on the way is an orientation at a centre of the
    // box, so none leaves i32.
    let o0 = x2._mm256_sub_epi32(
        x2._mm256_mullo_epi32(axi, ayj),
        x2._mm256_mullo_epi32(ayi, axj),
    );
    let (dy, dx) = (x2._mm256_sub_epi32(ayi, ayj), x2._mm256_sub_epi32(axj, axi));
    let mut any = 0;
    for c in BOX_CENTRES[((w.clamp(1, 4) - 1) * 4 + h.clamp(1, 4) - 1) as usize] {
        // (The repeats of the first centre, in a box of fewer than four, change no answer.)
        any |= centre_in_hull_v3(v3, o0, dy, dx, c);
    }
    empty | (few & (any & 1 == 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::pt::tests::{assert_same_fragments, fan_points};
    use crate::render::pt::{classify, raster_fan, FanGeometry, ProjVertex, SUBPIXEL};
    use crate::util::rng::Rng;

    /// The same centres, triangles and weights as the per-triangle rasteriser, on the fans of
    /// `tet_rasteriser_matches_per_pixel_rasteriser` shrunk to a few pixels (lattice, random,
    /// degenerate) and clipped; a box of more centres than asked for is left to the rows, and a
    /// tet with nothing inside the clip draws nothing.
    #[test]
    fn small_tet_matches_per_pixel_rasteriser() {
        let mut rng = Rng::new(31);
        let (mut small, mut empty, mut large, mut frags) = (0, 0, 0, 0);
        for it in 0..20_000 {
            let q = few_pixel_fan(&mut rng, it);
            let v = q.map(|q| ProjVertex {
                q,
                ..Default::default()
            });
            let g = FanGeometry::new(q, &classify(&v, false, 1.0));
            let (x, y) = (rng.int(6) - 1, rng.int(6) - 1);
            for clip in [[0, 0, 40, 40], [x, y, x + rng.int(3), y + rng.int(3)]] {
                let mut want = Vec::new();
                raster_fan(&g, clip, |f| want.push(f));
                let mut got = Vec::new();
                let mut t = SmallTet::default();
                match t.set_up(g.case, &q, clip, 6) {
                    Fit::Empty => empty += 1,
                    Fit::Large => {
                        large += 1;
                        continue;
                    }
                    Fit::Small => {
                        small += 1;
                        assert!(t.w * t.h <= 6);
                        t.fragments(|f| got.push(f));
                    }
                }
                assert_same_fragments(want, &got, &(q, clip));
                frags += got.len();
            }
        }
        assert!(
            small > 5_000 && empty > 1_000 && large > 1_000,
            "{small} {empty} {large}"
        );
        assert!(frags > 5_000, "{frags}");
    }

    /// The fans of `tet_rasteriser_matches_per_pixel_rasteriser`, shrunk to a few pixels: kinds
    /// 1–3 (random, lattice, degenerate) are a few pixels wide; kind 0 is shrunk by 8.
    fn few_pixel_fan(rng: &mut Rng, it: usize) -> [[i64; 2]; 4] {
        let mode = it % 4;
        let q = fan_points(rng, mode);
        if mode == 0 {
            q.map(|p| p.map(|x| x / 8))
        } else {
            q
        }
    }

    /// `hull_misses_centres` never leaves out a tet that covers a centre: where it says a box
    /// (the tet's, or a part of it) has no centre in the hull, `raster_fan` draws nothing of the
    /// tet there (centres on the silhouette's edges included, and flat tets); it says so often,
    /// always for an empty box and never for a box of more than 4 centres. Its AVX2 form gives the same answers, where the host has AVX2.
    #[test]
    fn hull_test_misses_only_empty_boxes() {
        let mut rng = Rng::new(47);
        let (mut tested, mut missed) = (0, 0);
        let s = SUBPIXEL;
        for it in 0..40_000 {
            // Tets of a pixel or a few at a random place: random, on the half-pixel lattice
            // (vertices on centres and on pixels' corners; shared and collinear points), flat
            // (four points on a line through a centre, or near one), and the fans above.
            let (o, size) = (
                [rng.int(8 * s as u64), rng.int(8 * s as u64)],
                [s / 2, s, 2 * s, 4 * s],
            );
            let size = size[rng.int(4) as usize];
            let q: [[i64; 2]; 4] = match it % 4 {
                0 => std::array::from_fn(|_| o.map(|o| o + rng.int(size as u64))),
                1 => std::array::from_fn(|_| o.map(|o| o / s * s + rng.int(6) * s / 2)),
                2 => {
                    let d = [rng.int(2 * s as u64) - s, rng.int(2 * s as u64) - s];
                    let c = [pixel_centre(3) + rng.int(3) - 1, pixel_centre(4)];
                    std::array::from_fn(|_| {
                        let t = rng.int(5) - 2;
                        [c[0] + t * d[0] / 2, c[1] + t * d[1] / 2]
                    })
                }
                _ => few_pixel_fan(&mut rng, it / 4),
            };
            // The tet's pixel box, and a part of it (as a tile's clip leaves of it).
            let whole = crate::render::pt::pixel_box(&q);
            let (w, h) = (whole[2] - whole[0] + 1, whole[3] - whole[1] + 1);
            let part = [0, 1, 2, 3].map(|k| whole[k] + [1, 1, -1, -1][k] * rng.int(2));
            for bx in [whole, part] {
                let (bw, bh) = (bx[2] - bx[0] + 1, bx[3] - bx[1] + 1);
                if w * h > 4 && bw * bh <= 4 && bw > 0 && bh > 0 {
                    // A small part of a larger tet: not to be asked about.
                    continue;
                }
                let miss = hull_misses_centres(&q, bx);
                #[cfg(target_arch = "x86_64")]
                if let Some(v3) = pulp::x86::V3::try_new() {
                    let q32 = q.map(|p| p.map(|x| x as i32));
                    assert_eq!(hull_misses_centres_in(v3, &q32, bx), miss, "{q:?} {bx:?}");
                }
                if bw < 1 || bh < 1 {
                    assert!(miss, "{q:?} {bx:?}");
                    continue;
                }
                if bw * bh > 4 {
                    assert!(!miss, "{q:?} {bx:?}");
                    continue;
                }
                tested += 1;
                if miss {
                    missed += 1;
                    let v = q.map(|q| ProjVertex {
                        q,
                        ..Default::default()
                    });
                    let g = FanGeometry::new(q, &classify(&v, false, 1.0));
                    raster_fan(&g, bx, |f| panic!("{q:?} covers {f:?} in {bx:?}"));
                }
            }
        }
        assert!(tested > 10_000 && missed > 5_000, "{tested} {missed}");
    }
}
