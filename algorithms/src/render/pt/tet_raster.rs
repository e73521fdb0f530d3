//! The whole-tet rasteriser of `cpu-pt`'s fast path: one set of edge functions per tet and the
//! rows of its silhouette, instead of the rows of each fan triangle.
//!
//! **Edges.** A fan of `n` triangles (thick, fan[k], fan[k+1]) has `n + 1` *fan edges*, the lines
//! from the thick vertex to fan[k] (k = 0..=n; for the closed fans of classes 1 and 2 the last is
//! the first), and the silhouette edges fan[k] → fan[k+1] (plus, for classes 3 and 4, the fan's
//! first and last edges, which lie on the silhouette). With `F_k(p) = d_k × (p − fan[k])`, d_k the
//! direction of [`raster_fan`]'s edge from the thick vertex to fan[k], and `b_k` its fill-rule
//! bias, [`raster_fan`] puts a centre p in triangle k iff
//! `F_k + b_k > 0`, `−F_{k+1} + (1 − b_{k+1}) > 0` (the same line seen from the other side: its
//! bias is the complement) and the silhouette edge of k is positive. So with the bits
//! `β_k = [F_k(p) + b_k > 0]`, triangle k holds p iff `β_k ∧ ¬β_{k+1}` and p is inside the
//! silhouette edge — exactly the per-triangle tests, with each fan edge evaluated once.
//!
//! **Which triangle.** Inside the silhouette the fan's triangles tile it, so exactly one k has
//! `β_k ∧ ¬β_{k+1}` ([`wedge`]: the lowest set bit of `β & ¬(β >> 1)`): for a closed fan the
//! angles between consecutive fan edges are below 180°, so the β_k that hold are one circular
//! run; for the open fans (classes 3, 4) β_0 = 1 and β_n = 0 inside. Outside the silhouette
//! (with classes 3 and 4) the wedge may be empty; the rows exclude the rest.
//!
//! **Rows.** The silhouette is convex: per row, each silhouette edge bounds the covered centres
//! from one side at `k = −h/st` (h its biased value at the row's first column, st its step per
//! pixel). The bound is found exactly once per tet (an f64 estimate corrected by one integer test
//! each way) and then stepped from row to row in integers, as a line is drawn by Bresenham's
//! method (Bresenham 1965; see [`SilEdges`]), so the row's range is exact: every centre in it is
//! inside the silhouette. A horizontal silhouette edge (st = 0) bounds rows instead, and narrows
//! the tet's row range once, in the set-up. [`raster_fan`] covers the same centres (test:
//! `tet_rasteriser_matches_per_pixel_rasteriser`, and on `post` in `cpu_pt`'s tests).
//!
//! [`raster_fan`]: super::raster_fan

use super::raster::{dir_from_thick, floor_i64, Edge};
use super::{pixel_box_in, pixel_centre, Case, Fragment};

/// Fan edges at most (class 2: four triangles, five fan edges).
pub const MAX_FAN: usize = 5;

/// The slanted silhouette edges as the rows see them (at most four, a structure of arrays so
/// that a row steps all four at once: four i64 lanes, one AVX2 vector), each in the form
/// `h + k·st` with `st > 0` (an edge bounding the row from above, whose value falls along the
/// row, is taken in `−k`): `k` is the first column offset where the edge is positive on the
/// current row, and `r = h + k·st` its value there, so `0 < r ≤ st`. From row to row `h` grows
/// by `sr`, so `k` moves by `q` or `q + 1` with `q = ⌊−sr/st⌋`: `r` grows by
/// `step = sr + q·st ∈ (−st, 0]`, and where that leaves `r ≤ 0` one more column is needed (an
/// exact integer DDA as a line is drawn by Bresenham's method: no division per row).
///
/// An unused slot bounds nothing: from below, at column 0, forever (`k = 0, r = 1, st = 1,
/// q = step = 0`), so that every row steps four edges without a branch on how many there are.
#[derive(Clone, Copy, Debug)]
struct SilEdges {
    k: [i64; 4],
    r: [i64; 4],
    st: [i64; 4],
    q: [i64; 4],
    step: [i64; 4],
    /// −1 (all bits) where the edge bounds the row from above (taken in `−k`), else 0.
    hi: [i64; 4],
}

impl Default for SilEdges {
    fn default() -> SilEdges {
        SilEdges {
            k: [0; 4],
            r: [1; 4],
            st: [1; 4],
            q: [0; 4],
            step: [0; 4],
            hi: [0; 4],
        }
    }
}

impl SilEdges {
    /// Sets slot `e` to the edge `h + k·st` (`st > 0`) whose `h` grows by `sr` a row.
    #[inline(always)]
    fn set(&mut self, e: usize, h: i64, st: i64, sr: i64, hi: bool) {
        let inv = 1.0 / st as f64;
        let k = first_positive(h, st, inv);
        let q = first_positive(sr, st, inv) - 1;
        self.k[e] = k;
        self.r[e] = h + k * st;
        self.st[e] = st;
        self.q[e] = q;
        self.step[e] = sr + q * st;
        self.hi[e] = -(hi as i64);
    }

    /// Every edge to the next row, branch-free lane by lane (the extra column is Bresenham's
    /// coin toss: as a branch, callgrind's model mispredicted 3.5 M of them in a post frame at
    /// 512²). The scalar form, for `next_row` and the set-up's skipped rows;
    /// [`SilEdges::bounds_then_advance`] is the vector one.
    #[inline(always)]
    fn advance(&mut self) {
        for e in 0..4 {
            let r = self.r[e] + self.step[e];
            let up = (r <= 0) as i64;
            self.r[e] = r + (self.st[e] & -up);
            self.k[e] += self.q[e] + up;
        }
    }

    /// The current row's covered columns, offsets `a..=b` from the box's first (`last`: the
    /// box's last offset); empty when `a > b`. From below: the first k with h + k·st > 0.
    /// From above: the last k with h + k·st > 0 (st < 0), −(the first −k with
    /// h + (−k)(−st) > 0).
    #[inline(always)]
    fn bounds(&self, last: i64) -> (i64, i64) {
        let (mut a, mut b) = (0i64, last);
        for e in 0..4 {
            let (k, m) = (self.k[e], self.hi[e]);
            a = a.max(k & !m);
            b = b.min((-k & m) | (last & !m));
        }
        (a, b)
    }

    /// [`SilEdges::bounds`], then every edge to the next row ([`SilEdges::advance`]), the four
    /// edges in `simd`'s i64 vectors (one with AVX2: the compiler did not vectorise the scalar
    /// loops, ~65 instructions a row). A vector wider than four lanes (AVX-512, not enabled)
    /// takes the scalar loops.
    #[inline(always)]
    fn bounds_then_advance<S: pulp::Simd>(&mut self, simd: S, last: i64) -> (i64, i64) {
        if std::mem::size_of::<S::i64s>() > std::mem::size_of::<[i64; 4]>() {
            let ab = self.bounds(last);
            self.advance();
            return ab;
        }
        let (mut lo, mut up) = ([0i64; 4], [0i64; 4]);
        {
            let (k, kt) = S::as_mut_simd_i64s(&mut self.k);
            let (r, _) = S::as_mut_simd_i64s(&mut self.r);
            let (st, _) = S::as_simd_i64s(&self.st);
            let (q, _) = S::as_simd_i64s(&self.q);
            let (step, _) = S::as_simd_i64s(&self.step);
            let (hi, _) = S::as_simd_i64s(&self.hi);
            let (lv, _) = S::as_mut_simd_i64s(&mut lo);
            let (uv, _) = S::as_mut_simd_i64s(&mut up);
            let (zero, one) = (simd.splat_i64s(0), simd.splat_i64s(1));
            let lastv = simd.splat_i64s(last);
            for v in 0..k.len() {
                let (kv, m) = (k[v], hi[v]);
                let not_m = simd.not_i64s(m);
                lv[v] = simd.and_i64s(kv, not_m);
                uv[v] = simd.or_i64s(
                    simd.and_i64s(simd.sub_i64s(zero, kv), m),
                    simd.and_i64s(lastv, not_m),
                );
                let rv = simd.add_i64s(r[v], step[v]);
                let extra = simd.less_than_or_equal_i64s(rv, zero);
                r[v] = simd.select_i64s(extra, simd.add_i64s(rv, st[v]), rv);
                let moved = simd.add_i64s(kv, q[v]);
                k[v] = simd.add_i64s(moved, simd.select_i64s(extra, one, zero));
            }
            // (Four lanes split into whole vectors: the case above took the wider ones.)
            debug_assert!(kt.is_empty());
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(&v3) = (&simd as &dyn std::any::Any).downcast_ref::<pulp::x86::V3>() {
            return bounds_of_lanes_v3(v3, &lo, &up, last);
        }
        let a = lo.iter().fold(0, |a, &x| a.max(x));
        let b = up.iter().fold(last, |b, &x| b.min(x));
        (a, b)
    }
}

/// `(max(0, lo…), min(last, up…))` of four i64 lanes each, in AVX2 registers: both maxima at
/// once (`min(up) = −max(−up)`) by two steps of compare and blend (AVX2 has no 64-bit max).
/// Stored and folded lane by lane, these were ~40 instructions a row (2.8 % of a post draw);
/// the values are integers, so the result is the fold's.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn bounds_of_lanes_v3(v3: pulp::x86::V3, lo: &[i64; 4], up: &[i64; 4], last: i64) -> (i64, i64) {
    use std::arch::x86_64::__m256i;
    let x2 = v3.avx2;
    let l: __m256i = bytemuck::cast(*lo);
    let nu = x2._mm256_sub_epi64(bytemuck::cast([0i64; 4]), bytemuck::cast(*up));
    let max = |a: __m256i, b: __m256i| x2._mm256_blendv_epi8(a, b, x2._mm256_cmpgt_epi64(b, a));
    // [lo0 lo1 nu0 nu1] against [lo2 lo3 nu2 nu3], then each 128-bit half against its swap.
    let m = max(
        x2._mm256_permute2x128_si256::<0x20>(l, nu),
        x2._mm256_permute2x128_si256::<0x31>(l, nu),
    );
    let m = max(m, x2._mm256_shuffle_epi32::<0x4E>(m));
    let m: [i64; 4] = bytemuck::cast(m);
    (m[0].max(0), (-m[2]).min(last))
}

/// The first `k` with `h + k·st > 0` (`st > 0`, `inv = 1/st`): `⌊−h/st⌋ + 1`, from an f64
/// estimate and one exact test each way. The estimate is within 1: snapped coordinates are at
/// most 2³⁰ ([`MAX_PIXEL_COORD`](super::MAX_PIXEL_COORD)), so an edge value, two products of
/// factors below 2³¹, has |h| < 2⁶³, and st is a nonzero multiple of [`SUBPIXEL`](super::SUBPIXEL) (2¹²), so
/// |h/st| < 2⁵¹ and the three roundings (h, 1/st, the product) move it by less than
/// 2⁵¹·3·2⁻⁵³ < 1. The products in the tests are near −h, so they do not overflow (test:
/// `tet_rasteriser_matches_per_pixel_rasteriser_at_extreme_coordinates`, with overflow checks).
#[inline(always)]
fn first_positive(h: i64, st: i64, inv: f64) -> i64 {
    let mut k = floor_i64(-(h as f64) * inv) + 1;
    k -= (h + (k - 1) * st > 0) as i64;
    k += (h + k * st <= 0) as i64;
    k
}

/// One classified tet, set up for [`TetRaster::rows`] (which consumes its rows: `j0` and `g`
/// advance as they are taken).
#[derive(Clone, Copy, Debug)]
pub struct TetRaster {
    /// Triangles in the fan.
    pub ntri: usize,
    /// Bit k set when triangle k has positive barycentric normalisers (always, for a table
    /// entry on exact tests; [`raster_fan`](super::raster_fan) skips the others, and so does this).
    pub valid: u32,
    /// Columns `ia..=ib` and rows `j0..=j1`: the silhouette's pixel box within the clip (`j0`:
    /// the next row).
    pub ia: i64,
    pub ib: i64,
    pub j0: i64,
    pub j1: i64,
    /// Fan edges k ≤ ntri: `F_k + b_k` at centre (ia, j0), steps per pixel and per row, and
    /// `b_k`; entries past ntri are 0 (their bit is never set).
    pub g: [i64; MAX_FAN],
    pub gst: [i64; MAX_FAN],
    pub gsr: [i64; MAX_FAN],
    pub gbias: [i64; MAX_FAN],
    /// Barycentric normalisers per triangle k: the weight of fan[k] is `lx = −F_{k+1}·inv_x[k]`,
    /// that of fan[k + 1] is `ly = F_k·inv_y[k]`, the thick vertex's `1 − lx − ly` (the weights
    /// of [`Fragment`]).
    pub inv_x: [f64; 4],
    pub inv_y: [f64; 4],
    /// The slanted silhouette edges (at most four; the rest of the slots bound nothing). A
    /// horizontal one bounds rows, not columns: it narrows `j0..=j1` once, in the set-up.
    sil: SilEdges,
    nsil: usize,
    /// Rows a horizontal silhouette edge excludes at the top (stepped over once set up).
    skip: i64,
}

/// One row of the silhouette: columns `i0..=i1` of row `j`, every centre of it inside the
/// silhouette, and the biased fan edges at `i0` (pixel `i0 + k` has `g[m] + k·gst[m]`).
#[derive(Clone, Copy, Debug)]
pub struct TetRow {
    pub j: i64,
    pub i0: i64,
    pub i1: i64,
    pub g: [i64; MAX_FAN],
}

/// The direction of each fan edge k ≤ ntri of table entry `c` (from the thick vertex; entries
/// past ntri are 0).
#[inline(always)]
pub(super) fn fan_dirs(c: &Case, q: &[[i64; 2]; 4]) -> [[i64; 2]; MAX_FAN] {
    std::array::from_fn(|k| {
        if k <= c.ntri as usize {
            dir_from_thick(c, q, c.fan[k] as usize)
        } else {
            [0, 0]
        }
    })
}

/// The silhouette edge of fan triangle `tri`, fan[tri] → fan[tri + 1].
#[inline(always)]
pub(super) fn silhouette_edge(c: &Case, q: &[[i64; 2]; 4], tri: usize) -> Edge {
    let (x, y) = (q[c.fan[tri] as usize], q[c.fan[tri + 1] as usize]);
    Edge::new(x, [y[0] - x[0], y[1] - x[1]])
}

/// Fan triangle `tri`'s barycentric normalisers `(n_x, n_y)`, [`raster_fan`]'s e2(x) and e0(y)
/// (`dirs` from [`fan_dirs`]); the triangle is valid where both are positive.
///
/// [`raster_fan`]: super::raster_fan
#[inline(always)]
pub(super) fn normalisers(
    c: &Case,
    q: &[[i64; 2]; 4],
    dirs: &[[i64; 2]; MAX_FAN],
    tri: usize,
) -> (i64, i64) {
    let (x, y) = (q[c.fan[tri] as usize], q[c.fan[tri + 1] as usize]);
    let (dx, dy) = (dirs[tri], dirs[tri + 1]);
    (Edge::new(y, [-dy[0], -dy[1]]).at(x), Edge::new(x, dx).at(y))
}

/// The bits `β_k = [g_k > 0]` of a pixel's biased fan edges.
#[inline(always)]
pub fn fan_bits(g: &[i64; MAX_FAN]) -> u32 {
    let mut b = 0u32;
    for (k, &v) in g.iter().enumerate() {
        b |= ((v > 0) as u32) << k;
    }
    b
}

/// The triangle of a pixel as one bit (bit k: triangle k), or 0 where it is in none of the
/// valid ones: `β & ¬(β >> 1) & valid`. The triangle is its `trailing_zeros`.
#[inline(always)]
pub fn wedge(bits: u32, valid: u32) -> u32 {
    bits & !(bits >> 1) & valid
}

impl TetRaster {
    /// Sets up the tet of table entry `c` with snapped vertices `q` for the inclusive pixel
    /// rectangle `clip = [i0, j0, i1, j1]`; `None` when nothing is drawn there.
    #[inline(always)]
    pub fn new(c: &Case, q: &[[i64; 2]; 4], clip: [i64; 4]) -> Option<TetRaster> {
        TetRaster::new_in(c, q, pixel_box_in(q, clip)?)
    }

    /// [`TetRaster::new`] for the tet's pixel box within the clip, `bx` (not empty), which the
    /// caller has found ([`pixel_box_i32`](super::pixel_box_i32)).
    #[inline(always)]
    pub fn new_in(c: &Case, q: &[[i64; 2]; 4], bx: [i64; 4]) -> Option<TetRaster> {
        if !c.drawn() {
            return None;
        }
        let n = c.ntri as usize;
        let [ia, j0, ib, j1] = bx;
        let p = [pixel_centre(ia), pixel_centre(j0)];
        let mut r = TetRaster {
            ntri: n,
            valid: 0,
            ia,
            ib,
            j0,
            j1,
            g: [0; MAX_FAN],
            gst: [0; MAX_FAN],
            gsr: [0; MAX_FAN],
            gbias: [0; MAX_FAN],
            inv_x: [0.0; 4],
            inv_y: [0.0; 4],
            sil: SilEdges::default(),
            nsil: 0,
            skip: 0,
        };
        // Each fan edge's direction once (the fan edges, the normalisers and the open fans'
        // ends read them).
        let dirs = fan_dirs(c, q);
        let dir = |k: usize| dirs[k];
        for k in 0..=n {
            let e = Edge::new(q[c.fan[k] as usize], dir(k));
            [r.g[k], r.gst[k], r.gsr[k]] = e.stepped(p);
            r.gbias[k] = e.bias;
        }
        for tri in 0..n {
            r.add_silhouette(silhouette_edge(c, q, tri), p);
            let (n_x, n_y) = normalisers(c, q, &dirs, tri);
            if n_y > 0 && n_x > 0 {
                r.valid |= 1 << tri;
                r.inv_x[tri] = 1.0 / n_x as f64;
                r.inv_y[tri] = 1.0 / n_y as f64;
            }
        }
        if c.class == 3 || c.class == 4 {
            // The open fans: their first and last fan edges are silhouette edges too (class 3:
            // both on the line the thick vertex lies on).
            r.add_silhouette(Edge::new(q[c.fan[0] as usize], dir(0)), p);
            let d = dir(n);
            r.add_silhouette(Edge::new(q[c.fan[n] as usize], [-d[0], -d[1]]), p);
        }
        for _ in 0..r.skip {
            r.step_row();
        }
        (r.j0 <= r.j1).then_some(r)
    }

    /// Steps every edge to the next row.
    #[inline(always)]
    fn step_row(&mut self) {
        self.sil.advance();
        for (v, s) in self.g.iter_mut().zip(&self.gsr) {
            *v += s;
        }
        self.j0 += 1;
    }

    /// Files silhouette edge `e` (biased value at centre `p`) by the side it bounds rows from.
    #[inline(always)]
    fn add_silhouette(&mut self, e: Edge, p: [i64; 2]) {
        let [h, st, sr] = e.stepped(p);
        if st != 0 {
            // From above (st < 0): h + k·st = h + (−k)·(−st). A select, as the side is a coin
            // toss per edge.
            let hi = st < 0;
            self.sil.set(self.nsil, h, st.abs(), sr, hi);
            self.nsil += 1;
        } else {
            // Horizontal: row r (from j0) is inside iff h + r·sr > 0.
            let last = self.j1 - self.j0;
            if sr > 0 {
                // Rows above the first inside are stepped over at the end of the set-up (the
                // other edges are set up at j0).
                let first = first_positive(h, sr, 1.0 / sr as f64).clamp(0, last + 1);
                self.skip = self.skip.max(first);
            } else if sr < 0 {
                // The last r with h + r·sr > 0 is one before the first with (1 − h) + r·(−sr) > 0.
                let end = first_positive(1 - h, -sr, -1.0 / sr as f64) - 1;
                self.j1 = self.j0 + end.clamp(-1, last);
            } else if h <= 0 {
                // A zero-length edge that excludes everything.
                self.j1 = self.j0 - 1;
            }
        }
    }

    /// Calls `f` for each row of the silhouette with a covered centre, top to bottom. Once:
    /// it steps the silhouette edges in place.
    #[inline(always)]
    pub fn rows(&mut self, mut f: impl FnMut(&TetRow)) {
        while let Some(row) = self.next_row() {
            f(&row);
        }
    }

    /// The next row of the silhouette with a covered centre (top to bottom), `None` past the
    /// last; [`TetRaster::rows`] as a loop the caller writes, so that its body is compiled in
    /// the caller (with the caller's target features: a closure would not be).
    #[inline(always)]
    pub fn next_row(&mut self) -> Option<TetRow> {
        let last = self.ib - self.ia;
        while self.j0 <= self.j1 {
            let j = self.j0;
            let (a, b) = self.sil.bounds(last);
            let g = self.g;
            self.step_row();
            if a <= b {
                return Some(TetRow {
                    j,
                    i0: self.ia + a,
                    i1: self.ia + b,
                    g: std::array::from_fn(|m| g[m] + a * self.gst[m]),
                });
            }
        }
        None
    }

    /// The next row's span `(j, i0, i1)` as [`TetRaster::next_row`] finds it, for a caller that
    /// needs no fan edges: only the silhouette edges are stepped, in `simd`'s vectors (the
    /// fan edges `g` stay at the row where the rows began).
    #[inline(always)]
    pub fn next_span<S: pulp::Simd>(&mut self, simd: S) -> Option<(i64, i64, i64)> {
        let last = self.ib - self.ia;
        while self.j0 <= self.j1 {
            let j = self.j0;
            let (a, b) = self.sil.bounds_then_advance(simd, last);
            self.j0 += 1;
            if a <= b {
                return Some((j, self.ia + a, self.ia + b));
            }
        }
        None
    }

    /// Calls `f` for every centre covered, as [`raster_fan`](super::raster_fan) would (the same
    /// centres, triangles and weights; the order is by rows, not by triangles).
    pub fn fragments(mut self, mut f: impl FnMut(Fragment)) {
        let me = self;
        self.rows(|r| {
            let mut g = r.g;
            for i in r.i0..=r.i1 {
                let t = wedge(fan_bits(&g), me.valid);
                if t != 0 {
                    let tri = t.trailing_zeros() as usize;
                    let fk = |k: usize| (g[k] - me.gbias[k]) as f64;
                    f(Fragment {
                        i,
                        j: r.j,
                        tri,
                        lx: -fk(tri + 1) * me.inv_x[tri],
                        ly: fk(tri) * me.inv_y[tri],
                    });
                }
                for (v, s) in g.iter_mut().zip(&me.gst) {
                    *v += s;
                }
            }
        });
    }
}

/// [`TetRaster::next_span`] (the silhouette edges stepped in vectors: AVX2 where the CPU has
/// it, and pulp's scalar lanes) finds the rows and spans of [`TetRaster::next_row`] (called on
/// every fan of the rasteriser tests in `pt/tests.rs`).
#[cfg(test)]
pub(super) fn assert_spans_are_rows(r: TetRaster) {
    let mut rows = Vec::new();
    let mut t = r;
    while let Some(row) = t.next_row() {
        rows.push((row.j, row.i0, row.i1));
    }
    fn spans<S: pulp::Simd>(simd: S, mut t: TetRaster) -> Vec<(i64, i64, i64)> {
        std::iter::from_fn(|| t.next_span(simd)).collect()
    }
    assert_eq!(spans(pulp::Scalar::new(), r), rows);
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        assert_eq!(simd.vectorize(|| spans(simd, r)), rows);
    }
}
