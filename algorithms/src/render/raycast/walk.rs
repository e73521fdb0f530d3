//! The cell walk: the exit face of each cell from the edge products (the entry face's carried
//! over from the previous cell), the crossing's depth and scalar, and one ray's cast.


use super::predicate::RayCtx;
use super::{Prepared, RayStats, TERMINATE_T};
use crate::camera::{Camera, Ray};
use crate::mesh::{Mesh, BOUNDARY, FACE_VERTS};
use crate::optics::{composite_under, Segment};

/// The six edges of a tet as local vertex pairs, and the index of pair (x, y) in that list.
const LOCAL_EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
const LOCAL_EDGE_INDEX: [[usize; 4]; 4] = [[0, 0, 1, 2], [0, 0, 3, 4], [1, 3, 0, 5], [2, 4, 5, 0]];

/// Edge products of the face a ray left the previous cell through, keyed by global vertex pair
/// (lower id first): the next cell's entry face has the same edges, so they are not recomputed.
#[derive(Default)]
struct EdgeCarry {
    edges: [(u32, u32, (f64, bool)); 3],
    valid: bool,
}

impl EdgeCarry {
    #[inline]
    fn get(&self, a: u32, b: u32) -> Option<(f64, bool)> {
        if !self.valid {
            return None;
        }
        self.edges
            .iter()
            .find(|e| e.0 == a && e.1 == b)
            .map(|e| e.2)
    }
    #[inline]
    fn set(&mut self, edges: [(u32, u32, (f64, bool)); 3]) {
        self.edges = edges;
        self.valid = true;
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
    fn edge(&self, ray: &RayCtx, a: u32, b: u32) -> (f64, bool) {
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

    /// The face through which the ray leaves tet `t` that it entered through face `fin`.
    /// `carry` holds the products of the entry face's edges from the previous cell (keyed by
    /// global vertex pair), so only the three edges to the apex are computed here; on return
    /// it holds the exit face's. Returns the crossing and whether the fallback (no consistent
    /// face) was used.
    fn exit(
        &self,
        mesh: &Mesh,
        ray: &RayCtx,
        t: usize,
        fin: usize,
        carry: &mut EdgeCarry,
    ) -> (Crossing, bool) {
        let tet = mesh.tets()[t];
        // Products of the six edges, each for the direction lower global id → higher.
        let mut vals = [(0.0f64, false); 6];
        for (e, &(i, j)) in LOCAL_EDGES.iter().enumerate() {
            let (a, b) = (tet[i].min(tet[j]), tet[i].max(tet[j]));
            vals[e] = match carry.get(a, b) {
                Some(v) => v,
                None => self.edge(ray, a, b),
            };
        }
        // The directed product x → y (local indices) from the table.
        let directed = |x: usize, y: usize| -> (f64, bool) {
            let (v, s) = vals[LOCAL_EDGE_INDEX[x][y]];
            if tet[x] <= tet[y] {
                (v, s)
            } else {
                (-v, !s)
            }
        };
        let face_products = |f: usize| -> [(f64, bool); 3] {
            let c = FACE_VERTS[f];
            // Weight of vertex k is the product with the opposite edge.
            std::array::from_fn(|k| directed(c[(k + 1) % 3], c[(k + 2) % 3]))
        };
        let pos_tet = self.sign[t] > 0;
        let mut chosen = None;
        'search: for want in [pos_tet, !pos_tet] {
            for f in (0..4).filter(|&f| f != fin) {
                let p = face_products(f);
                if p.iter().all(|&(_, s)| s == want) {
                    chosen = Some((f, p, false));
                    break 'search;
                }
            }
        }
        // No face is consistent (a flat or numerically inverted cell): leave through the face
        // whose products are closest to consistent, at its own crossing point.
        let (f, p, fallback) = chosen.unwrap_or_else(|| {
            let sgn = if pos_tet { 1.0 } else { -1.0 };
            let mut best = (f64::NEG_INFINITY, (fin + 1) % 4);
            for f in (0..4).filter(|&f| f != fin) {
                let m = face_products(f)
                    .iter()
                    .map(|&(v, _)| sgn * v)
                    .fold(f64::INFINITY, f64::min);
                if m > best.0 {
                    best = (m, f);
                }
            }
            (best.1, face_products(best.1), true)
        });
        let c = FACE_VERTS[f];
        let tri = c.map(|k| tet[k]);
        let (tt, s) = self.interpolate(ray, tri, p.map(|(v, _)| v.abs()));
        carry.set(std::array::from_fn(|k| {
            let (x, y) = (c[(k + 1) % 3], c[(k + 2) % 3]);
            let (a, b) = (tet[x].min(tet[y]), tet[x].max(tet[y]));
            (a, b, vals[LOCAL_EDGE_INDEX[x][y]])
        }));
        (Crossing { face: f, t: tt, s }, fallback)
    }

    /// Casts one ray; returns the composited pixel and the ray's counters.
    pub(super) fn cast(&self, mesh: &Mesh, cam: &Camera, ray: &Ray) -> (Segment, RayStats) {
        let ctx = RayCtx::new(ray, cam, self.max_abs);
        let mut acc = Segment::default();
        let mut stats = RayStats::default();
        let mut t_min = f64::NEG_INFINITY;
        let mut exclude = u32::MAX;
        let mut first = true;
        'rays: while let Some((bt, bf, mut t_in, mut s_in)) =
            self.bvh
                .first_entry(self, mesh.tets(), &ctx, t_min - self.t_eps, exclude)
        {
            if !first {
                stats.reentries += 1;
            }
            first = false;
            let (mut tet, mut fin) = (bt as usize, bf);
            let mut carry = EdgeCarry::default();
            loop {
                stats.steps += 1;
                if stats.steps as usize > self.max_steps {
                    stats.lost += 1;
                    break 'rays;
                }
                let (x, fallback) = self.exit(mesh, &ctx, tet, fin, &mut carry);
                stats.fallbacks += fallback as u64;
                let t_out = x.t.max(t_in);
                let l = (t_out - t_in) * self.inv_l;
                if l > 0.0 {
                    composite_under(&mut acc, self.integrator.segment(s_in, x.s, l));
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
                t_in = t_out;
                s_in = x.s;
            }
        }
        if first && self.bvh.any_crossing(self, mesh.tets(), &ctx) {
            stats.missed += 1;
        }
        stats.filter_fallbacks = ctx.fallbacks.get();
        (acc, stats)
    }
}
