//! The boundary: each boundary face's outward orientation (flat tets oriented by propagation)
//! and a BVH over the boundary faces for a ray's first entry at or beyond a depth.

use glam::DVec3;
use rayon::prelude::*;

use super::predicate::{coord, RayCtx};
use super::{Prepared, Vert};
use crate::camera::{Camera, Projection};
use crate::mesh::{Mesh, FACE_VERTS};

/// For each boundary face `bfs` of `mesh` (4·tet + face), whether its
/// [`FACE_VERTS`] circulation points out of the mesh.
///
/// A face of a tet with a nonzero exact orientation (Shewchuk's orient3d on the centred
/// positions the walk uses) points out when the tet is positive. A zero-volume tet has no
/// orientation of its own — blunt has 77, some with two boundary faces, and taking them as
/// positive turned their entry faces into exit faces (holes in the image). Such a face takes
/// the orientation that makes the boundary surface consistent: across a boundary edge shared by
/// exactly two boundary faces, the two circulations run the edge in opposite directions. It is
/// propagated breadth-first from the oriented faces; a connected patch of flat faces with no
/// oriented neighbour keeps "positive".
fn boundary_outward(mesh: &Mesh, pos: &[Vert], bfs: &[u32]) -> Vec<bool> {
    let tets = mesh.tets();
    // 1 = out (FACE_VERTS circulation outward), 0 = in, 2 = undecided.
    let mut out: Vec<u8> = bfs
        .par_iter()
        .map(|&bf| {
            let t = tets[bf as usize / 4].map(|v| coord(pos[v as usize].p));
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
pub(super) struct Bvh {
    nodes: Vec<BvhNode>,
    /// Boundary faces as 4·tet + face, in leaf order.
    pub(super) faces: Vec<u32>,
    /// Per face in leaf order: the sign of the edge products of a ray entering the mesh through
    /// it (the opposite of the outward circulation's).
    pub(super) entering: Vec<bool>,
}


#[derive(Clone, Copy)]
struct BvhNode {
    /// The box of the faces below, padded by a relative epsilon (1e-9 of its extent).
    min: DVec3,
    max: DVec3,
    /// Leaf: first face and count (count > 0). Inner: index of the left child (right follows it).
    start: u32,
    count: u32,
}

const LEAF_SIZE: usize = 4;

impl Bvh {
    /// `boundary`: the boundary faces as 4·tet + face, ascending.
    pub(super) fn build(mesh: &Mesh, pos: &[Vert], boundary: Vec<u32>) -> Bvh {
        let mut faces: Vec<u32> = boundary.clone();
        let tri = |bf: u32| mesh.face_vertices(bf as usize / 4, bf as usize % 4);
        let centroid = |bf: u32| {
            let v = tri(bf);
            (pos[v[0] as usize].p + pos[v[1] as usize].p + pos[v[2] as usize].p) / 3.0
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
                    lo = lo.min(pos[v as usize].p);
                    hi = hi.max(pos[v as usize].p);
                }
                let c = centroid(f);
                clo = clo.min(c);
                chi = chi.max(c);
            }
            // The slab test's box, padded by a relative epsilon so grazing rays are not lost.
            let pad = (hi - lo).abs().max(DVec3::splat(1e-300)) * 1e-9;
            nodes[ni].min = lo - pad;
            nodes[ni].max = hi + pad;
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

    /// The sign of the edge products (in [`FACE_VERTS`] circulation) of a ray entering through
    /// the face at leaf index `leaf` (as [`Bvh::first_entry`] returns it).
    #[inline]
    pub(super) fn entering_sign(&self, leaf: u32) -> bool {
        self.entering[leaf as usize]
    }

    /// Slab test: the parameter interval where the ray is inside the box, clipped to
    /// [t_lo, t_hi]; expanded by a relative epsilon so grazing rays are not lost.
    #[inline]
    fn hit_box(n: &BvhNode, ray: &RayCtx, t_lo: f64, t_hi: f64) -> bool {
        let mut t0 = t_lo;
        let mut t1 = t_hi;
        for k in 0..3 {
            let (lo, hi) = (n.min[k], n.max[k]);
            let d = ray.d[k];
            let o = ray.o[k];
            if d == 0.0 {
                if o < lo || o > hi {
                    return false;
                }
                continue;
            }
            let inv = ray.inv_d[k];
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
    ///
    /// Only the faces and subtrees `front` keeps are searched (the others cannot be entered by
    /// any ray of the frame's camera).
    ///
    /// `seed` (a face index in leaf order, or `u32::MAX`) is a face the ray probably enters
    /// through (the previous ray's): if it does, at depth `t_s ≥ t_min`, the search starts with
    /// `t_s` (plus a margin of 1e-9 of the mesh's size) as its bound, which prunes every box beyond
    /// it. The answer is the same: the first face in traversal order with the least depth (a
    /// face at exactly `t_s` is taken only while nothing is found, as it would be when first
    /// met); only faces whose depths tie to the rounding of a slab test could be ordered
    /// otherwise, and `tests/tests/renderers/raycast_bits.rs` pins the images. Returns the face's leaf
    /// index too.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn first_entry(
        &self,
        st: &Prepared,
        tets: &[[u32; 4]],
        front: &Front,
        ray: &RayCtx,
        t_min: f64,
        exclude: u32,
        seed: u32,
    ) -> Option<(u32, usize, f64, f64, u32)> {
        if self.faces.is_empty() {
            return None;
        }
        let tri_of = |bf: u32| FACE_VERTS[bf as usize % 4].map(|k| tets[bf as usize / 4][k]);
        let mut best: Option<(u32, usize, f64, f64, u32)> = None;
        let mut best_t = f64::INFINITY;
        if let Some(&bf) = self.faces.get(seed as usize) {
            if bf != exclude && front.faces[seed as usize] {
                if let Some((tt, _)) = st.cross_face(ray, tri_of(bf), self.entering[seed as usize])
                {
                    if tt >= t_min {
                        best_t = tt;
                    }
                }
            }
        }
        let slack = 10.0 * st.t_eps;
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp] as usize;
            let n = &self.nodes[ni];
            // Until a face is found the seed's depth bounds the search with a margin: a flat
            // box (a face in an axis plane) has no padding, and its slab depth may be an ulp
            // beyond the depth interpolated on its face.
            let bound = if best.is_none() {
                best_t + slack
            } else {
                best_t
            };
            if !front.nodes[ni] || !Self::hit_box(n, ray, t_min, bound) {
                continue;
            }
            if n.count > 0 {
                let leaf = n.start as usize..(n.start + n.count) as usize;
                for i in leaf {
                    let bf = self.faces[i];
                    if bf == exclude || !front.faces[i] {
                        continue;
                    }
                    if let Some((tt, s)) = st.cross_face(ray, tri_of(bf), self.entering[i]) {
                        if tt >= t_min && (tt < best_t || (best.is_none() && tt == best_t)) {
                            best_t = tt;
                            best = Some((bf / 4, bf as usize % 4, tt, s, i as u32));
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
    pub(super) fn any_crossing(&self, st: &Prepared, tets: &[[u32; 4]], ray: &RayCtx) -> bool {
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
                    if st.crosses_face(ray, tri) {
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

/// Per frame: the boundary faces a ray of the frame's camera may enter through, and the BVH
/// nodes with any such face below them.
pub(super) struct Front {
    nodes: Vec<bool>,
    pub(super) faces: Vec<bool>,
}

impl Front {
    /// Bytes the front holds.
    pub(super) fn bytes(&self) -> usize {
        self.nodes.len() + self.faces.len()
    }
}

impl Bvh {
    /// Which boundary faces a ray of `cam` can enter through, conservatively.
    ///
    /// The directed edge products of a ray with a triangle `(a, b, c)` sum to `d · N`,
    /// `N = (b − a) × (c − a)` (the origin terms cancel). A ray crosses the face with all
    /// products of the entering sign only if `d · N` has that sign or is 0 (each product's sign
    /// is exact, and a product that is exactly 0 adds nothing). For the orthographic camera `d`
    /// is the same for every ray; for the perspective one every ray starts at the eye `e`, and
    /// at its crossing point `x = e + t·d` (t > 0: the eye sees the whole mesh in front of it)
    /// `d · N = (x − e) · N / t = (a − e) · N / t`. A face is dropped only where that sign,
    /// computed in f64, is the wrong one by more than a bound of its rounding error (1e-12 of
    /// its permanent; the rounding is ~1e-15), so no face a ray could enter is dropped and the
    /// search returns what it would without this.
    pub(super) fn front(&self, verts: &[super::Vert], tets: &[[u32; 4]], cam: &Camera) -> Front {
        let persp = matches!(cam.projection, Projection::Persp);
        let eye = cam.eye();
        // Perspective: the mesh must lie wholly in front of the eye (it does: the eye is at
        // 3R from the centre, the mesh within R of it); otherwise nothing is dropped.
        let in_front = !persp
            || verts
                .iter()
                .all(|v| (v.p - eye).dot(cam.forward) > 1e-9 * cam.radius);
        let faces: Vec<bool> = self
            .faces
            .par_iter()
            .zip(&self.entering)
            .map(|(&bf, &entering)| {
                if !in_front {
                    return true;
                }
                let (t, f) = (bf as usize / 4, bf as usize % 4);
                let [a, b, c] = FACE_VERTS[f].map(|k| verts[tets[t][k] as usize].p);
                let (ab, ac) = (b - a, c - a);
                let n = ab.cross(ac);
                // The permanent of the cross product: its terms in absolute value.
                let nabs = DVec3::new(
                    (ab.y * ac.z).abs() + (ab.z * ac.y).abs(),
                    (ab.z * ac.x).abs() + (ab.x * ac.z).abs(),
                    (ab.x * ac.y).abs() + (ab.y * ac.x).abs(),
                );
                let dir = if persp { a - eye } else { cam.forward };
                let dn = dir.dot(n);
                let bound = 1e-12 * dir.abs().dot(nabs);
                if entering {
                    dn >= -bound
                } else {
                    dn <= bound
                }
            })
            .collect();
        let mut nodes = vec![false; self.nodes.len()];
        // Children follow their parent in `nodes`, so a reverse pass sees them first.
        for i in (0..self.nodes.len()).rev() {
            let n = &self.nodes[i];
            nodes[i] = if n.count > 0 {
                faces[n.start as usize..(n.start + n.count) as usize]
                    .iter()
                    .any(|&o| o)
            } else {
                nodes[n.start as usize] || nodes[n.start as usize + 1]
            };
        }
        Front { nodes, faces }
    }
}
