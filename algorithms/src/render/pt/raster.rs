//! The fan rasterizer: which pixel centres each triangle of a tet's fan covers, and the
//! barycentric weights there.
//!
//! **Fill rule.** Edge functions are exact integers on the snapped points. A pixel centre on an
//! edge belongs to the triangle that contains the centre moved by (+ε, −ε²) pixels, i.e. moved
//! right, then up — the top-left rule in the image plane's own frame (x along the camera's right
//! vector, y along its up vector; in pixel rows, which run downwards, a horizontal edge belongs to
//! the triangle above it). It is the same tie-break as the reference ray caster's Simulation of
//! Simplicity (rays shifted by ε·r + ε²·u), so a ray exactly through a projected edge or vertex
//! is given to the same cell by both. As the two triangles on either side of an edge see it with
//! opposite directions, exactly one of them owns a centre on it, and no perturbed point lies on
//! any edge: every centre inside a fan's silhouette is covered by exactly one of its triangles,
//! and a centre on an edge shared by two tets' silhouettes by exactly one of them.
//!
//! Class 2: the thick vertex P is the crossing of edges A and B and not on the grid, but each fan
//! edge through P lies on the line of A or of B, so it is evaluated exactly from that line.

use super::{pixel_centre, Case, Thick, SUBPIXEL, TABLE};

/// What the rasterizer needs of a classified tet.
#[derive(Clone, Copy, Debug)]
pub struct FanGeometry {
    pub case: &'static Case,
    /// Snapped projected vertices.
    pub q: [[i64; 2]; 4],
    /// Thick vertex in snapped units.
    pub thick: [f64; 2],
}

impl FanGeometry {
    pub fn new(q: [[i64; 2]; 4], t: &Thick) -> FanGeometry {
        FanGeometry {
            case: &TABLE[t.case as usize],
            q,
            thick: [t.x, t.y],
        }
    }

    /// Direction of the fan edge from the thick vertex towards vertex `v`: for class 2 along the
    /// line of v's set (from v's partner), else from the thick vertex (a snapped vertex).
    #[inline]
    fn dir_from_thick(&self, v: usize) -> [i64; 2] {
        dir_from_thick(self.case, &self.q, v)
    }

    /// Pixel bounding box (inclusive) of the silhouette.
    pub fn pixel_bounds(&self) -> [i64; 4] {
        pixel_box(&self.q)
    }
}

/// Pixel bounding box (inclusive: first and last centre columns and rows) of four snapped
/// points; empty (first > last) where no centre lies inside their box.
#[inline(always)]
pub fn pixel_box(q: &[[i64; 2]; 4]) -> [i64; 4] {
    let (mut lo, mut hi) = ([i64::MAX; 2], [i64::MIN; 2]);
    for p in q {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    [
        first_centre(lo[0]),
        first_centre(lo[1]),
        last_centre(hi[0]),
        last_centre(hi[1]),
    ]
}

/// [`pixel_box`] of four snapped points held as i32 (as the fast path's records and projected
/// vertices hold them), on `simd`: with SSE4.1 (x86-64-v3) the extremes of the four points are
/// two vector min/max steps and the rounding to centres one add and one shift, ~12
/// instructions where the scalar form took ~40 (its i64 `div_euclid` and the eight minima and
/// maxima); otherwise [`pixel_box`]. The same box (`pixel_box_of_i32_points_is_pixel_box`).
#[inline(always)]
pub fn pixel_box_i32<S: pulp::Simd>(simd: S, q: &[[i32; 2]; 4]) -> [i64; 4] {
    #[cfg(target_arch = "x86_64")]
    if let Some(&v3) = (&simd as &dyn std::any::Any).downcast_ref::<pulp::x86::V3>() {
        return pixel_box_v3(v3, q);
    }
    let _ = simd;
    pixel_box(&q.map(|p| p.map(i64::from)))
}

/// [`pixel_box_i32`] in SSE4.1: the first centre ≥ x is `⌈(x − S/2)/S⌉ = (x − S/2 + S − 1) >> 12`
/// and the last ≤ x is `(x − S/2) >> 12` (S = [`SUBPIXEL`], an arithmetic shift: the floor);
/// |x| ≤ 2³⁰ ([`MAX_PIXEL_COORD`](super::MAX_PIXEL_COORD)), so the sums stay in i32.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn pixel_box_v3(v3: pulp::x86::V3, q: &[[i32; 2]; 4]) -> [i64; 4] {
    use std::arch::x86_64::__m128i;
    let (x2, x4) = (v3.sse2, v3.sse4_1);
    let [a, b]: [__m128i; 2] = bytemuck::cast(*q);
    // Per lane (x, y, x, y) the min and max of the points 0 and 2, 1 and 3; then of the halves.
    let (lo, hi) = (x4._mm_min_epi32(a, b), x4._mm_max_epi32(a, b));
    let lo = x4._mm_min_epi32(lo, x2._mm_shuffle_epi32::<0x4E>(lo));
    let hi = x4._mm_max_epi32(hi, x2._mm_shuffle_epi32::<0x4E>(hi));
    let half = (SUBPIXEL / 2) as i32;
    let round: __m128i = bytemuck::cast([
        SUBPIXEL as i32 - 1 - half,
        SUBPIXEL as i32 - 1 - half,
        -half,
        -half,
    ]);
    let bx = x2._mm_srai_epi32::<{ super::SUBPIXEL_BITS as i32 }>(
        x2._mm_add_epi32(x2._mm_unpacklo_epi64(lo, hi), round),
    );
    let bx: [i32; 4] = bytemuck::cast(bx);
    bx.map(i64::from)
}

/// [`pixel_box`] within the inclusive pixel rectangle `clip = [i0, j0, i1, j1]`; `None` where no
/// centre of the box is inside it.
#[inline(always)]
pub fn pixel_box_in(q: &[[i64; 2]; 4], clip: [i64; 4]) -> Option<[i64; 4]> {
    let b = pixel_box(q);
    let b = [
        b[0].max(clip[0]),
        b[1].max(clip[1]),
        b[2].min(clip[2]),
        b[3].min(clip[3]),
    ];
    (b[0] <= b[2] && b[1] <= b[3]).then_some(b)
}

/// Direction of the fan edge from the thick vertex towards vertex `v` (see
/// [`FanGeometry::dir_from_thick`]): from v's anchor in the table ([`Case::anchor`]).
#[inline(always)]
pub(super) fn dir_from_thick(c: &Case, q: &[[i64; 2]; 4], v: usize) -> [i64; 2] {
    let a = q[c.anchor[v] as usize];
    [q[v][0] - a[0], q[v][1] - a[1]]
}

/// Index of the first pixel whose centre is ≥ `x` (snapped units).
#[inline]
pub(super) fn first_centre(x: i64) -> i64 {
    let v = x - SUBPIXEL / 2;
    v.div_euclid(SUBPIXEL) + (v.rem_euclid(SUBPIXEL) != 0) as i64
}

/// `x.floor() as i64` without the libm call (`f64::floor` is one on baseline x86-64); the
/// snapped coordinates are far below 2^52, where the truncation is exact.
#[inline]
pub(super) fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - ((t as f64) > x) as i64
}

/// `x.ceil() as i64`, as [`floor_i64`].
#[inline]
pub(super) fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    t + ((t as f64) < x) as i64
}

/// Index of the last pixel whose centre is ≤ `x`.
#[inline]
pub(super) fn last_centre(x: i64) -> i64 {
    (x - SUBPIXEL / 2).div_euclid(SUBPIXEL)
}

/// One covered pixel centre: pixel (i, j), fan triangle `tri`, and the barycentric weights of
/// the triangle's silhouette vertices `fan[tri]` (`lx`) and `fan[tri + 1]` (`ly`); the thick
/// vertex has `1 − lx − ly`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    pub i: i64,
    pub j: i64,
    pub tri: usize,
    pub lx: f64,
    pub ly: f64,
}

/// An oriented edge line: inside is `E(p) = d × (p − b) > 0`; `bias` = 1 when the edge owns
/// the centres on it (the perturbed point (+ε, −ε²) is inside: `E(p + δ) = −d.x·ε² − d.y·ε`).
#[derive(Clone, Copy)]
pub(super) struct Edge {
    b: [i64; 2],
    pub(super) d: [i64; 2],
    pub(super) bias: i64,
}

impl Edge {
    #[inline]
    pub(super) fn new(b: [i64; 2], d: [i64; 2]) -> Edge {
        let bias = (d[1] < 0 || (d[1] == 0 && d[0] < 0)) as i64;
        Edge { b, d, bias }
    }
    #[inline]
    pub(super) fn at(&self, p: [i64; 2]) -> i64 {
        self.d[0] * (p[1] - self.b[1]) - self.d[1] * (p[0] - self.b[0])
    }
    /// The biased value at centre `p` and the steps per column and per row.
    #[inline(always)]
    pub(super) fn stepped(&self, p: [i64; 2]) -> [i64; 3] {
        [
            self.at(p) + self.bias,
            -self.d[1] * SUBPIXEL,
            self.d[0] * SUBPIXEL,
        ]
    }
}

/// Calls `f` for every pixel centre covered by the fan within the inclusive pixel rectangle
/// `clip = [i0, j0, i1, j1]`, once per centre.
#[inline]
pub fn raster_fan(g: &FanGeometry, clip: [i64; 4], mut f: impl FnMut(Fragment)) {
    let c = g.case;
    for tri in 0..c.ntri as usize {
        let (xv, yv) = (c.fan[tri] as usize, c.fan[tri + 1] as usize);
        let (x, y) = (g.q[xv], g.q[yv]);
        let dx = g.dir_from_thick(xv);
        let dy = g.dir_from_thick(yv);
        // Edges of (thick, x, y): thick→x, x→y, y→thick.
        let e0 = Edge::new(x, dx);
        let e1 = Edge::new(x, [y[0] - x[0], y[1] - x[1]]);
        let e2 = Edge::new(y, [-dy[0], -dy[1]]);
        // Barycentric normalisers: e0 vanishes at the thick vertex and at x, so e0(p)/e0(y) is
        // y's weight; likewise e2(p)/e2(x) is x's.
        let n_y = e0.at(y);
        let n_x = e2.at(x);
        if n_y <= 0 || n_x <= 0 {
            continue; // cannot happen for a table entry on exact tests
        }
        let (inv_x, inv_y) = (1.0 / n_x as f64, 1.0 / n_y as f64);
        let tx = [floor_i64(g.thick[0]), ceil_i64(g.thick[0])];
        let ty = [floor_i64(g.thick[1]), ceil_i64(g.thick[1])];
        let i0 = first_centre(x[0].min(y[0]).min(tx[0])).max(clip[0]);
        let j0 = first_centre(x[1].min(y[1]).min(ty[0])).max(clip[1]);
        let i1 = last_centre(x[0].max(y[0]).max(tx[1])).min(clip[2]);
        let j1 = last_centre(x[1].max(y[1]).max(ty[1])).min(clip[3]);
        if i0 > i1 || j0 > j1 {
            continue;
        }
        // Steps of the edge functions per pixel in x: −d.y·S.
        let st = [
            -e0.d[1] * SUBPIXEL,
            -e1.d[1] * SUBPIXEL,
            -e2.d[1] * SUBPIXEL,
        ];
        for j in j0..=j1 {
            let p = [pixel_centre(i0), pixel_centre(j)];
            let mut v = [e0.at(p) + e0.bias, e1.at(p) + e1.bias, e2.at(p) + e2.bias];
            let mut inside = false;
            for i in i0..=i1 {
                if v[0] > 0 && v[1] > 0 && v[2] > 0 {
                    inside = true;
                    f(Fragment {
                        i,
                        j,
                        tri,
                        lx: (v[2] - e2.bias) as f64 * inv_x,
                        ly: (v[0] - e0.bias) as f64 * inv_y,
                    });
                } else if inside {
                    // The covered centres of a row are contiguous (the triangle is convex).
                    break;
                }
                v[0] += st[0];
                v[1] += st[1];
                v[2] += st[2];
            }
        }
    }
}

/// One row of a fan triangle, for a caller that tests its pixels itself: a range
/// `i0..=i1` of row `j` (clipped) that holds every covered centre of the row, with the three
/// edge functions at `i0` (fill-rule bias included: pixel `i0 + k` is covered iff
/// `v[m] + k·st[m] > 0` for all m) and the barycentric weights of [`Fragment`] at `i0` with
/// their steps per pixel (`lx + k·dlx`, `ly + k·dly`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    pub tri: usize,
    pub j: i64,
    pub i0: i64,
    pub i1: i64,
    pub v: [i64; 3],
    pub st: [i64; 3],
    pub lx: f64,
    pub ly: f64,
    pub dlx: f64,
    pub dly: f64,
}

impl Row {
    /// Whether pixel `i0 + k` is covered.
    #[inline(always)]
    pub fn covers(&self, k: i64) -> bool {
        (self.v[0] + k * self.st[0] > 0)
            & (self.v[1] + k * self.st[1] > 0)
            & (self.v[2] + k * self.st[2] > 0)
    }
}

/// The rows of the fan for [`raster_fan`]'s coverage, narrowed per row: each edge bounds the
/// covered centres from one side at `k ≈ −v/st`, an f64 estimate within 1 of the exact bound,
/// so the range is the estimated span widened by 2 on each side; the caller's exact tests
/// ([`Row::covers`]) then give the same centres as `raster_fan` (test), without testing the
/// whole bounding box. Reads `case` and `q` only (not the thick vertex's float position: for
/// class 2 the bounding box of a fan triangle is taken with set A's edge, on which the thick
/// vertex lies). Rows with no covered centre may be skipped or not.
#[inline]
pub fn raster_fan_rows(c: &Case, q: &[[i64; 2]; 4], clip: [i64; 4], mut f: impl FnMut(Row)) {
    if !c.drawn() {
        return;
    }
    // The thick vertex's box: a vertex, or (class 2) the box of edge A, which contains it.
    let a0 = c.side_a.trailing_zeros() as usize;
    let (tlo, thi) = if c.class == 2 {
        let a1 = (c.side_a & !(1 << a0)).trailing_zeros() as usize;
        (
            [q[a0][0].min(q[a1][0]), q[a0][1].min(q[a1][1])],
            [q[a0][0].max(q[a1][0]), q[a0][1].max(q[a1][1])],
        )
    } else {
        (q[a0], q[a0])
    };
    for tri in 0..c.ntri as usize {
        let (xv, yv) = (c.fan[tri] as usize, c.fan[tri + 1] as usize);
        let (x, y) = (q[xv], q[yv]);
        let dx = dir_from_thick(c, q, xv);
        let dy = dir_from_thick(c, q, yv);
        let e = [
            Edge::new(x, dx),
            Edge::new(x, [y[0] - x[0], y[1] - x[1]]),
            Edge::new(y, [-dy[0], -dy[1]]),
        ];
        let n_y = e[0].at(y);
        let n_x = e[2].at(x);
        if n_y <= 0 || n_x <= 0 {
            continue; // cannot happen for a table entry on exact tests
        }
        let (inv_x, inv_y) = (1.0 / n_x as f64, 1.0 / n_y as f64);
        let ia = first_centre(x[0].min(y[0]).min(tlo[0])).max(clip[0]);
        let j0 = first_centre(x[1].min(y[1]).min(tlo[1])).max(clip[1]);
        let ib = last_centre(x[0].max(y[0]).max(thi[0])).min(clip[2]);
        let j1 = last_centre(x[1].max(y[1]).max(thi[1])).min(clip[3]);
        if ia > ib || j0 > j1 {
            continue;
        }
        let n = (ib - ia) as f64; // the last k
                                  // Per pixel in x the edge functions step by −d.y·S, per row by d.x·S.
        let st = e.map(|e| -e.d[1] * SUBPIXEL);
        let sr = e.map(|e| e.d[0] * SUBPIXEL);
        // −1/st, and which side each edge bounds (+1: from below, −1: from above, 0: neither).
        let ninv = st.map(|s| if s != 0 { -1.0 / s as f64 } else { 0.0 });
        let p = [pixel_centre(ia), pixel_centre(j0)];
        let mut v = [
            e[0].at(p) + e[0].bias,
            e[1].at(p) + e[1].bias,
            e[2].at(p) + e[2].bias,
        ];
        for j in j0..=j1 {
            let (mut lo, mut hi) = (0.0f64, n);
            for m in 0..3 {
                // Edge m is positive for k > −v/st (st > 0) or k < −v/st (st < 0).
                let b = v[m] as f64 * ninv[m];
                if st[m] > 0 {
                    lo = lo.max(b - 1.0);
                } else if st[m] < 0 {
                    hi = hi.min(b + 1.0);
                } else if v[m] <= 0 {
                    hi = -1.0;
                }
            }
            if lo <= hi {
                let (k0, k1) = (floor_i64(lo), ceil_i64(hi).min(ib - ia));
                if k0 <= k1 {
                    f(Row {
                        tri,
                        j,
                        i0: ia + k0,
                        i1: ia + k1,
                        v: [v[0] + k0 * st[0], v[1] + k0 * st[1], v[2] + k0 * st[2]],
                        st,
                        lx: (v[2] - e[2].bias + k0 * st[2]) as f64 * inv_x,
                        ly: (v[0] - e[0].bias + k0 * st[0]) as f64 * inv_y,
                        dlx: st[2] as f64 * inv_x,
                        dly: st[0] as f64 * inv_y,
                    });
                }
            }
            v[0] += sr[0];
            v[1] += sr[1];
            v[2] += sr[2];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::fan_points;
    use super::super::{classify, ProjVertex, MAX_PIXEL_COORD};
    use super::*;
    use crate::util::rng::Rng;

    /// The table's anchors put every fan edge on the line from the thick vertex through its
    /// vertex, pointing towards it: the thick vertex (classified in f64) lies on the line through
    /// the anchor and v, on the anchor's side of v. On random, lattice and degenerate fans
    /// (classes 1–4).
    #[test]
    fn anchors_put_fan_edges_through_the_thick_vertex() {
        let mut rng = Rng::new(31);
        let mut classes = [0usize; 5];
        for it in 0..4000 {
            let q = fan_points(&mut rng, it % 5);
            let v = q.map(|q| ProjVertex {
                q,
                ..Default::default()
            });
            let g = FanGeometry::new(q, &classify(&v, false, 1.0));
            let c = g.case;
            if !c.drawn() {
                continue;
            }
            classes[c.class as usize] += 1;
            for &v in &c.fan[..=c.ntri as usize] {
                let v = v as usize;
                let d = dir_from_thick(c, &q, v);
                // From the thick vertex to v.
                let (tx, ty) = (q[v][0] as f64 - g.thick[0], q[v][1] as f64 - g.thick[1]);
                let (dx, dy) = (d[0] as f64, d[1] as f64);
                let scale = (dx.abs() + dy.abs()) * (tx.abs() + ty.abs()) + 1.0;
                assert!(
                    (dx * ty - dy * tx).abs() <= 1e-9 * scale,
                    "{c:?}, v = {v}, {q:?}"
                );
                assert!(dx * tx + dy * ty > 0.0, "{c:?}, v = {v}, {q:?}");
            }
        }
        assert!(classes[1..].iter().all(|&n| n > 20), "{classes:?}");
    }

    /// [`pixel_box_i32`] on this host's vectors (x86-64-v3 where it has it, as CI's and the
    /// benchmark machines do) and on the scalar fallback is [`pixel_box`]: on the rasteriser
    /// tests' fans, on points on and beside pixel centres and corners, negative ones, and at
    /// ±2³⁰, the largest snapped coordinate.
    #[test]
    fn pixel_box_of_i32_points_is_pixel_box() {
        let mut rng = Rng::new(59);
        let m = (MAX_PIXEL_COORD as i64) * SUBPIXEL;
        let edge = [
            -m,
            -m + 1,
            m - 1,
            m,
            0,
            -1,
            1,
            2047,
            2048,
            2049,
            -2048,
            -2049,
            4095,
            4096,
        ];
        for it in 0..20_000 {
            let q: [[i64; 2]; 4] = match it % 3 {
                0 => fan_points(&mut rng, it % 5),
                1 => std::array::from_fn(|_| {
                    std::array::from_fn(|_| edge[rng.int(edge.len() as u64) as usize])
                }),
                _ => std::array::from_fn(|_| {
                    std::array::from_fn(|_| rng.int(16 * SUBPIXEL as u64) - 8 * SUBPIXEL)
                }),
            };
            let q32 = q.map(|p| p.map(|x| x as i32));
            let want = pixel_box(&q);
            assert_eq!(pixel_box_i32(pulp::Scalar::new(), &q32), want, "{q:?}");
            #[cfg(target_arch = "x86_64")]
            if let Some(v3) = pulp::x86::V3::try_new() {
                assert_eq!(pixel_box_i32(v3, &q32), want, "{q:?}");
            }
        }
    }
}
