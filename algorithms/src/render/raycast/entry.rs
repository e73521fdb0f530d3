//! The projected walk's first entries from a per-frame grid over the image: every boundary
//! face a ray of the frame can enter through (the BVH's [`Front`]) is binned by its projected
//! box into square cells of [`CELL`] pixels, and a ray tests only its cell's faces whose box
//! holds its pixel centre — with the same exact signs as the BVH's crossing test, taken in the
//! walk's frame ([`Frame2::cross_face`]: 2-D products with a static error bound, the exact
//! predicate below it), so it enters through the same face (ties between faces at one depth
//! aside, which the BVH orders by its traversal and the grid by face order) at the BVH's depth
//! to rounding (the crossing is interpolated as the walk's exits are). The 3-D predicates took
//! ~6 % of a post frame's samples; the frame's products are 1.5 % fewer instructions over all.
//! Re-entries beyond a depth are found the same way. A ray whose pixel centre lies in no
//! boundary face's padded box, front or back ([`EntryGrid::may_cross`]), is neither searched
//! nor checked: by the argument below it crosses no face. The check that any other ray which
//! entered nowhere crosses no face (in either direction, over all boundary faces) stays with
//! the BVH. (On `post` at 512² two thirds of the rays miss the mesh, and the BVH's check of
//! each took ~1 070 instructions.)
//!
//! A ray's pixel centre is where every point of the ray projects ([`Camera::project`] inverts
//! [`Camera::ray_at`] on the image plane), so a face the ray crosses has the centre in its
//! projected triangle, up to the rounding of the projection (~1e-13 px); boxes are widened by
//! [`PAD`] px to cover it.
//!
//! Each face also carries a bound of the depth at which any ray can cross it, so that the search
//! for a re-entry beyond a depth passes over the faces wholly in front of it (on a convex mesh,
//! all of them) without their crossing test. The bound is conservative, so every face the test
//! would have accepted is still tested: the same entries, the same bits.

use rayon::prelude::*;

use super::bvh::{Bvh, Front};
use super::predicate::RayCtx;
use super::projected::Frame2;
use super::Prepared;
use crate::camera::{Camera, Projection};
use crate::mesh::FACE_VERTS;

/// Side of a grid cell in pixels.
const CELL: usize = 8;
/// Widening of the projected boxes in pixels (their rounding is ~1e-13 px, f32 storage ~1e-4).
const PAD: f64 = 0.01;

/// A face in a cell's list: its leaf index in the BVH, its projected box (pixels) and a bound
/// of the depth along the ray at which a ray of the frame can cross it ([`depth_bound`]).
#[derive(Clone, Copy)]
struct Item {
    leaf: u32,
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    t_max: f32,
}

/// An upper bound of the depth `(x − o)·d` of any point `x` of the triangle `p` along any ray
/// `(o, d)` of `cam`, as [`Prepared::cross_face`] computes it, in f32 (the margin below covers
/// the conversion's rounding).
///
/// The depth of a point of the triangle is a convex combination of its vertices' (the crossing
/// is interpolated with non-negative weights). Orthographic rays start on the plane at `2R`
/// towards the eye and run along `−e` (`e` the unit vector to the eye), so a vertex's depth is
/// `2R − p·e` (up to the rounding of `r·e` and `u·e`, ~1e-16 of the pixel offsets); perspective
/// rays start at the eye with unit directions, so it is at most `|p − eye|`. A margin of 1e-6
/// of the bound plus `4R` covers the rounding of both computations and of the f32 (6e-8
/// relative). A NaN bound is +∞ (the face is always tested).
fn depth_bound(cam: &Camera, p: [glam::DVec3; 3]) -> f32 {
    let eye = cam.eye();
    let depth = |v: glam::DVec3| match cam.projection {
        Projection::Ortho => 2.0 * cam.radius - v.dot(cam.to_eye),
        Projection::Persp => (v - eye).length(),
    };
    let t = p.map(depth).into_iter().fold(f64::NEG_INFINITY, f64::max);
    let t = t + 1e-6 * (t.abs() + 4.0 * cam.radius);
    if t.is_nan() {
        f32::INFINITY
    } else {
        t as f32
    }
}

pub(super) struct EntryGrid {
    nx: usize,
    ny: usize,
    /// Cell c's items are `items[start[c]..start[c + 1]]`, in ascending leaf order. A face is
    /// filed in every cell its box meets, so the total can pass 2³² on a large mesh: 64-bit.
    start: Vec<usize>,
    items: Vec<Item>,
    /// Per cell, the largest `t_max` of its items (−∞ when it has none): a search beyond it
    /// would pass over every item, so it is not made (a ray leaving a convex part of the mesh
    /// looks for a re-entry behind it).
    cell_t_max: Vec<f32>,
    /// Image size in pixels, and one bit per pixel (row-major): set where the pixel centre
    /// lies in the padded box of a boundary face, enterable or not.
    width: usize,
    height: usize,
    covered: Vec<u64>,
}

impl EntryGrid {
    /// Bytes the grid holds.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.start.as_slice())
            + std::mem::size_of_val(self.items.as_slice())
            + std::mem::size_of_val(self.cell_t_max.as_slice())
            + std::mem::size_of_val(self.covered.as_slice())
    }

    /// Whether the ray of pixel `(i, j)` may cross a boundary face in either direction: `false`
    /// only where the pixel centre is in no face's padded box, which every face the ray
    /// crosses has it in (see the module docs). A pixel off the image may.
    #[inline]
    pub(super) fn may_cross(&self, i: usize, j: usize) -> bool {
        if i >= self.width || j >= self.height {
            return true;
        }
        let b = j * self.width + i;
        self.covered[b / 64] & (1 << (b % 64)) != 0
    }

    /// The grid of `cam`'s frame, or `None` where the projection cannot be trusted (a
    /// perspective eye with mesh behind it: `front` then keeps every face and so does the BVH).
    pub(super) fn new(
        st: &Prepared,
        tets: &[[u32; 4]],
        front: &Front,
        cam: &Camera,
    ) -> Option<EntryGrid> {
        let (w, h) = (cam.width.max(1) as usize, cam.height.max(1) as usize);
        let bvh: &Bvh = &st.bvh;
        if matches!(cam.projection, Projection::Persp) {
            let eye = cam.eye();
            let ok = st
                .verts
                .iter()
                .all(|v| (v.p - eye).dot(cam.forward) > 1e-9 * cam.radius);
            if !ok {
                return None;
            }
        }
        let (nx, ny) = (w.div_ceil(CELL), h.div_ceil(CELL));
        // Each face's padded box in pixels, or None off the image (the depth bound only for
        // the enterable faces, the only ones searched).
        let boxes: Vec<Option<Item>> = (0..bvh.faces.len())
            .into_par_iter()
            .map(|i| {
                let bf = bvh.faces[i] as usize;
                let pos = FACE_VERTS[bf % 4].map(|k| st.verts[tets[bf / 4][k] as usize].p);
                let p = pos.map(|v| cam.project(v));
                let x0 = p[0].0.min(p[1].0).min(p[2].0) - PAD;
                let x1 = p[0].0.max(p[1].0).max(p[2].0) + PAD;
                let y0 = p[0].1.min(p[1].1).min(p[2].1) - PAD;
                let y1 = p[0].1.max(p[1].1).max(p[2].1) + PAD;
                // A NaN box (never for finite vertices) is kept whole.
                let (x0, x1, y0, y1) = if x0.is_nan() || x1.is_nan() || y0.is_nan() || y1.is_nan() {
                    (f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    (x0, x1, y0, y1)
                };
                if x1 < 0.0 || y1 < 0.0 || x0 > w as f64 || y0 > h as f64 {
                    return None;
                }
                // f32 rounded outwards by the padding's margin (|x| ≤ a few thousand px).
                Some(Item {
                    leaf: i as u32,
                    x0: x0.max(-1.0) as f32,
                    x1: x1.min(w as f64 + 1.0) as f32,
                    y0: y0.max(-1.0) as f32,
                    y1: y1.min(h as f64 + 1.0) as f32,
                    t_max: if front.faces[i] {
                        depth_bound(cam, pos)
                    } else {
                        f32::INFINITY
                    },
                })
            })
            .collect();
        // Every face for the coverage bits, the enterable ones for the cells.
        let covered = coverage(boxes.iter().flatten(), w, h);
        let enterable = || {
            boxes
                .iter()
                .flatten()
                .filter(|it| front.faces[it.leaf as usize])
        };
        let range = |it: &Item| {
            let c = |v: f32, n: usize| ((v.max(0.0) as usize) / CELL).min(n - 1);
            (c(it.x0, nx), c(it.x1, nx), c(it.y0, ny), c(it.y1, ny))
        };
        let mut start = vec![0usize; nx * ny + 1];
        for it in enterable() {
            let (cx0, cx1, cy0, cy1) = range(it);
            for cy in cy0..=cy1 {
                for cx in cx0..=cx1 {
                    start[cy * nx + cx + 1] += 1;
                }
            }
        }
        for c in 0..nx * ny {
            start[c + 1] += start[c];
        }
        let mut fill: Vec<usize> = start[..nx * ny].to_vec();
        let blank = Item {
            leaf: 0,
            x0: 0.0,
            x1: -1.0,
            y0: 0.0,
            y1: -1.0,
            t_max: f32::NEG_INFINITY,
        };
        let mut items = vec![blank; start[nx * ny]];
        for it in enterable() {
            let (cx0, cx1, cy0, cy1) = range(it);
            for cy in cy0..=cy1 {
                for cx in cx0..=cx1 {
                    let f = &mut fill[cy * nx + cx];
                    items[*f] = *it;
                    *f += 1;
                }
            }
        }
        let cell_t_max = start
            .windows(2)
            .map(|r| {
                items[r[0]..r[1]]
                    .iter()
                    .fold(f32::NEG_INFINITY, |m, it| m.max(it.t_max))
            })
            .collect();
        Some(EntryGrid {
            nx,
            ny,
            start,
            items,
            cell_t_max,
            width: w,
            height: h,
            covered,
        })
    }

    /// A guess at the work of each band of `rows` image rows (from the top): the grid cells
    /// over it that hold a face, that is the part of the band the mesh covers. (The number of
    /// faces would be a worse guess: a curvilinear grid's boundary faces crowd at the
    /// silhouette, where rays are short.) Only the order bands are handed out in depends on
    /// it, never a pixel.
    pub(super) fn band_weights(&self, rows: usize) -> Vec<u64> {
        let h = self.ny * CELL;
        (0..h.div_ceil(rows))
            .map(|b| {
                let (c0, c1) = (b * rows / CELL, ((b + 1) * rows).div_ceil(CELL).min(self.ny));
                let cells = &self.start[c0 * self.nx..=c1 * self.nx];
                cells.windows(2).filter(|p| p[1] > p[0]).count() as u64
            })
            .collect()
    }

    /// The nearest boundary face the ray of pixel `(i, j)` enters through at depth ≥ `t_min`,
    /// other than `exclude` (4·tet + face): (tet, face, depth, scalar, leaf index), as
    /// [`Bvh::first_entry`] with no seed.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn first_entry(
        &self,
        st: &Prepared,
        tets: &[[u32; 4]],
        (ray, fr): (&RayCtx, &Frame2),
        i: usize,
        j: usize,
        t_min: f64,
        exclude: u32,
    ) -> Option<(u32, usize, f64, f64, u32)> {
        let c = (j / CELL).min(self.ny - 1) * self.nx + (i / CELL).min(self.nx - 1);
        // Every item would be passed over by its own `t_max` test below.
        if (self.cell_t_max[c] as f64) < t_min {
            return None;
        }
        let (px, py) = (i as f32 + 0.5, j as f32 + 0.5);
        let bvh = &st.bvh;
        let mut best: Option<(u32, usize, f64, f64, u32)> = None;
        let mut best_t = f64::INFINITY;
        for it in &self.items[self.start[c]..self.start[c + 1]] {
            // (`|`, not `||`: one branch a face, not five hard-to-predict ones.)
            if (px < it.x0) | (px > it.x1) | (py < it.y0) | (py > it.y1) | ((it.t_max as f64) < t_min) {
                continue;
            }
            let bf = bvh.faces[it.leaf as usize];
            if bf == exclude {
                continue;
            }
            let tri = FACE_VERTS[bf as usize % 4].map(|k| tets[bf as usize / 4][k]);
            if let Some((tt, s)) = fr.cross_face(st, ray, tri, bvh.entering[it.leaf as usize]) {
                // The BVH's rule (NaN depths never taken).
                if tt >= t_min && (tt < best_t || (best.is_none() && tt == best_t)) {
                    best_t = tt;
                    best = Some((bf / 4, bf as usize % 4, tt, s, it.leaf));
                }
            }
        }
        best
    }
}

/// One bit per pixel of a `w`×`h` image (row-major), set where the pixel centre
/// `(i + 0.5, j + 0.5)` lies in one of `boxes` (the test of [`EntryGrid::first_entry`]).
fn coverage<'a>(boxes: impl Iterator<Item = &'a Item>, w: usize, h: usize) -> Vec<u64> {
    let mut bits = vec![0u64; (w * h).div_ceil(64)];
    // The first and last index whose centre is in [a, b], clamped to 0..n.
    let span = |a: f32, b: f32, n: usize| {
        // (In f64: exact for these f32 values.)
        let lo = (a as f64 - 0.5).ceil().max(0.0);
        let hi = (b as f64 - 0.5).floor().min(n as f64 - 1.0);
        (lo <= hi).then_some((lo as usize, hi as usize))
    };
    for it in boxes {
        let (Some((i0, i1)), Some((j0, j1))) = (span(it.x0, it.x1, w), span(it.y0, it.y1, h)) else {
            continue;
        };
        for j in j0..=j1 {
            set_bits(&mut bits, j * w + i0, j * w + i1);
        }
    }
    bits
}

/// Sets bits `a..=b` of `bits`, a word at a time (a face that covers the image, as a close
/// perspective view gives, costs a few thousand operations, not a quarter million).
fn set_bits(bits: &mut [u64], a: usize, b: usize) {
    let (wa, wb) = (a / 64, b / 64);
    // Bits a % 64 and up of the first word, up to b % 64 of the last.
    let lo = u64::MAX << (a % 64);
    let hi = u64::MAX >> (63 - b % 64);
    if wa == wb {
        bits[wa] |= lo & hi;
        return;
    }
    bits[wa] |= lo;
    for w in &mut bits[wa + 1..wb] {
        *w = u64::MAX;
    }
    bits[wb] |= hi;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coverage bits are set exactly where `first_entry`'s box test holds a pixel centre,
    /// on boxes with fractional, negative, off-image and empty extents, a few pixels or the
    /// whole width wide, on an image whose rows and pixel count are not multiples of 64.
    #[test]
    fn coverage_is_the_box_test() {
        // Rows of 157 pixels: a box spans up to four words of a row, and rows start mid-word.
        let (w, h) = (157usize, 23usize);
        let mut rng = crate::util::rng::Rng::new(5);
        let mut next = || rng.f() as f32;
        for round in 0..300 {
            let boxes: Vec<Item> = (0..1 + round % 4)
                .map(|_| {
                    let (x, y) = (next() * 170.0 - 8.0, next() * 34.0 - 6.0);
                    // Some boxes hit centres exactly (x.5), some are empty (x1 < x0).
                    let snap = |v: f32| if round % 3 == 0 { v.floor() + 0.5 } else { v };
                    Item {
                        leaf: 0,
                        x0: snap(x),
                        x1: snap(x + next() * if round % 5 == 0 { 180.0 } else { 6.0 } - 0.5),
                        y0: snap(y),
                        y1: snap(y + next() * 6.0 - 0.5),
                        t_max: 0.0,
                    }
                })
                .collect();
            let bits = coverage(boxes.iter(), w, h);
            let grid = EntryGrid {
                nx: 1,
                ny: 1,
                start: vec![0, 0],
                items: Vec::new(),
                cell_t_max: vec![f32::NEG_INFINITY],
                width: w,
                height: h,
                covered: bits,
            };
            for j in 0..h {
                for i in 0..w {
                    let (px, py) = (i as f32 + 0.5, j as f32 + 0.5);
                    let want = boxes.iter().any(|it| {
                        !((px < it.x0) | (px > it.x1) | (py < it.y0) | (py > it.y1))
                    });
                    assert_eq!(grid.may_cross(i, j), want, "round {round}, pixel ({i}, {j})");
                }
            }
            // Off the image nothing is ruled out.
            assert!(grid.may_cross(w, 0) && grid.may_cross(0, h) && grid.may_cross(3, h + 5));
        }
    }
}
