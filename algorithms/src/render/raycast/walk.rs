//! The reference walk: the exit face of each cell from the edge products in three dimensions
//! (the entry face's carried over from the previous cell), the crossing's depth and scalar, and
//! one ray's cast. The renderers walk with the projected walk (`projected.rs`), which decides
//! the same signs; this one is what the tests hold it to, and its edge predicate and face
//! crossings are the exact fallback and the entry tests of both.

use super::bvh::Front;
use super::predicate::RayCtx;
use super::shade::Shade;
use super::{Prepared, RayStats, TERMINATE_T};
use crate::mesh::{BOUNDARY, FACE_VERTS};
use crate::optics::{composite_under, Segment};

/// The six edges of a tet as local vertex pairs, and the index of pair (x, y) in that list.
const LOCAL_EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
const LOCAL_EDGE_INDEX: [[usize; 4]; 4] = [[0, 0, 1, 2], [0, 0, 3, 4], [1, 3, 0, 5], [2, 4, 5, 0]];

/// The products of a cell's six edges (local edge order [`LOCAL_EDGES`]), each for the
/// direction lower global id → higher, with their signs after the symbolic perturbation;
/// `known` marks the ones already computed (bit per edge). Each product is a function of the
/// ray and the edge's two global vertices only, so carrying the entry face's three from the
/// previous cell changes no bit of it.
struct Edges {
    vals: [(f64, bool); 6],
    known: u8,
}

impl Edges {
    const NONE: Edges = Edges {
        vals: [(0.0, false); 6],
        known: 0,
    };

    /// The entry face's edges of cell `g2` (entered through its face `f2`) from those of cell
    /// `g`, which the ray left through the same triangle; an edge whose vertices are not found
    /// (or coincide) is left to be computed.
    #[inline(always)]
    fn carried(&self, g: &[u32; 4], g2: &[u32; 4], f2: usize) -> Edges {
        // Local index in `g` of each vertex of `g2` (4 = not found).
        let find = |v: u32| -> usize {
            let m = (g[0] == v) as u32
                | ((g[1] == v) as u32) << 1
                | ((g[2] == v) as u32) << 2
                | ((g[3] == v) as u32) << 3;
            m.trailing_zeros().min(4) as usize
        };
        let at: [usize; 4] = std::array::from_fn(|k| find(g2[k]));
        let mut out = Edges::NONE;
        let c = FACE_VERTS[f2];
        for k in 0..3 {
            let (i, j) = (c[(k + 1) % 3], c[(k + 2) % 3]);
            let (x, y) = (at[i], at[j]);
            if x < 4 && y < 4 && x != y {
                let e = LOCAL_EDGE_INDEX[x][y];
                if self.known & (1 << e) != 0 {
                    let e2 = LOCAL_EDGE_INDEX[i][j];
                    out.vals[e2] = self.vals[e];
                    out.known |= 1 << e2;
                }
            }
        }
        out
    }
}

/// A face crossing: face index within the tet, depth `t` and scalar `s` at the crossing.
#[derive(Clone, Copy)]
struct Crossing {
    face: usize,
    t: f64,
    s: f64,
}

impl Prepared {
    /// Products of the ray with the directed edge `a → b` (global vertex ids), consistent for
    /// every cell that has the edge.
    #[inline]
    pub(super) fn edge(&self, ray: &RayCtx, a: u32, b: u32) -> (f64, bool) {
        if a < b {
            ray.side(self.verts[a as usize].p, self.verts[b as usize].p)
        } else {
            let (v, s) = ray.side(self.verts[b as usize].p, self.verts[a as usize].p);
            (-v, !s)
        }
    }

    /// Whether the ray crosses triangle `tri` (circulation order) with all products of sign
    /// `want`; if so the depth and scalar at the crossing.
    #[inline]
    pub(super) fn cross_face(&self, ray: &RayCtx, tri: [u32; 3], want: bool) -> Option<(f64, f64)> {
        let mut w = [0.0; 3];
        for k in 0..3 {
            // Weight of vertex k is the product with the opposite edge.
            let (v, s) = self.edge(ray, tri[(k + 1) % 3], tri[(k + 2) % 3]);
            if s != want {
                return None;
            }
            w[k] = v.abs();
        }
        Some(self.interpolate(ray, tri, w))
    }

    /// Whether the ray crosses triangle `tri` in either direction: the products of its three
    /// edges in circulation order have one sign. The same decisions as
    /// `cross_face(ray, tri, true)` or `cross_face(ray, tri, false)`, each product taken once.
    #[inline]
    pub(super) fn crosses_face(&self, ray: &RayCtx, tri: [u32; 3]) -> bool {
        let s0 = self.edge(ray, tri[1], tri[2]).1;
        s0 == self.edge(ray, tri[2], tri[0]).1 && s0 == self.edge(ray, tri[0], tri[1]).1
    }

    #[inline]
    fn interpolate(&self, ray: &RayCtx, tri: [u32; 3], w: [f64; 3]) -> (f64, f64) {
        let sum = w[0] + w[1] + w[2];
        let w = if sum > 0.0 && sum.is_finite() {
            w.map(|x| x / sum)
        } else {
            [1.0 / 3.0; 3]
        };
        let v = tri.map(|k| &self.verts[k as usize]);
        let p = w[0] * v[0].p + w[1] * v[1].p + w[2] * v[2].p;
        let s = w[0] * v[0].s + w[1] * v[1].s + w[2] * v[2].s;
        ((p - ray.o).dot(ray.d), s)
    }

    /// The face through which the ray leaves cell `t` (vertices `g`) that it entered through
    /// face `fin`. `edges` holds the products already known (the entry face's, carried from the
    /// previous cell); the others (the three edges to the apex, or all six in the first cell)
    /// are computed here. Returns the crossing and whether the fallback (no consistent face)
    /// was used.
    #[inline(always)]
    fn exit(
        &self,
        ray: &RayCtx,
        t: usize,
        fin: usize,
        g: &[u32; 4],
        edges: &mut Edges,
    ) -> (Crossing, bool) {
        if edges.known != 0b11_1111 {
            for (e, &(i, j)) in LOCAL_EDGES.iter().enumerate() {
                if edges.known & (1 << e) == 0 {
                    edges.vals[e] = self.edge(ray, g[i].min(g[j]), g[i].max(g[j]));
                }
            }
            edges.known = 0b11_1111;
        }
        let vals = &edges.vals;
        // Sign of the directed product x → y (local indices): the stored one, flipped when the
        // edge runs from the higher global id to the lower.
        let dsign = |x: usize, y: usize| -> u8 { (vals[LOCAL_EDGE_INDEX[x][y]].1 ^ (g[x] > g[y])) as u8 };
        // Per face, bit k = sign of the product with the edge opposite its vertex k.
        let mask = |f: usize| -> u8 {
            let c = FACE_VERTS[f];
            dsign(c[1], c[2]) | dsign(c[2], c[0]) << 1 | dsign(c[0], c[1]) << 2
        };
        let masks = [mask(0), mask(1), mask(2), mask(3)];
        let pos_tet = self.sign[t] > 0;
        let all = |want: bool| if want { 0b111 } else { 0 };
        let mut chosen = 4;
        'search: for want in [pos_tet, !pos_tet] {
            for (f, &m) in masks.iter().enumerate() {
                if f != fin && m == all(want) {
                    chosen = f;
                    break 'search;
                }
            }
        }
        let weights = |f: usize| -> [f64; 3] {
            let c = FACE_VERTS[f];
            // Weight of vertex k is the product with the opposite edge.
            std::array::from_fn(|k| vals[LOCAL_EDGE_INDEX[c[(k + 1) % 3]][c[(k + 2) % 3]]].0.abs())
        };
        let (f, fallback) = if chosen < 4 {
            (chosen, false)
        } else {
            (self.fallback_face(vals, g, fin, pos_tet), true)
        };
        let c = FACE_VERTS[f];
        let tri = c.map(|k| g[k]);
        let (tt, s) = self.interpolate(ray, tri, weights(f));
        (Crossing { face: f, t: tt, s }, fallback)
    }

    /// No face is consistent (a flat or numerically inverted cell): the face other than `fin`
    /// whose directed products are closest to consistent (the ray leaves at its own crossing
    /// point).
    #[cold]
    fn fallback_face(&self, vals: &[(f64, bool); 6], g: &[u32; 4], fin: usize, pos: bool) -> usize {
        let directed = |x: usize, y: usize| -> f64 {
            let v = vals[LOCAL_EDGE_INDEX[x][y]].0;
            if g[x] <= g[y] {
                v
            } else {
                -v
            }
        };
        let sgn = if pos { 1.0 } else { -1.0 };
        let mut best = (f64::NEG_INFINITY, (fin + 1) % 4);
        for f in (0..4).filter(|&f| f != fin) {
            let c = FACE_VERTS[f];
            let m = (0..3)
                .map(|k| sgn * directed(c[(k + 1) % 3], c[(k + 2) % 3]))
                .fold(f64::INFINITY, f64::min);
            if m > best.0 {
                best = (m, f);
            }
        }
        best.1
    }

    /// Casts one ray; returns the composited pixel and the ray's counters.
    #[inline(always)]
    pub(super) fn cast<S: Shade>(
        &self,
        tets: &[[u32; 4]],
        shade: &S,
        front: &Front,
        ctx: &RayCtx,
        seed: &mut u32,
    ) -> (Segment, RayStats) {
        let mut acc = Segment::default();
        let mut stats = RayStats::default();
        let mut t_min = f64::NEG_INFINITY;
        let mut exclude = u32::MAX;
        let mut first = true;
        // The first search is seeded with the previous ray's entry face (see `first_entry`).
        let mut hint = *seed;
        'rays: while let Some((bt, bf, mut t_in, s_in, leaf)) =
            self.bvh
                .first_entry(self, tets, front, ctx, t_min - self.t_eps, exclude, hint)
        {
            if first {
                *seed = leaf;
            } else {
                stats.reentries += 1;
            }
            first = false;
            hint = u32::MAX;
            let (mut tet, mut fin) = (bt as usize, bf);
            let mut g = tets[tet];
            let mut e_in = shade.end(s_in);
            let mut edges = Edges::NONE;
            loop {
                stats.steps += 1;
                if stats.steps as usize > self.max_steps {
                    stats.lost += 1;
                    break 'rays;
                }
                let (x, fallback) = self.exit(ctx, tet, fin, &g, &mut edges);
                stats.fallbacks += fallback as u64;
                let t_out = x.t.max(t_in);
                let l = (t_out - t_in) * self.inv_l;
                let e_out = shade.end(x.s);
                if l > 0.0 {
                    composite_under(&mut acc, shade.segment(&e_in, &e_out, l));
                    if 1.0 - acc.alpha < TERMINATE_T {
                        break 'rays;
                    }
                }
                let nb = self.next[tet][x.face];
                if nb == BOUNDARY {
                    t_min = t_out;
                    exclude = (4 * tet + x.face) as u32;
                    break;
                }
                tet = nb as usize / 4;
                fin = nb as usize % 4;
                let g2 = tets[tet];
                edges = edges.carried(&g, &g2, fin);
                g = g2;
                t_in = t_out;
                e_in = e_out;
            }
        }
        if first && self.bvh.any_crossing(self, tets, ctx) {
            stats.missed += 1;
        }
        stats.filter_fallbacks = ctx.fallbacks.get();
        (acc, stats)
    }
}
