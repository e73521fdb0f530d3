//! `xmpvo`: an exact visibility order for non-convex meshes, at image resolution. MPVONC's
//! interior-face DAG (Williams, "Visibility ordering meshed polyhedra", ACM TOG 11(2), 1992) plus
//! the constraints that occlusion across empty space imposes, found per pixel ray among the
//! mesh's boundary faces: the image-space exterior ordering of Cook, Max, Silva & Williams
//! ("Image-space visibility ordering for cell projection volume rendering of unstructured data",
//! IEEE TVCG 10(6), 2004), after Silva, Mitchell & Williams' XMPVO (VolVis 1998).
//!
//! **Setup** ([`Sort::prepare`]). As `mpvonc`: every interior face's plane (unit normal from tet
//! `a` into tet `b`, offset, the two tets; 24 bytes per interior face) and the f32 centroids.
//! Also the boundary surface: each boundary face's three vertices, its tet and the tet's sign
//! (20 bytes a face; the sign from the tet's signed volume, 0 below `Mesh::degenerate_tets`'
//! threshold) and the centred f32 positions of the boundary vertices (12 bytes each), the very
//! numbers `cpu-pt` projects.
//!
//! **Per frame.**
//! 1. *Interior faces*, oriented as in `mpvonc`: `s = n · eye − d` (persp) or `s = n · to_eye`
//!    (ortho); `s > ε`: edge `a → b` (`a` is farther and comes first), `s < −ε`: `b → a`,
//!    `|s| ≤ ε`: no edge (ε = 1e-6·L persp, 1e-6 ortho).
//! 2. *Exterior constraints* (the `exterior` module): the boundary faces are rasterised at the
//!    camera's resolution with `cpu-pt`'s snapping and fill rule; per pixel, the crossings of the
//!    pixel ray with the boundary sorted by depth; from each exit face and the next entry face
//!    behind it (and from every consecutive pair in a pixel whose crossings do not alternate),
//!    the edge "the farther cell first". Deduplicated, they are held as a CSR list per tet.
//! 3. *Topological sort*, as `mpvonc`'s: sources farthest first by centroid key, Kahn with a
//!    LIFO stack run dry after each source.
//!
//! **What that guarantees.** Take any pixel centre and the cells its (perturbed) ray crosses, in
//! order. Consecutive cells either share an interior face the ray crosses — the eye is on the
//! nearer cell's side of its plane, so step 1 gives the edge — or are separated by a stretch of
//! empty space between an exit face and the next entry face, which step 2 gives. So the cells of
//! every pixel form a chain in the graph, and any topological order composites every pixel in
//! ray order: **exact at image resolution** whenever the graph is acyclic. It can still break
//! (a) where the graph has a cycle — cells that overlap each other cyclically along different
//! rays, which no order can satisfy: found, counted and broken as in `mpvonc`; (b) where an
//! interior face is crossed while within ε of edge-on (no edge, as in `mpvonc`); (c) for a
//! renderer whose coverage differs from `cpu-pt`'s (the GPU renderers rasterise with their own
//! rule: a pixel-centre tie there may see two cells in an order that was not constrained);
//! (d) for a camera other than the one given (the constraints are per pixel of this image).
//!
//! **Cycles and bad input.** As in `mpvonc`: at the first stall the strongly connected
//! components of the remaining graph (interior and exterior edges) are counted
//! ([`SortStats::cycles`], [`SortStats::cells_in_cycles`]), then the farthest remaining cell by
//! centroid key is emitted regardless of its predecessors ([`SortStats::forced`]) at each stall.
//! A mesh with no boundary (every face glued twice) has no exterior constraints; non-manifold
//! or open boundaries make pixels whose crossings do not alternate entry/exit, counted in
//! [`SortStats::irregular_pixels`]: their pairs are all kept, and what they make contradictory
//! ends as a counted cycle. Every tet is emitted exactly once. An image for which the boundary
//! rasterisation would exceed `exterior::MAX_FRAGMENTS` (2^28) fragments is refused with an
//! `Error::Input` naming its size.
//!
//! **Memory.** Prepared: ~48 bytes a tet of interior faces, 12 of centroids, 5 of in-degree and
//! edge bits, plus 20 a boundary face and 12 a boundary vertex. Per frame: 4 bytes a tet (CSR
//! offsets), 4 an exterior edge, and the rasteriser's per-band hit lists (24 bytes a hit).

mod exterior;

use super::{
    centroids, check_prepared, f32x3, seed_sources, KeyFn, Sort, SortInfo, SortStats, Stall,
};
use crate::camera::{Camera, Projection};
use crate::error::Result;
use crate::mesh::{signed_volume6, Mesh};
use exterior::{exterior, BoundaryFace};

use super::mpvonc::Face;

/// In-degree mark of a cell emitted by the cycle fallback: it never decrements to 0 again.
const FORCED: u32 = 1 << 31;

/// `xmpvo`.
pub const XMPVO: SortInfo = SortInfo {
    name: "xmpvo",
    description: "MPVONC's face DAG plus the per-pixel boundary order across empty space \
                  (XMPVO, image-space exterior ordering): exact at image resolution when acyclic",
    params: &[],
    lattice_only: false,
    make: |_| Ok(Box::new(Xmpvo::default())),
};

#[derive(Debug, Default)]
pub struct Xmpvo {
    centroids: Vec<[f32; 3]>,
    faces: Vec<Face>,
    /// Face slot of the face in `a` (bits 0–1) and in `b` (bits 2–3).
    slots: Vec<u8>,
    diag: f32,
    /// Boundary vertices, centred, f32; boundary faces.
    bpos: Vec<[f32; 3]>,
    bfaces: Vec<BoundaryFace>,
    // Per frame.
    indeg: Vec<u32>,
    /// Bit f: an edge from this cell to its neighbour across face f.
    out: Vec<u8>,
    /// CSR of the exterior edges by their source: `xto[xoff[t]..xoff[t + 1]]`.
    xoff: Vec<u32>,
    xto: Vec<u32>,
    sources: Vec<u32>,
    stack: Vec<u32>,
}

impl Sort for Xmpvo {
    fn name(&self) -> String {
        "xmpvo".into()
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        let nt = mesh.num_tets();
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let area_eps = 1e-12 * l * l;
        let p = |v: u32| mesh.positions()[v as usize] - c;
        super::mpvonc::interior_faces(mesh, c, area_eps, &mut self.faces, &mut self.slots)?;
        // The boundary surface, with cpu-pt's f32 centred positions.
        // Six times the volume, the threshold of `Mesh::degenerate_tets`; computed for the
        // boundary tets only (the mesh's cached volumes would cost 8 bytes a tet).
        let vol_eps = 6e-14 * l * l * l;
        let mut map = vec![u32::MAX; mesh.num_vertices()];
        self.bpos.clear();
        self.bfaces.clear();
        for &bf in mesh.boundary_faces() {
            let (t, f) = (bf as usize / 4, bf as usize % 4);
            let v = mesh.face_vertices(t, f).map(|v| {
                let m = &mut map[v as usize];
                if *m == u32::MAX {
                    *m = self.bpos.len() as u32;
                    self.bpos.push(p(v).as_vec3().to_array());
                }
                *m
            });
            let vol = signed_volume6(mesh.tet_points(t).map(|q| q - c));
            let sign = if vol.abs() < vol_eps || vol == 0.0 {
                0
            } else if vol > 0.0 {
                1
            } else {
                -1
            };
            self.bfaces.push(BoundaryFace {
                v,
                tet: t as u32,
                sign,
            });
        }
        self.bpos.shrink_to_fit();
        self.bfaces.shrink_to_fit();
        self.faces.shrink_to_fit();
        self.slots.shrink_to_fit();
        self.centroids = centroids(mesh);
        self.diag = l as f32;
        self.indeg = vec![0; nt];
        self.out = vec![0; nt];
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        let nt = self.centroids.len();
        check_prepared("xmpvo", nt, mesh)?;
        let adj = &mesh.adjacency().neighbors;
        let mut stats = SortStats::default();

        // 2 first, so that a refused image size leaves nothing half done.
        let ext = exterior(camera, &self.bpos, &self.bfaces)?;
        stats.irregular_pixels = ext.irregular_pixels;
        stats.exterior_edges = ext.edges.len();
        self.xoff.clear();
        self.xoff.resize(nt + 1, 0);
        for &e in &ext.edges {
            self.xoff[(e >> 32) as usize + 1] += 1;
        }
        for t in 0..nt {
            self.xoff[t + 1] += self.xoff[t];
        }
        // The edges are sorted by source, so their targets are already in CSR order.
        self.xto.clear();
        self.xto.extend(ext.edges.iter().map(|&e| e as u32));
        drop(ext);

        // 1. Orient every interior face; in-degrees of both kinds of edge.
        self.indeg.iter_mut().for_each(|x| *x = 0);
        self.out.iter_mut().for_each(|x| *x = 0);
        let (e, w, eps) = match camera.projection {
            Projection::Ortho => (f32x3(camera.to_eye), 0.0f32, 1e-6f32),
            Projection::Persp => (f32x3(camera.eye()), 1.0, 1e-6 * self.diag),
        };
        for (face, &slot) in self.faces.iter().zip(&self.slots) {
            let s = face.n[0] * e[0] + face.n[1] * e[1] + face.n[2] * e[2] - w * face.d;
            let (from, to, bit) = if s > eps {
                (face.a, face.b, slot & 3)
            } else if s < -eps {
                (face.b, face.a, slot >> 2)
            } else {
                stats.unconstrained_faces += 1;
                continue;
            };
            self.out[from as usize] |= 1 << bit;
            self.indeg[to as usize] += 1;
            stats.edges += 1;
        }
        for &t in &self.xto {
            self.indeg[t as usize] += 1;
        }
        stats.edges += self.xto.len();

        // 3. Sources farthest first, then Kahn with a stack; cycle fallback at stalls.
        let kf = KeyFn::for_camera(camera);
        let cents = &self.centroids;
        stats.sources = seed_sources(&self.indeg, |t| kf.key(&cents[t]), &mut self.sources);
        order.clear();
        order.reserve(nt);
        self.stack.clear();
        let mut next_source = 0;
        let mut fallback: Option<Stall> = None;
        loop {
            while let Some(t) = self.stack.pop() {
                order.push(t);
                let t = t as usize;
                let mut bits = self.out[t];
                while bits != 0 {
                    let f = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let nb = adj[t][f] as usize;
                    self.indeg[nb] -= 1;
                    if self.indeg[nb] == 0 {
                        self.stack.push(nb as u32);
                    }
                }
                for &nb in &self.xto[self.xoff[t] as usize..self.xoff[t + 1] as usize] {
                    let d = &mut self.indeg[nb as usize];
                    *d -= 1;
                    if *d == 0 {
                        self.stack.push(nb);
                    }
                }
            }
            if next_source < self.sources.len() {
                self.stack.push(self.sources[next_source]);
                next_source += 1;
                continue;
            }
            if order.len() == nt {
                break;
            }
            // A stall: the remaining cells lie on cycles or downstream of them.
            let stall = fallback.get_or_insert_with(|| {
                let g = Graph {
                    adj,
                    out: &self.out,
                    xoff: &self.xoff,
                    xto: &self.xto,
                };
                let (cycles, cells) = super::count_cycles(self.indeg.len(), |v| self.indeg[v] != 0, |v, k| {
                    g.next(v, k)
                });
                stats.cycles = cycles;
                stats.cells_in_cycles = cells;
                Stall::new(&self.indeg, |t| kf.key(&cents[t]))
            });
            let t = stall.force(&mut self.indeg, FORCED, &mut stats, "xmpvo", order.len())?;
            self.stack.push(t);
        }
        Ok(stats)
    }
}

/// The frame's graph: interior edges as bits per face slot, exterior edges in CSR.
struct Graph<'a> {
    adj: &'a [[u32; 4]],
    out: &'a [u8],
    xoff: &'a [u32],
    xto: &'a [u32],
}

impl Graph<'_> {
    /// Successor number `k` of `v` (0..4 the face slots, then the exterior edges), or `None`
    /// past the last; `k` is advanced past it.
    #[inline]
    fn next(&self, v: usize, k: &mut u32) -> Option<usize> {
        while *k < 4 {
            let g = *k as usize;
            *k += 1;
            if self.out[v] & (1 << g) != 0 {
                return Some(self.adj[v][g] as usize);
            }
        }
        let i = self.xoff[v] + (*k - 4);
        if i < self.xoff[v + 1] {
            *k += 1;
            return Some(self.xto[i as usize] as usize);
        }
        None
    }
}


#[cfg(test)]
mod tests;
