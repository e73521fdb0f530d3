//! Visibility sorts for projected tetrahedra, kept apart from rendering.
//!
//! A [`Sort`] is prepared once per mesh and then, per camera, writes a back-to-front order:
//! every tet index exactly once, farthest first. The sorts, by name ([`SORTS`], [`make`]):
//!
//! | name | order | per frame |
//! | --- | --- | --- |
//! | `centroid` | centroid depth, `sort_unstable_by`, one thread | O(n log n) |
//! | `centroid-par` | the same order, rayon's `par_sort_unstable_by` | O(n log n) / threads |
//! | `centroid-radix` | the same order, stable LSD radix sort on the keys' bits | O(n) |
//! | `bucket[:N]` | PTINT's N depth slabs (default 20), index order inside a slab | O(n) |
//! | `mpvonc` | Williams' MPVONC: topological sort of the face-adjacency DAG | O(n) |
//! | `xmpvo` | MPVONC's DAG plus the per-pixel boundary order across empty space: exact at image resolution when acyclic ([`xmpvo`]) | O(n + boundary fragments) |
//! | `bcc-implicit` | lattice meshes only (`bcc`, `cc5`, `cc6`), ortho: back-to-front traversal of the lattice, no sort ([`lattice`]) | O(n) |
//! | `bcc-implicit-skip` | the same, leaving out tets transparent under the transfer function (empty-space skipping) | O(visible) |
//!
//! **Centroid keys.** Centroids are computed once, in f64 in the frame centred on the bounding-box
//! centre (CONVENTIONS §1), and stored as f32 (12 bytes per tet). Per frame the key is computed
//! in f32 from the stored centroid: orthographic — the signed distance along the view direction,
//! `c · forward`; perspective — the squared distance from the eye, `|c − eye|²`. A larger key is
//! farther. The three centroid sorts order by key descending under IEEE total order (so `+0.0`,
//! the larger, comes before `−0.0`) and break ties by ascending tet index: they give the same
//! order on the same keys.

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::mesh::{Mesh, BOUNDARY};
use crate::plugin::{did_you_mean, ParamInfo};
use crate::tf::TransferFunction;

pub mod gpu;

pub use bucket::BucketSort;
pub use centroid::CentroidSort;
pub use lattice::LatticeSort;
pub use mpvonc::Mpvonc;
pub use radix::RadixSort;
pub use xmpvo::Xmpvo;

/// A sort's registry entry: declared in the sort's own file, listed once in [`REGISTRY`].
pub struct SortInfo {
    pub name: &'static str,
    pub description: &'static str,
    /// The parameter after `:` in the name (`bucket:16`), if the sort takes one.
    pub params: &'static [ParamInfo],
    /// Only for meshes built on a lattice (`datasets-gen` `bcc`, `cc5`, `cc6`); an
    /// experiment's `sorts = ["*"]` leaves these out.
    pub lattice_only: bool,
    /// Makes the sort; the argument is the text after `:` in the name, if any.
    pub make: fn(Option<&str>) -> Result<Box<dyn Sort>>,
}

/// Declares each sort module and lists its entries, so that the registry is the one place
/// sorts are known by.
macro_rules! registry {
    ($($(#[$m:meta])* $vis:vis $module:ident => [$($entry:ident),+],)+) => {
        $($(#[$m])* $vis mod $module;)+
        /// Every sort, in `tetbench list` order.
        pub static REGISTRY: &[&SortInfo] = &[$($(&$module::$entry,)+)+];
        /// The names of the sorts, in registry order (for renderer entries, which list the
        /// sorts they take).
        pub const CPU_SORTS: &[&str] = &[$($($module::$entry.name,)+)+];
    };
}

// The registry: adding a sort is one new file in this directory (with its `SortInfo`) and one
// line here.
registry! {
    centroid => [CENTROID, CENTROID_PAR],
    radix => [CENTROID_RADIX],
    bucket => [BUCKET],
    mpvonc => [MPVONC],
    xmpvo => [XMPVO],
    pub lattice => [BCC_IMPLICIT, BCC_IMPLICIT_SKIP],
}

/// What a sort reports about one frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SortStats {
    /// Non-trivial strongly connected components (cycles) of the visibility graph (MPVONC).
    pub cycles: usize,
    /// Cells in those components.
    pub cells_in_cycles: usize,
    /// Cells emitted by the cycle fallback before all their predecessors (MPVONC).
    pub forced: usize,
    /// Cells with no predecessor, where the topological sort starts (MPVONC).
    pub sources: usize,
    /// Precedence constraints (directed edges) used (MPVONC).
    pub edges: usize,
    /// Interior faces that gave no constraint: zero area, or the eye in (or, in ortho, the view
    /// direction parallel to) their plane (MPVONC).
    pub unconstrained_faces: usize,
    /// Distinct constraints across empty space from the per-pixel boundary order (XMPVO).
    pub exterior_edges: usize,
    /// Pixels whose boundary crossings do not alternate entry, exit (open or non-manifold
    /// boundary, overlapping cells): all their consecutive pairs are kept (XMPVO).
    pub irregular_pixels: usize,
}

/// A visibility sort.
pub trait Sort: Send {
    fn name(&self) -> String;
    /// Per-mesh precomputation (centroids in the centred frame, adjacency, …), done once.
    fn prepare(&mut self, mesh: &Mesh) -> Result<()>;
    /// Hands the sort the transfer function the renderer draws with; called after `prepare`
    /// and again whenever the transfer function changes. A skipping sort
    /// (`bcc-implicit-skip`) rebuilds its visibility structure here; the others ignore it.
    fn set_transfer_function(&mut self, _mesh: &Mesh, _tf: &TransferFunction) -> Result<()> {
        Ok(())
    }
    /// Back-to-front visibility order for this camera: `order` receives every tet index exactly
    /// once, farthest first — except that a skipping sort, once given a transfer function,
    /// leaves out the tets that are transparent under it (τ = 0 over the tet's whole scalar
    /// interval: they add nothing to any pixel). `prepare` must have been called with this mesh.
    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats>;
}

/// The sorts known by name (all CPU sorts; `bucket` also takes a slab count, `bucket:N`).
pub const SORTS: &[&str] = CPU_SORTS;

/// `own` followed by every CPU sort: the sort list of a renderer that has sorts of its own
/// (e.g. `hapt`'s GPU sorts) and takes every CPU sort too, kept in step with [`CPU_SORTS`].
pub const fn with_sorts<const A: usize, const N: usize>(
    own: [&'static str; A],
) -> [&'static str; N] {
    assert!(N == A + CPU_SORTS.len(), "N must be A + CPU_SORTS.len()");
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < A { own[i] } else { CPU_SORTS[i - A] };
        i += 1;
    }
    out
}

/// Default slab count of `bucket` (PTINT: "around 20").
pub const DEFAULT_SLABS: usize = 20;
/// Largest slab count `bucket:N` accepts.
pub const MAX_SLABS: usize = 4096;

/// The registry entry of a sort name (`bucket:16` is `bucket`'s); an unknown name is one line
/// with the known ones and the closest.
pub fn info(name: &str) -> Result<&'static SortInfo> {
    let base = name.split(':').next().unwrap_or(name);
    REGISTRY
        .iter()
        .copied()
        .find(|s| s.name == base)
        .ok_or_else(|| {
            Error::Input(format!(
                "unknown sort '{name}' (known: {}; bucket:N for N slabs){}",
                SORTS.join(", "),
                did_you_mean(base, SORTS)
            ))
        })
}

/// Makes a sort by name: one of [`SORTS`], or `bucket:N` with N slabs in 1..=4096.
pub fn make(name: &str) -> Result<Box<dyn Sort>> {
    let s = info(name)?;
    let arg = name.split_once(':').map(|(_, a)| a);
    if arg.is_some() && s.params.is_empty() {
        return Err(Error::Input(format!(
            "sort '{name}': '{}' takes no parameter after ':'",
            s.name
        )));
    }
    (s.make)(arg)
}

/// Tet centroids in the centred frame, f32 (12 bytes per tet).
pub(crate) fn centroids(mesh: &Mesh) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    let c = mesh.bbox().center();
    (0..mesh.num_tets())
        .into_par_iter()
        .map(|t| {
            let [a, b, cc, d] = mesh.tet_points(t);
            let m = 0.25 * (a + b + cc + d) - c;
            [m.x as f32, m.y as f32, m.z as f32]
        })
        .collect()
}

/// How a centroid becomes a depth key (larger = farther), in f32.
#[derive(Clone, Copy, Debug)]
pub(crate) enum KeyFn {
    /// `c · forward`.
    Axis([f32; 3]),
    /// `|c − eye|²`.
    EyeDist2([f32; 3]),
}

impl KeyFn {
    /// The key of the centroid sorts: axis depth in ortho, squared eye distance in persp.
    pub(crate) fn for_camera(camera: &Camera) -> KeyFn {
        match camera.projection {
            Projection::Ortho => KeyFn::Axis(f32x3(camera.forward)),
            Projection::Persp => KeyFn::EyeDist2(f32x3(camera.eye())),
        }
    }
    #[inline]
    pub(crate) fn key(&self, c: &[f32; 3]) -> f32 {
        match *self {
            KeyFn::Axis(f) => c[0] * f[0] + c[1] * f[1] + c[2] * f[2],
            KeyFn::EyeDist2(e) => {
                let (x, y, z) = (c[0] - e[0], c[1] - e[1], c[2] - e[2]);
                x * x + y * y + z * z
            }
        }
    }
}

pub(crate) fn f32x3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Maps an f32 key to a u32 whose ascending order is the key's *descending* IEEE total order
/// (`f32::total_cmp`): `+0.0` before `−0.0`, larger before smaller.
#[inline]
pub(crate) fn desc_bits(k: f32) -> u32 {
    let u = k.to_bits();
    let asc = if u & 0x8000_0000 != 0 {
        !u
    } else {
        u | 0x8000_0000
    };
    !asc
}

/// Sorts `(tet, key)` pairs farthest first, ties by index, via packed u64 keys; returns tets.
pub(crate) fn sort_desc_by_key(items: impl Iterator<Item = (u32, f32)>, out: &mut Vec<u32>) {
    let mut v: Vec<u64> = items
        .map(|(t, k)| ((desc_bits(k) as u64) << 32) | t as u64)
        .collect();
    v.sort_unstable();
    out.extend(v.iter().map(|&x| x as u32));
}

/// The sources of a visibility graph (the cells whose in-degree `indeg` is 0) into `sources`,
/// farthest first by `key` (the [`KeyFn`] of a cell's centroid): the order in which the Kahn
/// sorts (MPVONC, XMPVO) start each new run. Returns their number.
pub(crate) fn seed_sources<D: Copy + Into<u32>>(
    indeg: &[D],
    key: impl Fn(usize) -> f32,
    sources: &mut Vec<u32>,
) -> usize {
    sources.clear();
    sort_desc_by_key(
        indeg
            .iter()
            .enumerate()
            .filter(|(_, &d)| d.into() == 0)
            .map(|(t, _)| (t as u32, key(t))),
        sources,
    );
    sources.len()
}

/// Checks that a sort was prepared for a mesh of this size.
pub(crate) fn check_prepared(name: &str, prepared: usize, mesh: &Mesh) -> Result<()> {
    if prepared != mesh.num_tets() {
        return Err(Error::Internal(format!(
            "sort '{name}' was prepared for {prepared} tets, asked to sort {}",
            mesh.num_tets()
        )));
    }
    Ok(())
}

/// Interior faces whose constraint `order` breaks: the tet on the far side of a face from the
/// eye must come first. Faces with the eye within `tol`·L of their plane (ortho: |cos| < tol)
/// are skipped (a sort's test: 0 on a convex mesh means a visibility order). Geometry in f64, normals oriented away from the tet's opposite vertex.
pub fn face_violations(mesh: &Mesh, cam: &Camera, order: &[u32], tol: f64) -> usize {
    let mut pos = vec![0usize; order.len()];
    for (i, &t) in order.iter().enumerate() {
        pos[t as usize] = i;
    }
    let c = mesh.bbox().center();
    let l = mesh.diagonal();
    let mut bad = 0;
    for t in 0..mesh.num_tets() {
        for f in 0..4 {
            let nb = mesh.neighbor(t, f);
            if nb == BOUNDARY || (nb as usize) < t {
                continue;
            }
            let [v0, v1, v2] = mesh
                .face_vertices(t, f)
                .map(|v| mesh.positions()[v as usize] - c);
            let opp = mesh.positions()[mesh.tets()[t][f] as usize] - c;
            let mut n = (v1 - v0).cross(v2 - v0).normalize();
            if n.dot(opp - v0) > 0.0 {
                n = -n;
            }
            let s = match cam.projection {
                Projection::Ortho => n.dot(cam.to_eye),
                Projection::Persp => n.dot(cam.eye() - v0) / l,
            };
            let (far, near) = if s > tol {
                (t, nb as usize)
            } else if s < -tol {
                (nb as usize, t)
            } else {
                continue;
            };
            if pos[far] > pos[near] {
                bad += 1;
            }
        }
    }
    bad
}

#[cfg(test)]
mod tests;

/// Where emitting a visibility graph in topological order stalls (the cells left lie on
/// cycles or behind them), MPVONC's and XMPVO's rule: the cells left, farthest first by the
/// sort key, are forced one at a time, each time the first one still waiting. `indeg` is the
/// sort's in-degree per cell, with the `forced` bit set on cells already forced.
pub(crate) struct Stall {
    left: Vec<u32>,
    cursor: usize,
}

impl Stall {
    /// At the first stall: the cells left (non-zero in-degree) with their keys.
    pub(crate) fn new<D: Copy + Default + PartialEq>(
        indeg: &[D],
        key: impl Fn(usize) -> f32,
    ) -> Stall {
        let mut v = Vec::new();
        sort_desc_by_key(
            indeg
                .iter()
                .enumerate()
                .filter(|(_, &d)| d != D::default())
                .map(|(t, _)| (t as u32, key(t))),
            &mut v,
        );
        Stall { left: v, cursor: 0 }
    }

    /// Forces the farthest cell still waiting (neither emitted nor forced): marks it, counts it
    /// in `stats.forced` and returns it. An error naming `sort` when none is left (a bug: the
    /// emission had stalled with every cell out).
    pub(crate) fn force<D>(
        &mut self,
        indeg: &mut [D],
        forced: D,
        stats: &mut SortStats,
        sort: &str,
        emitted: usize,
    ) -> Result<u32>
    where
        D: Copy + Default + PartialOrd + std::ops::BitOrAssign,
    {
        while let Some(&t) = self.left.get(self.cursor) {
            let d = &mut indeg[t as usize];
            if *d != D::default() && *d < forced {
                *d |= forced;
                stats.forced += 1;
                return Ok(t);
            }
            self.cursor += 1;
        }
        Err(Error::Internal(format!(
            "{sort} emitted {emitted} of {} tets",
            indeg.len()
        )))
    }
}

/// Strongly connected components of two or more cells in a visibility graph of `n` cells,
/// searched from the cells `is_root` accepts (those with a non-zero in-degree); returns
/// (components, cells in them). Iterative Tarjan. `next(v, k)` gives v's successor number `k`
/// and advances `k`, or `None` when v has no more (MPVONC's and XMPVO's graphs share this).
pub(crate) fn count_cycles(
    n: usize,
    is_root: impl Fn(usize) -> bool,
    mut next: impl FnMut(usize, &mut u32) -> Option<usize>,
) -> (usize, usize) {
    const NONE: u32 = u32::MAX;
    let mut index = vec![NONE; n];
    let mut low = vec![0u32; n];
    let mut on_stack = vec![false; n];
    let mut stack: Vec<u32> = Vec::new();
    // (cell, next successor number)
    let mut call: Vec<(u32, u32)> = Vec::new();
    let mut counter = 0u32;
    let (mut comps, mut cells) = (0, 0);
    for root in 0..n {
        if !is_root(root) || index[root] != NONE {
            continue;
        }
        call.push((root as u32, 0));
        index[root] = counter;
        low[root] = counter;
        counter += 1;
        stack.push(root as u32);
        on_stack[root] = true;
        while let Some(&(v32, k0)) = call.last() {
            let v = v32 as usize;
            let mut k = k0;
            let succ = next(v, &mut k);
            if let Some(top) = call.last_mut() {
                top.1 = k;
            }
            match succ {
                Some(w) if index[w] == NONE => {
                    index[w] = counter;
                    low[w] = counter;
                    counter += 1;
                    stack.push(w as u32);
                    on_stack[w] = true;
                    call.push((w as u32, 0));
                }
                Some(w) => {
                    if on_stack[w] {
                        low[v] = low[v].min(index[w]);
                    }
                }
                None => {
                    call.pop();
                    if let Some(&(u, _)) = call.last() {
                        low[u as usize] = low[u as usize].min(low[v]);
                    }
                    if low[v] == index[v] {
                        let mut size = 0;
                        loop {
                            let w = stack.pop().expect("tarjan stack") as usize;
                            on_stack[w] = false;
                            size += 1;
                            if w == v {
                                break;
                            }
                        }
                        if size >= 2 {
                            comps += 1;
                            cells += size;
                        }
                    }
                }
            }
        }
    }
    (comps, cells)
}
