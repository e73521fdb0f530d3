//! The tetrahedral ray caster: every ray enters the mesh through a boundary face (found in a
//! BVH over the boundary faces), walks from cell to cell through the face adjacency, and
//! re-enters at the next boundary face along the ray where the mesh is not convex
//! (Garrity 1990; Bunyk, Kaufman & Silva 1997). With the `exact` integrator it is `reference`,
//! the yardstick every image error is measured against, and it works in f64 throughout.
//!
//! **Watertightness.** Which face a ray crosses is decided from the signs of the Plücker
//! products of the ray with the face's edges (Platis & Theoharis 2003). Each edge's product is
//! computed once per ray from the edge oriented by global vertex index, so the two cells that
//! share an edge always agree on its sign. A product that is exactly zero (the ray meets the
//! edge's line) gets its sign by Simulation of Simplicity: the ray is shifted by ε·r + ε²·u (r, u
//! the camera's right and up vectors), which decides every edge not parallel to the ray in one
//! consistent way. So a ray through a shared edge or vertex is neither lost nor counted twice.
//! The same products give the barycentric coordinates of the crossing point on the face, from
//! which the depth and scalar are interpolated; the exit of one cell is the entry of the next.

use std::cell::Cell;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::{ms_since, Family, Frame, FrameTimes, RenderOptions, Renderer, RendererInfo};
use crate::camera::{Camera, Ray};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::{signed_volume6, Mesh, BOUNDARY, FACE_VERTS};
use crate::optics::{composite_under, integrator, Integrator, Segment, INTEGRATORS};
use crate::tf::TransferFunction;

/// Registry entry for `raycast` (any integrator; `partial` by default).
pub static RAYCAST: RendererInfo = RendererInfo {
    name: "raycast",
    description: "CPU ray caster walking cell to cell through face adjacency (rayon over rows)",
    sorts: &[],
    integrators: &INTEGRATORS,
    family: Family::RayCasting,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "partial",
    params: &[],
    make: |o| {
        Ok(Box::new(RayCaster::new(
            o.integrator.as_deref().unwrap_or("partial"),
            "raycast",
        )))
    },
};

/// Registry entry for `reference`: `raycast` with the `exact` integrator.
pub static REFERENCE: RendererInfo = RendererInfo {
    name: "reference",
    description: "the exact reference: raycast with the exact integrator, f64 throughout",
    sorts: &[],
    integrators: &["exact"],
    family: Family::RayCasting,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "exact",
    params: &[],
    make: |_: &RenderOptions| Ok(Box::new(RayCaster::new("exact", "reference"))),
};

/// Remaining transmittance below which a ray stops (its further contribution is < 1e-12).
const TERMINATE_T: f64 = 1e-12;

pub struct RayCaster {
    name: &'static str,
    integrator_name: String,
    state: Option<Prepared>,
}

struct Prepared {
    /// Vertex positions in the frame centred on the bounding box (CONVENTIONS §1).
    pos: Vec<DVec3>,
    /// Per-vertex transfer-function coordinate `s`.
    s: Vec<f64>,
    /// Orientation of each tet: +1, −1 (0 never stored: flat tets take +1 and are retried).
    sign: Vec<i8>,
    /// The walk's cell links: per tet and face, `4 · neighbour + the neighbour's face back to
    /// this tet`, or [`BOUNDARY`] (16 B/tet; the mesh's adjacency is not kept beside it).
    next: Vec<[u32; 4]>,
    /// Largest |coordinate| of `pos`, for the predicate filter's static error bound.
    max_abs: f64,
    bvh: Bvh,
    integrator: Box<dyn Integrator>,
    /// 1 / L: world length to optical length.
    inv_l: f64,
    /// Tolerance for re-entry at the same depth (concave boundary edges).
    t_eps: f64,
    max_steps: usize,
}

impl RayCaster {
    pub fn new(integrator: &str, name: &'static str) -> RayCaster {
        RayCaster {
            name,
            integrator_name: integrator.to_string(),
            state: None,
        }
    }
}

/// Counters of a frame: cell steps, rays that hit the step limit, walks that found no
/// consistent exit face (flat cells), re-entries through the boundary, and rays that cross the
/// boundary without entering it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayStats {
    pub steps: u64,
    pub lost: u64,
    pub fallbacks: u64,
    pub reentries: u64,
    /// Rays that cross the mesh boundary (their pixel centre is covered by the projected
    /// boundary) but found no face to enter through: a hole. 0 for a watertight entry test.
    pub missed: u64,
    /// Edge predicates the f64 filter could not decide, computed by the exact orient3d.
    pub filter_fallbacks: u64,
}

impl std::ops::AddAssign for RayStats {
    fn add_assign(&mut self, o: RayStats) {
        self.steps += o.steps;
        self.lost += o.lost;
        self.fallbacks += o.fallbacks;
        self.reentries += o.reentries;
        self.missed += o.missed;
        self.filter_fallbacks += o.filter_fallbacks;
    }
}

impl Renderer for RayCaster {
    fn name(&self) -> String {
        self.name.to_string()
    }
    fn integrator_name(&self) -> String {
        self.integrator_name.clone()
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        let integrator = integrator(&self.integrator_name, tf)?;
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let map = tf.scalar_map(mesh.scalar_range());
        let pos: Vec<DVec3> = mesh.positions().par_iter().map(|p| *p - c).collect();
        let s: Vec<f64> = mesh.scalars().par_iter().map(|&v| map.s(v)).collect();
        // The sign of `Mesh::volumes` (the same expression), without caching 8 B/tet there.
        let sign: Vec<i8> = (0..mesh.num_tets())
            .into_par_iter()
            .map(|t| {
                let v = signed_volume6(mesh.tet_points(t).map(|p| p - c)) / 6.0;
                if v < 0.0 {
                    -1
                } else {
                    1
                }
            })
            .collect();
        let (next, boundary) = {
            let adj = mesh.adjacency_transient();
            let nb = &adj.neighbors;
            let next: Vec<[u32; 4]> = nb
                .par_iter()
                .enumerate()
                .map(|(t, n)| {
                    n.map(|x| {
                        if x == BOUNDARY {
                            return BOUNDARY;
                        }
                        // Adjacency is symmetric by construction; a break is treated as
                        // boundary by the walk.
                        match (0..4).find(|&f| nb[x as usize][f] == t as u32) {
                            Some(back) => 4 * x + back as u32,
                            None => BOUNDARY,
                        }
                    })
                })
                .collect();
            // The boundary faces in `Mesh::boundary_faces` order.
            let boundary: Vec<u32> = (0..nb.len())
                .flat_map(|t| (0..4).map(move |f| (t, f)))
                .filter(|&(t, f)| nb[t][f] == BOUNDARY)
                .map(|(t, f)| (4 * t + f) as u32)
                .collect();
            (next, boundary)
        };
        let max_abs = pos
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        let bvh = Bvh::build(mesh, &pos, boundary);
        self.state = Some(Prepared {
            pos,
            s,
            sign,
            next,
            max_abs,
            bvh,
            integrator,
            inv_l: if l > 0.0 { 1.0 / l } else { 0.0 },
            t_eps: 1e-10 * l.max(f64::MIN_POSITIVE),
            max_steps: 64 + 8 * mesh.num_tets(),
        });
        Ok(())
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let t0 = Instant::now();
        let (px, stats) = self.render_f64(mesh, camera)?;
        let mut image = Image::new(camera.width, camera.height);
        for (o, p) in image.pixels.iter_mut().zip(&px) {
            *o = p.map(|c| c as f32);
        }
        let draw_ms = ms_since(t0);
        let rays = camera.width as u64 * camera.height as u64;
        Ok(Frame {
            image,
            times: FrameTimes {
                draw_ms,
                total_ms: draw_ms,
                ..Default::default()
            },
            counters: vec![
                ("rays", rays as f64),
                ("cell_steps", stats.steps as f64),
                ("lost_rays", stats.lost as f64),
                ("walk_fallbacks", stats.fallbacks as f64),
                ("reentries", stats.reentries as f64),
                ("missed_rays", stats.missed as f64),
                ("filter_fallbacks", stats.filter_fallbacks as f64),
            ],
        })
    }
}

impl RayCaster {
    /// Renders in f64 (premultiplied RGBA per pixel, row-major), with the ray counters. The
    /// `Renderer::render` image is this rounded to f32.
    pub fn render_f64(&self, mesh: &Mesh, camera: &Camera) -> Result<(Vec<[f64; 4]>, RayStats)> {
        let st = self
            .state
            .as_ref()
            .ok_or_else(|| Error::Internal("raycast: render before prepare".into()))?;
        let w = camera.width.max(1) as usize;
        let mut px = vec![[0.0f64; 4]; w * camera.height as usize];
        let stats = px
            .par_chunks_mut(w)
            .enumerate()
            .map(|(j, row)| {
                let mut rs = RayStats::default();
                for (i, p) in row.iter_mut().enumerate() {
                    let ray = camera.pixel_ray(i as u32, j as u32);
                    let (seg, s) = st.cast(mesh, camera, &ray);
                    rs += s;
                    *p = [seg.rgb[0], seg.rgb[1], seg.rgb[2], seg.alpha];
                }
                rs
            })
            .reduce(RayStats::default, |mut a, b| {
                a += b;
                a
            });
        Ok((px, stats))
    }
}

/// A ray with the perturbation directions of the Simulation of Simplicity tie-break.
struct RayCtx {
    o: DVec3,
    d: DVec3,
    /// A second point on the ray, `o + d`: with `o` it defines the line every predicate uses.
    q: DVec3,
    /// d × r and d × u: first- and second-order terms of the perturbed products.
    d_r: DVec3,
    d_u: DVec3,
    /// `q − o`, the column every orient3d of this ray shares, as orient3d computes it.
    c: DVec3,
    /// Static error bound of the f64 filter for this ray (see [`RayCtx::orient`]).
    bound: f64,
    /// Predicates the filter left to the exact orient3d.
    fallbacks: Cell<u64>,
}

/// Shewchuk's error-bound coefficient of orient3d's first stage, `(7 + 56ε)ε`, ε = 2⁻⁵³.
const O3D_ERRBOUND_A: f64 = (7.0 + 56.0 * f64::EPSILON / 2.0) * f64::EPSILON / 2.0;

#[inline]
fn coord(p: DVec3) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

impl RayCtx {
    /// `max_abs` bounds every vertex coordinate the ray is tested against.
    fn new(ray: &Ray, cam: &Camera, max_abs: f64) -> RayCtx {
        let (o, q) = (ray.origin, ray.origin + ray.dir);
        let c = q - o;
        // |u − o|, |v − o| ≤ a and |q − o| ≤ cm per coordinate, so orient3d's permanent is at
        // most 6·a²·cm (three terms of two products each) and its dynamic bound
        // O3D_ERRBOUND_A·permanent at most this static one (the factor covers the rounding
        // of the bound's own arithmetic, ~10 ε).
        let a = max_abs + o.abs().max_element();
        let cm = c.abs().max_element();
        RayCtx {
            o,
            d: ray.dir,
            q,
            d_r: ray.dir.cross(cam.right),
            d_u: ray.dir.cross(cam.up),
            c,
            bound: O3D_ERRBOUND_A * 6.0 * a * a * cm * (1.0 + 1e-12),
            fallbacks: Cell::new(0),
        }
    }

    /// `orient3d(u, v, q, o) = det[u − o, v − o, q − o]`, filtered: orient3d's own first stage
    /// (the same expression, so the same bits) is accepted when it exceeds the static bound of
    /// this ray, which is never below orient3d's dynamic one — so the result is bit for bit
    /// what `robust::orient3d` returns, without its permanent and call. Otherwise (the
    /// filter cannot decide the sign) the exact adaptive predicate is called and counted.
    #[inline(always)]
    fn orient(&self, pu: DVec3, pv: DVec3) -> f64 {
        let (o, c) = (self.o, self.c);
        let (adx, ady, adz) = (pu.x - o.x, pu.y - o.y, pu.z - o.z);
        let (bdx, bdy, bdz) = (pv.x - o.x, pv.y - o.y, pv.z - o.z);
        let (cdx, cdy, cdz) = (c.x, c.y, c.z);
        let bdxcdy = bdx * cdy;
        let cdxbdy = cdx * bdy;
        let cdxady = cdx * ady;
        let adxcdy = adx * cdy;
        let adxbdy = adx * bdy;
        let bdxady = bdx * ady;
        let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
        if det > self.bound || -det > self.bound {
            return det;
        }
        self.fallbacks.set(self.fallbacks.get() + 1);
        robust::orient3d(coord(pu), coord(pv), coord(self.q), coord(self.o))
    }

    /// Plücker product of the ray with the edge from `u` to `v` (callers pass the lower global
    /// index first), `det[u − o, v − o, q − o]`, with an exact sign (Shewchuk's adaptive
    /// orient3d): every decision is then that of one real line, the one through `o` and `q`.
    /// Returns the value and its sign after the symbolic perturbation.
    #[inline]
    fn side(&self, pu: DVec3, pv: DVec3) -> (f64, bool) {
        let p = self.orient(pu, pv);
        if p != 0.0 {
            return (p, p > 0.0);
        }
        // The line meets the edge's line: shift it by ε·r + ε²·u. The ε-term of
        // det[u − o − εδ, v − o − εδ, d] is det[δ, u − v, d] = (u − v)·(d × δ).
        let e = pu - pv;
        let p1 = e.dot(self.d_r);
        if p1 != 0.0 {
            return (0.0, p1 > 0.0);
        }
        (0.0, e.dot(self.d_u) >= 0.0)
    }
}

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
            ray.side(self.pos[a as usize], self.pos[b as usize])
        } else {
            let (v, s) = ray.side(self.pos[b as usize], self.pos[a as usize]);
            (-v, !s)
        }
    }

    /// Whether the ray crosses triangle `tri` (circulation order) with all products of sign
    /// `want`; if so the depth and scalar at the crossing.
    #[inline]
    fn cross_face(&self, ray: &RayCtx, tri: [u32; 3], want: bool) -> Option<(f64, f64)> {
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
        let p = w[0] * self.pos[tri[0] as usize]
            + w[1] * self.pos[tri[1] as usize]
            + w[2] * self.pos[tri[2] as usize];
        let s = w[0] * self.s[tri[0] as usize]
            + w[1] * self.s[tri[1] as usize]
            + w[2] * self.s[tri[2] as usize];
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
    fn cast(&self, mesh: &Mesh, cam: &Camera, ray: &Ray) -> (Segment, RayStats) {
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

/// For each boundary face `bfs` of `mesh` (4·tet + face), whether its
/// [`FACE_VERTS`] circulation points out of the mesh.
///
/// A face of a tet with a nonzero exact orientation (Shewchuk's orient3d on the centred
/// positions the walk uses) points out when the tet is positive. A zero-volume tet has no
/// orientation of its own — blunt has 77, some with two boundary faces, and taking them as
/// positive turned their entry faces into exit faces (the holes of issue 13). Such a face takes
/// the orientation that makes the boundary surface consistent: across a boundary edge shared by
/// exactly two boundary faces, the two circulations run the edge in opposite directions. It is
/// propagated breadth-first from the oriented faces; a connected patch of flat faces with no
/// oriented neighbour keeps "positive".
fn boundary_outward(mesh: &Mesh, pos: &[DVec3], bfs: &[u32]) -> Vec<bool> {
    let tets = mesh.tets();
    // 1 = out (FACE_VERTS circulation outward), 0 = in, 2 = undecided.
    let mut out: Vec<u8> = bfs
        .par_iter()
        .map(|&bf| {
            let t = tets[bf as usize / 4].map(|v| coord(pos[v as usize]));
            // orient3d(a, b, c, d) = det[a − d, b − d, c − d] = −det(b − a, c − a, d − a).
            let o = robust::orient3d(t[0], t[1], t[2], t[3]);
            if o < 0.0 {
                1
            } else if o > 0.0 {
                0
            } else {
                2
            }
        })
        .collect();
    if out.iter().all(|&o| o != 2) {
        return out.into_iter().map(|o| o == 1).collect();
    }
    // Boundary edges: (low id, high id, face index, runs low → high in the circulation).
    let mut edges: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * bfs.len());
    for (i, &bf) in bfs.iter().enumerate() {
        let tri = mesh.face_vertices(bf as usize / 4, bf as usize % 4);
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), i as u32, a < b));
        }
    }
    edges.par_sort_unstable();
    // Neighbours across manifold boundary edges (exactly two faces): (other face, whether this
    // face's circulation runs the edge low → high, whether the other's does).
    let mut pairs: Vec<Vec<(u32, bool, bool)>> = vec![Vec::new(); bfs.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        if j - i == 2 {
            let (x, y) = (edges[i], edges[i + 1]);
            pairs[x.2 as usize].push((y.2, x.3, y.3));
            pairs[y.2 as usize].push((x.2, y.3, x.3));
        }
        i = j;
    }
    let mut queue: std::collections::VecDeque<u32> = (0..bfs.len() as u32)
        .filter(|&f| out[f as usize] != 2)
        .collect();
    while let Some(f) = queue.pop_front() {
        let of = out[f as usize] == 1;
        for &(g, df, dg) in &pairs[f as usize] {
            if out[g as usize] != 2 {
                continue;
            }
            // Oriented outwards, f runs the edge low → high iff df == of; g must run it the
            // other way: (dg == og) == !(df == of).
            let og = dg != (df == of);
            out[g as usize] = og as u8;
            queue.push_back(g);
        }
    }
    out.into_iter().map(|o| o != 0).collect()
}

/// A bounding-volume hierarchy over the boundary faces, for the first entry of a ray at or
/// beyond a depth.
struct Bvh {
    nodes: Vec<BvhNode>,
    /// Boundary faces as 4·tet + face, in leaf order.
    faces: Vec<u32>,
    /// Per face in leaf order: the sign of the edge products of a ray entering the mesh through
    /// it (the opposite of the outward circulation's).
    entering: Vec<bool>,
}


#[derive(Clone, Copy)]
struct BvhNode {
    min: DVec3,
    max: DVec3,
    /// Leaf: first face and count (count > 0). Inner: index of the left child (right follows it).
    start: u32,
    count: u32,
}

const LEAF_SIZE: usize = 4;

impl Bvh {
    /// `boundary`: the boundary faces as 4·tet + face, ascending.
    fn build(mesh: &Mesh, pos: &[DVec3], boundary: Vec<u32>) -> Bvh {
        let mut faces: Vec<u32> = boundary.clone();
        let tri = |bf: u32| mesh.face_vertices(bf as usize / 4, bf as usize % 4);
        let centroid = |bf: u32| {
            let v = tri(bf);
            (pos[v[0] as usize] + pos[v[1] as usize] + pos[v[2] as usize]) / 3.0
        };
        let mut nodes = Vec::with_capacity(2 * faces.len() / LEAF_SIZE + 1);
        // Iterative build with an explicit stack of (node index, start, end).
        nodes.push(BvhNode {
            min: DVec3::ZERO,
            max: DVec3::ZERO,
            start: 0,
            count: 0,
        });
        let mut stack = vec![(0usize, 0usize, faces.len())];
        while let Some((ni, a, b)) = stack.pop() {
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            let (mut clo, mut chi) = (lo, hi);
            for &f in &faces[a..b] {
                for v in tri(f) {
                    lo = lo.min(pos[v as usize]);
                    hi = hi.max(pos[v as usize]);
                }
                let c = centroid(f);
                clo = clo.min(c);
                chi = chi.max(c);
            }
            nodes[ni].min = lo;
            nodes[ni].max = hi;
            if b - a <= LEAF_SIZE {
                nodes[ni].start = a as u32;
                nodes[ni].count = (b - a) as u32;
                continue;
            }
            let ext = chi - clo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = (a + b) / 2;
            faces[a..b].select_nth_unstable_by(mid - a, |&p, &q| {
                centroid(p)[axis].total_cmp(&centroid(q)[axis])
            });
            // Children are stored side by side: left at `start`, right at `start + 1`.
            let left = nodes.len();
            nodes.push(nodes[ni]);
            nodes.push(nodes[ni]);
            nodes[ni].start = left as u32;
            nodes[ni].count = 0;
            stack.push((left + 1, mid, b));
            stack.push((left, a, mid));
        }
        let outward = boundary_outward(mesh, pos, &boundary);
        let entering = faces
            .iter()
            .map(|bf| boundary.binary_search(bf).is_ok_and(|i| !outward[i]))
            .collect();
        Bvh {
            nodes,
            faces,
            entering,
        }
    }

    /// Slab test: the parameter interval where the ray is inside the box, clipped to
    /// [t_lo, t_hi]; expanded by a relative epsilon so grazing rays are not lost.
    #[inline]
    fn hit_box(n: &BvhNode, ray: &RayCtx, t_lo: f64, t_hi: f64) -> bool {
        let mut t0 = t_lo;
        let mut t1 = t_hi;
        for k in 0..3 {
            let pad = 1e-9 * (n.max[k] - n.min[k]).abs().max(1e-300);
            let (lo, hi) = (n.min[k] - pad, n.max[k] + pad);
            let d = ray.d[k];
            let o = ray.o[k];
            if d == 0.0 {
                if o < lo || o > hi {
                    return false;
                }
                continue;
            }
            let inv = 1.0 / d;
            let (mut a, mut b) = ((lo - o) * inv, (hi - o) * inv);
            if a > b {
                std::mem::swap(&mut a, &mut b);
            }
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return false;
            }
        }
        true
    }

    /// The nearest boundary face the ray enters at depth ≥ `t_min`, other than `exclude`:
    /// (tet, face, depth, scalar).
    fn first_entry(
        &self,
        st: &Prepared,
        tets: &[[u32; 4]],
        ray: &RayCtx,
        t_min: f64,
        exclude: u32,
    ) -> Option<(u32, usize, f64, f64)> {
        if self.faces.is_empty() {
            return None;
        }
        let mut best: Option<(u32, usize, f64, f64)> = None;
        let mut best_t = f64::INFINITY;
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let n = &self.nodes[stack[sp] as usize];
            if !Self::hit_box(n, ray, t_min, best_t) {
                continue;
            }
            if n.count > 0 {
                let leaf = n.start as usize..(n.start + n.count) as usize;
                for (&bf, &entering) in self.faces[leaf.clone()].iter().zip(&self.entering[leaf])
                {
                    if bf == exclude {
                        continue;
                    }
                    let (t, f) = (bf as usize / 4, bf as usize % 4);
                    let tri = FACE_VERTS[f].map(|k| tets[t][k]);
                    if let Some((tt, s)) = st.cross_face(ray, tri, entering) {
                        if tt >= t_min && tt < best_t {
                            best_t = tt;
                            best = Some((t as u32, f, tt, s));
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = n.start + 1;
                stack[sp + 1] = n.start;
                sp += 2;
            }
        }
        best
    }

    /// Whether the ray crosses any boundary face, in either direction (the same edge
    /// predicates as the walk): a ray that does but enters none is a hole.
    fn any_crossing(&self, st: &Prepared, tets: &[[u32; 4]], ray: &RayCtx) -> bool {
        if self.faces.is_empty() {
            return false;
        }
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let n = &self.nodes[stack[sp] as usize];
            if !Self::hit_box(n, ray, f64::NEG_INFINITY, f64::INFINITY) {
                continue;
            }
            if n.count > 0 {
                for &bf in &self.faces[n.start as usize..(n.start + n.count) as usize] {
                    let (t, f) = (bf as usize / 4, bf as usize % 4);
                    let tri = FACE_VERTS[f].map(|k| tets[t][k]);
                    if st.cross_face(ray, tri, true).is_some()
                        || st.cross_face(ray, tri, false).is_some()
                    {
                        return true;
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = n.start + 1;
                stack[sp + 1] = n.start;
                sp += 2;
            }
        }
        false
    }
}
