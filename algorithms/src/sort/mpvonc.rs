//! `mpvonc`: Williams' "Visibility ordering meshed polyhedra" (ACM TOG 11(2), 1992), MPVO with
//! the heuristic of its non-convex variant MPVONC, for orthographic and perspective cameras.
//!
//! **Setup** ([`Sort::prepare`]). The face adjacency of the mesh ([`Mesh::adjacency`]) and, for
//! every interior face once, its plane in the centred frame: a unit normal pointing from tet `a`
//! into tet `b` (oriented away from `a`'s opposite vertex, or towards `b`'s when `a` is flat, so
//! inverted tets are handled) and the offset `d = n · (face centroid)`, stored in f32 with the
//! two tets (24 bytes per interior face, about 48 per tet). A face of area below 1e-12·L² gets
//! a zero normal and never constrains anything. Also the f32 centroids (for the source order and
//! the cycle fallback).
//!
//! **Per frame.**
//! 1. *Orient the DAG.* For each interior face, `s = n · eye − d` (persp) or `s = n · to_eye`
//!    (ortho, the eye at infinity). `s > ε`: the eye is on `b`'s side, rays cross `b` then `a`,
//!    so `a` (farther) must precede `b`: edge `a → b`. `s < −ε`: edge `b → a`. `|s| ≤ ε` (eye in
//!    the face's plane, or in ortho the view direction parallel to it, or a zero-area face):
//!    no edge. ε = 1e-6·L in persp, 1e-6 in ortho (the f32 rounding of `s` is ~1e-7·L).
//! 2. *Sources.* Cells with no incoming edge. Every source of a non-degenerate tet owns a
//!    back-facing boundary face (one whose plane the eye is behind): a tet always has a face it
//!    is seen through from behind, and if that face were interior the neighbour would precede
//!    it. On a convex mesh these are the cells on the far side of the hull.
//! 3. *Topological sort* (Kahn, deterministic): the sources are sorted farthest first by their
//!    centroid key (the key of `centroid`: axis depth in ortho, squared eye distance in persp;
//!    ties by index). One source at a time is pushed on a LIFO stack and the stack is run dry —
//!    pop, emit, decrement the in-degree of its successors (faces in 0..4 order), push those that
//!    reach 0 — before the next source is taken. This is Williams' depth-first traversal from
//!    the sources, and his MPVONC heuristic for non-convex meshes: instead of visiting the
//!    sources in arbitrary order, visit them in depth order, so that a part of the mesh that
//!    lies behind a cavity or a concavity (and is connected to its occluder by no chain of
//!    faces) is released, and emitted as far as its own constraints allow, before the sources
//!    of the nearer part that hides it across empty space. This costs O(s log s) for the s
//!    sources (O(n^(2/3)) on a compact mesh) and O(n) for the rest.
//!
//! **What that guarantees.** On a convex mesh with an acyclic graph the order is an exact
//! visibility order (Williams: every topological order of the adjacency DAG of a convex mesh
//! is). On a non-convex mesh it honours every face constraint, but an occlusion between two
//! cells across empty space is honoured only when the heuristic's depth order of sources
//! happens to release the hidden part first: MPVONC is approximate there, and wrong e.g. when
//! an occluder's sources lie deeper than the sources of what it hides (long slanted parts,
//! interleaved concavities). No convexification and no XMPVO sweep is done.
//!
//! **Cycles.** When the stack is empty, the sources are used up and cells remain, each remaining
//! cell lies on a cycle or downstream of one. On that first stall the strongly connected
//! components of the remaining graph are found (Tarjan): [`SortStats::cycles`] counts the
//! components with two or more cells, [`SortStats::cells_in_cycles`] their cells. Fallback: the
//! remaining cells are sorted farthest first by centroid key; at each stall the farthest cell not
//! yet emitted is emitted regardless of its unfinished predecessors (counted in
//! [`SortStats::forced`]) and the topological sort goes on from it. Every cell is still emitted
//! exactly once.

use super::{
    centroids, check_prepared, f32x3, seed_sources, KeyFn, Sort, SortInfo, SortStats, Stall,
};
use glam::DVec3;
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::mesh::{Mesh, BOUNDARY};

/// The plane of one interior face between tets `a` and `b`; `n` points from `a` into `b`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Face {
    pub(super) n: [f32; 3],
    pub(super) d: f32,
    pub(super) a: u32,
    pub(super) b: u32,
}

/// In-degree mark of a cell emitted by the cycle fallback: it never decrements to 0 again.
const FORCED: u8 = 0x80;

#[derive(Debug, Default)]
pub struct Mpvonc {
    centroids: Vec<[f32; 3]>,
    faces: Vec<Face>,
    /// Face slot of the face in `a` (bits 0–1) and in `b` (bits 2–3).
    slots: Vec<u8>,
    /// L, the bounding-box diagonal.
    diag: f32,
    indeg: Vec<u8>,
    /// Bit f: an edge from this cell to its neighbour across face f.
    out: Vec<u8>,
    sources: Vec<u32>,
    stack: Vec<u32>,
}

/// `mpvonc`.
pub const MPVONC: SortInfo = SortInfo {
    name: "mpvonc",
    description: "Williams' MPVONC: topological sort of the face-adjacency visibility graph, O(n)",
    params: &[],
    lattice_only: false,
    make: |_| Ok(Box::new(Mpvonc::default())),
};

/// The oriented plane of every interior face (once per pair, from the lower-numbered tet) and
/// its slots in both tets (`f | fb << 2`): MPVONC's visibility graph, which XMPVO extends.
/// `c` is the centre the planes are taken about; faces with an area below `area_eps` get a zero
/// normal (never oriented).
pub(super) fn interior_faces(
    mesh: &Mesh,
    c: DVec3,
    area_eps: f64,
    faces: &mut Vec<Face>,
    slots: &mut Vec<u8>,
) -> Result<()> {
    let nt = mesh.num_tets();
    let adj = &mesh.adjacency().neighbors;
    let p = |v: u32| mesh.positions()[v as usize] - c;
    faces.clear();
    slots.clear();
    for t in 0..nt {
        for f in 0..4 {
            let nb = adj[t][f];
            if nb == BOUNDARY || (nb as usize) <= t {
                continue;
            }
            let fv = mesh.face_vertices(t, f);
            let mut key = fv;
            key.sort_unstable();
            // The slot of this face in the neighbour: same vertices, glued back to t.
            let fb = (0..4)
                .find(|&g| {
                    let mut k = mesh.face_vertices(nb as usize, g);
                    k.sort_unstable();
                    adj[nb as usize][g] == t as u32 && k == key
                })
                .ok_or_else(|| {
                    Error::Internal(format!("adjacency of tets {t} and {nb} is not symmetric"))
                })?;
            let [v0, v1, v2] = fv.map(p);
            let mut n = (v1 - v0).cross(v2 - v0);
            let len = n.length();
            let (n32, d32) = if len <= area_eps {
                ([0.0; 3], 0.0)
            } else {
                n /= len;
                let opp_a = p(mesh.tets()[t][f]);
                let opp_b = p(mesh.tets()[nb as usize][fb]);
                let sa = n.dot(opp_a - v0);
                let sb = n.dot(opp_b - v0);
                // Point away from a's opposite vertex, or towards b's if a is flatter.
                if (sa.abs() >= sb.abs() && sa > 0.0) || (sa.abs() < sb.abs() && sb < 0.0) {
                    n = -n;
                }
                let m = (v0 + v1 + v2) / 3.0;
                (f32x3(n), n.dot(m) as f32)
            };
            faces.push(Face {
                n: n32,
                d: d32,
                a: t as u32,
                b: nb,
            });
            slots.push(f as u8 | ((fb as u8) << 2));
        }
    }
    Ok(())
}

impl Sort for Mpvonc {
    fn name(&self) -> String {
        "mpvonc".into()
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        let nt = mesh.num_tets();
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let area_eps = 1e-12 * l * l;
        interior_faces(mesh, c, area_eps, &mut self.faces, &mut self.slots)?;
        self.centroids = centroids(mesh);
        self.diag = l as f32;
        self.indeg = vec![0; nt];
        self.out = vec![0; nt];
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        let nt = self.centroids.len();
        check_prepared("mpvonc", nt, mesh)?;
        let adj = &mesh.adjacency().neighbors;
        let mut stats = SortStats::default();

        // 1. Orient every interior face.
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

        // 2. Sources, farthest first.
        let kf = KeyFn::for_camera(camera);
        let cents = &self.centroids;
        stats.sources = seed_sources(&self.indeg, |t| kf.key(&cents[t]), &mut self.sources);

        // 3. Kahn with a stack, one source at a time; cycle fallback at stalls.
        order.clear();
        order.reserve(nt);
        self.stack.clear();
        let mut next_source = 0;
        let mut fallback: Option<Stall> = None;
        loop {
            while let Some(t) = self.stack.pop() {
                order.push(t);
                let mut bits = self.out[t as usize];
                while bits != 0 {
                    let f = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let nb = adj[t as usize][f] as usize;
                    self.indeg[nb] -= 1;
                    if self.indeg[nb] == 0 {
                        self.stack.push(nb as u32);
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
                let (cycles, cells) = {
                    let out = &self.out;
                    super::count_cycles(self.indeg.len(), |v| self.indeg[v] != 0, |v, f| {
                        // The next face slot of v with an outgoing edge.
                        while *f < 4 {
                            let g = *f as usize;
                            *f += 1;
                            if out[v] & (1 << g) != 0 {
                                return Some(adj[v][g] as usize);
                            }
                        }
                        None
                    })
                };
                stats.cycles = cycles;
                stats.cells_in_cycles = cells;
                Stall::new(&self.indeg, |t| kf.key(&cents[t]))
            });
            let t = stall.force(&mut self.indeg, FORCED, &mut stats, "mpvonc", order.len())?;
            self.stack.push(t);
        }
        Ok(stats)
    }
}

