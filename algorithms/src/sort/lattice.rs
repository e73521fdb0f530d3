//! `bcc-implicit` and `bcc-implicit-skip`: the visibility order of a lattice mesh read off its
//! structure, with no sort (BCC paper §4.1), and the same with empty-space skipping (§4.2).
//!
//! Works on meshes that `datasets-gen` built on a `bcc`, `cc5` or `cc6` lattice: the lattice
//! description travels in `mesh.field_data["lattice"]` ([`crate::bcc::lattice`]), so a written and
//! re-read `.vtu` works too. Any other mesh is refused in `prepare` with one line.
//!
//! # Order (orthographic)
//!
//! Work in lattice coordinates `ξ = (x − o) / h` (per axis), where the ray direction is
//! `g = f / h` (`f` the camera's forward vector); visibility is affine-invariant, so the order
//! for `g` in lattice space is the order for `f` in world space.
//!
//! **Traversal steps.** BCC: one step per primary point `q`, owning the three primary edges
//! from `q` *towards the far side*, `q → q + σ_a e_a` with `σ_a = sign g_a` (`+` for `g_a = 0`),
//! i.e. their three octahedra, 12 tets. CC: one step per cell, its 5 or 6 tets. Steps are
//! visited in three nested loops, each axis from far to near (descending coordinate where
//! `σ_a > 0`), the outermost loop on the axis of largest `|g_a|`, the innermost on the smallest.
//!
//! **Inside a step** the tets go farthest first by the key `g · c` of their centroids `c`
//! (lattice space), computed once per frame for the step's 12 (or 5, 6 per cell parity) tet
//! types: a table per view. It depends only on which of the 48 chambers of the cube's
//! symmetry group `g` lies in (the signs of `g_a` and the order of `|g_a|`) for `bcc` and
//! `cc6`: every face between two tets has a normal of the form `(1, ±1, 0)` (or an axis), so
//! the signs of `g · n` are fixed inside a chamber. The paper's "table per octant" is not
//! enough: across a face with normal `(1, 0, −1)` the order flips where `|g_x| = |g_z|`.
//! For `cc5` the central tet's faces have normals `(±1, ±1, ±1)`, so its table also depends on
//! the signs of `g · (±1, ±1, ±1)`; computing the table per frame covers every case alike.
//!
//! **Why this is a visibility order.** On the infinite lattice (which fills space, so is
//! convex) every linear extension of the face-adjacency "behind" relation is a visibility order
//! (Williams 1992), and an order restricted to a sub-mesh stays one: rays cross the parts
//! outside the mesh (the dents of the BCC boundary) in the same order. So it suffices that
//! every pair of face-adjacent tets is in order.
//! - *Inside a step:* two adjacent tets of the BCC (and cc6) lattice are mirror images in their
//!   common face, and in cc5 the corner and central tets are symmetric about the cube
//!   diagonal, so the centroid difference is parallel to the face normal `n`, and the centroid
//!   key orders the pair exactly as `sign(g · n)` does.
//! - *Between BCC steps:* the tet of edge `(q, a)` meets, across its faces with a primary
//!   vertex, tets of the octahedra of the edges `(q − e_c, c)` (normal `−(e_a + e_c)`),
//!   `(q + e_a, c)` (normal `e_a + e_c`) and `(q + e_a − e_c, c)` (normal `e_a − e_c`), written
//!   here for `σ = (+, +, +)` (the other octants are its mirror images). With `g ≥ 0` the first
//!   two are behind exactly when their step comes first in a loop that descends every axis;
//!   the third is behind iff `g_a > g_c`, and its step comes first iff the loop on `a` is
//!   outside the loop on `c`: hence the nesting by decreasing `|g_a|`. (A fixed nesting, or
//!   steps owning the `+` edges in every octant, breaks these.) Ties (`g · n = 0`) constrain
//!   nothing.
//! - *Between CC cells:* faces are axis planes, so any nesting of far-to-near loops works.
//!
//! The tests check every face constraint over many views and that `cpu-pt` images agree in
//! 8 bits with `mpvonc`'s.
//!
//! **Perspective** is refused: every pixel has its own ray direction, so the chamber (and the
//! step order) changes across the grid; a correct order must split the traversal at the eye's
//! cell and at the planes where the ray direction crosses a chamber boundary (`|g_a| = |g_b|`),
//! which is not done here.
//!
//! **Cost.** O(n) with no comparison sort (a sort of 12 keys per frame).
//!
//! # Empty-space skipping (`bcc-implicit-skip`)
//!
//! After Orchard & Möller's adjacency structure as the paper adapts it (§4.2), built by
//! [`Sort::set_transfer_function`] (so rebuilt whenever the transfer function changes):
//! - a tet is *transparent* when `τ = 0` over its whole scalar interval `[min s, max s]` of its
//!   vertices (τ is piecewise linear: checked at the interval's ends and the control points in
//!   it), widened by a margin of 2/127 of the TF's `s` span so that no table a renderer
//!   interpolates (4096-sample TF table, 128-bin pre-integration table) can give such a tet a
//!   non-zero opacity;
//! - per traversal complex (BCC: a primary point; CC: a cell) a bit mask of its visible tets
//!   (the paper's "checksum": for BCC 24 bits, the 4 tets of each of the 6 edges at the point,
//!   since which 3 edges a step owns depends on the view; 4 bytes per point, 1 per cell);
//! - the adjacency links along each axis, stored as runs: per scanline along axis `a`, the
//!   sorted coordinates of its visible complexes (the "next visible complex" links in both
//!   directions); a scanline with no visible complex is skipped at once. Three copies, one per
//!   axis, because the innermost loop's axis depends on the view.
//!
//! The traversal then visits only visible complexes and emits only their visible tets: the
//! order is the order of `bcc-implicit` with the transparent tets left out (the [`Sort`]
//! contract allows a sort that was given a transfer function to leave out tets that contribute
//! nothing), and the image is the same.

use super::{Sort, SortInfo, SortStats};
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::bcc::lattice::{bcc_axis_offset, Lattice, LatticeKind};
use crate::mesh::Mesh;
use crate::tf::TransferFunction;

/// One tet type of a traversal step.
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// BCC: the primary axis of the tet's edge; CC: unused.
    axis: usize,
    /// BCC: sub-tet 0..4 of the edge; CC: tet within the cell (0..5 or 0..6).
    sub: usize,
    /// Centroid relative to the step's point (BCC, for the edge towards `+e_axis`) or cell
    /// corner (CC), in lattice coordinates.
    c: [f64; 3],
}

/// What a skipping sort holds (built per transfer function).
#[derive(Debug, Default)]
struct Skip {
    /// Visible-tet mask per complex. BCC: bit `(dir·3 + a)·4 + u` for the edge `q → q + e_a`
    /// (`dir` 0) or `q − e_a → q` (`dir` 1), sub-tet `u`. CC: bit `j` for the cell's tet `j`.
    mask: Vec<u32>,
    /// Per axis `a`: scanline offsets (scanline = the other two coordinates, `b + nb·c` with
    /// `b < c` the other axes) into `coords`, the visible complexes' coordinates along `a`.
    runs: [(Vec<u32>, Vec<u32>); 3],
    visible_tets: usize,
}

#[derive(Debug)]
pub struct LatticeSort {
    skip: bool,
    lattice: Option<Lattice>,
    /// Step grid: BCC primary points, CC cells.
    steps: [usize; 3],
    /// Tet types of a step (BCC: 12; CC: `[even parity, odd parity]` patterns).
    entries: [Vec<Entry>; 2],
    vis: Option<Skip>,
}

impl LatticeSort {
    pub fn new(skip: bool) -> LatticeSort {
        LatticeSort {
            skip,
            lattice: None,
            steps: [0; 3],
            entries: [Vec::new(), Vec::new()],
            vis: None,
        }
    }

    fn who(&self) -> &'static str {
        if self.skip {
            "sort 'bcc-implicit-skip'"
        } else {
            "sort 'bcc-implicit'"
        }
    }

    /// Tets visible under the transfer function last given (all, before one is given).
    pub fn visible_tets(&self) -> Option<usize> {
        self.vis.as_ref().map(|v| v.visible_tets)
    }

    /// Bytes of the skipping structure (0 before a transfer function is given).
    pub fn skip_bytes(&self) -> usize {
        self.vis.as_ref().map_or(0, |v| {
            v.mask.capacity() * 4
                + v.runs
                    .iter()
                    .map(|(o, c)| 4 * (o.capacity() + c.capacity()))
                    .sum::<usize>()
        })
    }
}

/// Lattice coordinates of a world position.
fn to_lattice(l: &Lattice, p: glam::DVec3) -> [f64; 3] {
    ((p - l.origin) / l.spacing).to_array()
}

fn centroid(l: &Lattice, mesh: &Mesh, t: usize, corner: [usize; 3]) -> [f64; 3] {
    let p = mesh.tet_points(t);
    let c = to_lattice(l, 0.25 * (p[0] + p[1] + p[2] + p[3]));
    std::array::from_fn(|a| c[a] - corner[a] as f64)
}

/// The traversal for one view: the ray direction `g` in lattice space, the loop axes by
/// decreasing `|g_a|` (ties by axis, outermost first) and the far side per axis (`pos[a]`:
/// the larger coordinate is farther).
#[derive(Clone, Copy, Debug)]
struct Traversal {
    g: [f64; 3],
    axes: [usize; 3],
    pos: [bool; 3],
}

impl Traversal {
    fn new(g: [f64; 3]) -> Traversal {
        let mut axes = [0, 1, 2];
        axes.sort_by(|&a, &b| g[b].abs().total_cmp(&g[a].abs()).then(a.cmp(&b)));
        Traversal {
            g,
            axes,
            pos: g.map(|x| x >= 0.0),
        }
    }
}

/// The two axes other than `a`, in increasing order.
fn others(a: usize) -> (usize, usize) {
    match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Entries sorted farthest first by `g · c` (ties by position in the list).
fn step_table(entries: &[Entry], g: [f64; 3], shift: impl Fn(&Entry) -> [f64; 3]) -> Vec<usize> {
    let key = |e: &Entry| {
        let d = shift(e);
        (0..3).map(|a| g[a] * (e.c[a] + d[a])).sum::<f64>()
    };
    let mut idx: Vec<usize> = (0..entries.len()).collect();
    idx.sort_by(|&i, &j| {
        key(&entries[j])
            .total_cmp(&key(&entries[i]))
            .then(i.cmp(&j))
    });
    idx
}

/// `bcc-implicit`.
pub const BCC_IMPLICIT: SortInfo = SortInfo {
    name: "bcc-implicit",
    description: "lattice meshes only (bcc, cc5, cc6), ortho: back-to-front traversal of the \
                  lattice, no sort, O(n)",
    params: &[],
    lattice_only: true,
    make: |_| Ok(Box::new(LatticeSort::new(false))),
};

/// `bcc-implicit-skip`.
pub const BCC_IMPLICIT_SKIP: SortInfo = SortInfo {
    name: "bcc-implicit-skip",
    description: "bcc-implicit leaving out tets transparent under the transfer function \
                  (empty-space skipping), O(visible)",
    params: &[],
    lattice_only: true,
    make: |_| Ok(Box::new(LatticeSort::new(true))),
};

impl Sort for LatticeSort {
    fn name(&self) -> String {
        if self.skip {
            "bcc-implicit-skip"
        } else {
            "bcc-implicit"
        }
        .to_string()
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        self.lattice = None;
        self.vis = None;
        let l = Lattice::of_mesh(mesh, self.who())?;
        let n = l.n;
        match l.kind {
            LatticeKind::Bcc => {
                self.steps = n;
                let mut e = Vec::with_capacity(12);
                for axis in 0..3 {
                    for sub in 0..4 {
                        if let Some(t) = crate::bcc::lattice::bcc_tet_index(n, [0; 3], axis, sub) {
                            e.push(Entry {
                                axis,
                                sub,
                                c: centroid(&l, mesh, t, [0; 3]),
                            });
                        }
                    }
                }
                self.entries = [e, Vec::new()];
            }
            LatticeKind::Cc5 | LatticeKind::Cc6 => {
                let per = if l.kind == LatticeKind::Cc5 { 5 } else { 6 };
                self.steps = n.map(|x| x - 1);
                let [cx, cy, _] = self.steps;
                let pattern = |cell: [usize; 3]| -> Vec<Entry> {
                    let c = cell[0] + cx * (cell[1] + cy * cell[2]);
                    (0..per)
                        .map(|j| Entry {
                            axis: 0,
                            sub: j,
                            c: centroid(&l, mesh, per * c + j, cell),
                        })
                        .collect()
                };
                let even = pattern([0; 3]);
                // An odd cell, if there is one (cc5 mirrors its pattern there).
                let odd = (0..3)
                    .find(|&a| self.steps[a] >= 2)
                    .map(|a| {
                        let mut cell = [0; 3];
                        cell[a] = 1;
                        pattern(cell)
                    })
                    .unwrap_or_else(|| even.clone());
                self.entries = [even, odd];
            }
        }
        self.lattice = Some(l);
        Ok(())
    }

    fn set_transfer_function(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        if !self.skip {
            return Ok(());
        }
        let l = self
            .lattice
            .ok_or_else(|| Error::Internal(format!("{}: TF before prepare", self.who())))?;
        let visible = transparency(mesh, tf);
        self.vis = Some(build_skip(&l, self.steps, &visible));
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        let l = self
            .lattice
            .ok_or_else(|| Error::Internal(format!("{}: sort before prepare", self.who())))?;
        super::check_prepared(&self.name(), l.num_tets(), mesh)?;
        if camera.projection != Projection::Ortho {
            return Err(Error::Input(format!(
                "{}: orthographic views only (in perspective the view direction, and with it \
                 the traversal order, changes across the grid); use mpvonc or centroid",
                self.who()
            )));
        }
        let f = camera.forward;
        // The ray direction in lattice space, f / h.
        let g = (f / l.spacing).to_array();
        let tr = Traversal::new(g);
        order.clear();
        order.reserve(l.num_tets());
        let vis = if self.skip { self.vis.as_ref() } else { None };
        match l.kind {
            LatticeKind::Bcc => self.traverse_bcc(&l, tr, vis, order),
            _ => self.traverse_cc(&l, tr, vis, order),
        }
        if vis.is_none() && order.len() != l.num_tets() {
            return Err(Error::Internal(format!(
                "{}: emitted {} of {} tets",
                self.who(),
                order.len(),
                l.num_tets()
            )));
        }
        Ok(SortStats::default())
    }
}

/// One loop of the traversal: coordinates along an axis, far to near.
fn far_to_near(len: usize, ascending: bool) -> impl Iterator<Item = usize> {
    let r = 0..len;
    let (a, b) = if ascending {
        (Some(r), None)
    } else {
        (None, Some(r.rev()))
    };
    a.into_iter().flatten().chain(b.into_iter().flatten())
}

/// Calls `visit(point)` for every step point in traversal order: loops nested as `tr.axes`
/// (outermost first), each axis far to near (`tr.pos[a]`: far is the larger coordinate). With
/// `runs`, only the points listed there for the innermost axis.
fn traverse(
    steps: [usize; 3],
    tr: Traversal,
    runs: Option<&[(Vec<u32>, Vec<u32>); 3]>,
    mut visit: impl FnMut([usize; 3]),
) {
    let Traversal { axes, pos, .. } = tr;
    let [a0, a1, a2] = axes;
    if steps.contains(&0) {
        return;
    }
    for i0 in far_to_near(steps[a0], !pos[a0]) {
        for i1 in far_to_near(steps[a1], !pos[a1]) {
            let mut q = [0usize; 3];
            q[a0] = i0;
            q[a1] = i1;
            match runs {
                None => {
                    for i2 in far_to_near(steps[a2], !pos[a2]) {
                        q[a2] = i2;
                        visit(q);
                    }
                }
                Some(runs) => {
                    let (offsets, coords) = &runs[a2];
                    let line = scanline(steps, a2, q);
                    let run = &coords[offsets[line] as usize..offsets[line + 1] as usize];
                    let mut each = |&i2: &u32| {
                        q[a2] = i2 as usize;
                        visit(q);
                    };
                    if pos[a2] {
                        run.iter().rev().for_each(&mut each);
                    } else {
                        run.iter().for_each(&mut each);
                    }
                }
            }
        }
    }
}

/// Index of the scanline along `axis` through `q`.
fn scanline(steps: [usize; 3], axis: usize, q: [usize; 3]) -> usize {
    let (b, c) = others(axis);
    q[b] + steps[b] * q[c]
}

impl LatticeSort {
    fn traverse_bcc(&self, l: &Lattice, tr: Traversal, vis: Option<&Skip>, order: &mut Vec<u32>) {
        let Traversal { g, pos, .. } = tr;
        let n = l.n;
        let entries = &self.entries[0];
        // The step owns the edge towards the far side: `q → q + e_a` (σ_a = +) or
        // `q − e_a → q` (σ_a = −), whose centroids are the reference ones shifted by −e_a.
        let table = step_table(entries, g, |e| {
            let mut d = [0.0; 3];
            if !pos[e.axis] {
                d[e.axis] = -1.0;
            }
            d
        });
        // Per table entry: axis, tet offset, strides of the edge grid, mask bit.
        let plan: Vec<(usize, usize, [usize; 3], u32)> = table
            .iter()
            .map(|&i| {
                let e = entries[i];
                let mut m = n;
                m[e.axis] -= 1;
                let dir = if pos[e.axis] { 0 } else { 1 };
                (
                    e.axis,
                    bcc_axis_offset(n, e.axis) + e.sub,
                    [4, 4 * m[0], 4 * m[0] * m[1]],
                    1u32 << ((dir * 3 + e.axis) * 4 + e.sub),
                )
            })
            .collect();
        let masks = vis.map(|v| v.mask.as_slice());
        traverse(n, tr, vis.map(|v| &v.runs), |q| {
            let bits = masks.map_or(u32::MAX, |m| m[q[0] + n[0] * (q[1] + n[1] * q[2])]);
            for &(a, off, stride, bit) in &plan {
                if bits & bit == 0 {
                    continue;
                }
                let mut lo = q;
                if pos[a] {
                    if q[a] + 1 >= n[a] {
                        continue;
                    }
                } else {
                    if q[a] == 0 {
                        continue;
                    }
                    lo[a] -= 1;
                }
                let t = off + stride[0] * lo[0] + stride[1] * lo[1] + stride[2] * lo[2];
                order.push(t as u32);
            }
        });
    }

    fn traverse_cc(&self, l: &Lattice, tr: Traversal, vis: Option<&Skip>, order: &mut Vec<u32>) {
        let g = tr.g;
        let per = if l.kind == LatticeKind::Cc5 { 5 } else { 6 };
        let tables = [
            step_table(&self.entries[0], g, |_| [0.0; 3]),
            step_table(&self.entries[1], g, |_| [0.0; 3]),
        ];
        let subs: [Vec<usize>; 2] =
            std::array::from_fn(|p| tables[p].iter().map(|&i| self.entries[p][i].sub).collect());
        let c = self.steps;
        let masks = vis.map(|v| v.mask.as_slice());
        traverse(c, tr, vis.map(|v| &v.runs), |q| {
            let cell = q[0] + c[0] * (q[1] + c[1] * q[2]);
            let bits = masks.map_or(u32::MAX, |m| m[cell]);
            // cc6 uses one pattern; cc5 alternates with the parity of i + j + k.
            let parity = if per == 5 {
                (q[0] + q[1] + q[2]) & 1
            } else {
                0
            };
            for &j in &subs[parity] {
                if bits & (1 << j) != 0 {
                    order.push((per * cell + j) as u32);
                }
            }
        });
    }
}

/// Per tet: whether it can be non-transparent under `tf` (see the module docs for the margin).
pub(crate) fn transparency(mesh: &Mesh, tf: &TransferFunction) -> Vec<bool> {
    use rayon::prelude::*;
    let map = tf.scalar_map(mesh.scalar_range());
    let (lo, hi) = tf.table_domain();
    let margin = 2.0 * (hi - lo) / 127.0;
    let s: Vec<f64> = mesh.scalars().iter().map(|&v| map.s(v)).collect();
    mesh.tets()
        .par_iter()
        .map(|t| {
            let v = t.map(|i| s[i as usize]);
            let a = v.iter().copied().fold(f64::INFINITY, f64::min) - margin;
            let b = v.iter().copied().fold(f64::NEG_INFINITY, f64::max) + margin;
            // τ is piecewise linear: its maximum over [a, b] is at an end or a control point.
            tf.eval(a).1 > 0.0
                || tf.eval(b).1 > 0.0
                || tf.points_between(a, b).iter().any(|p| p.tau > 0.0)
        })
        .collect()
}

/// The skipping structure for per-tet visibility `visible`.
fn build_skip(l: &Lattice, steps: [usize; 3], visible: &[bool]) -> Skip {
    let n = l.n;
    let nsteps = steps[0] * steps[1] * steps[2];
    let mut mask = vec![0u32; nsteps];
    match l.kind {
        LatticeKind::Bcc => {
            for a in 0..3 {
                let mut m = n;
                m[a] -= 1;
                for k in 0..m[2] {
                    for j in 0..m[1] {
                        for i in 0..m[0] {
                            let lo = [i, j, k];
                            let mut hi = lo;
                            hi[a] += 1;
                            let t0 = crate::bcc::lattice::bcc_tet_index(n, lo, a, 0).expect("edge");
                            for u in 0..4 {
                                if visible[t0 + u] {
                                    let id = |p: [usize; 3]| p[0] + n[0] * (p[1] + n[1] * p[2]);
                                    mask[id(lo)] |= 1 << (a * 4 + u);
                                    mask[id(hi)] |= 1 << ((3 + a) * 4 + u);
                                }
                            }
                        }
                    }
                }
            }
        }
        _ => {
            let per = if l.kind == LatticeKind::Cc5 { 5 } else { 6 };
            for (c, m) in mask.iter_mut().enumerate() {
                for j in 0..per {
                    if visible[per * c + j] {
                        *m |= 1 << j;
                    }
                }
            }
        }
    }
    let runs = std::array::from_fn(|a| {
        let (b, c) = others(a);
        let mut offsets = Vec::with_capacity(steps[b] * steps[c] + 1);
        let mut coords = Vec::new();
        offsets.push(0u32);
        for ic in 0..steps[c] {
            for ib in 0..steps[b] {
                for ia in 0..steps[a] {
                    let mut q = [0; 3];
                    q[a] = ia;
                    q[b] = ib;
                    q[c] = ic;
                    if mask[q[0] + steps[0] * (q[1] + steps[1] * q[2])] != 0 {
                        coords.push(ia as u32);
                    }
                }
                offsets.push(coords.len() as u32);
            }
        }
        (offsets, coords)
    });
    Skip {
        mask,
        runs,
        visible_tets: visible.iter().filter(|&&v| v).count(),
    }
}
