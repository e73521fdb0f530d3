//! The exterior constraints of `xmpvo`: per pixel ray, the mesh's boundary faces in depth order,
//! and from each consecutive pair of them the precedence "the farther cell first" (the image-space
//! exterior ordering of Cook, Max, Silva & Williams 2004, after Silva, Mitchell & Williams 1998).
//!
//! **Coverage** is decided exactly as `cpu-pt` decides it (see `render::pt`): the boundary
//! vertices are the renderer's centred f32 positions, projected by the camera and snapped to
//! 1/4096 pixel; a pixel centre is inside a face when every integer edge function of the face's
//! snapped triangle is positive, and a centre exactly on an edge goes to the side that contains
//! the centre moved by (+ε, −ε²) pixels (the fan rasterizer's rule and the reference ray caster's
//! Simulation of Simplicity). So a face "covers" a pixel exactly when the renderer's perturbed
//! pixel ray crosses it.
//!
//! **Depth** along the ray is a quantity affine in screen space and increasing with distance:
//! ortho the depth from the camera plane, persp `−1/z` (z the distance along the view axis),
//! interpolated with the exact integer barycentric weights. The three vertices are put in a
//! canonical order (by snapped position) first, so two coincident faces (a seam of duplicate
//! vertices) get bit-identical depths and the tie rule below decides.
//!
//! **Kinds.** A boundary face is an *entry* where the ray enters its cell (the face's outward
//! normal points to the eye: for a positive tet, its outward-ordered snapped triangle is clockwise
//! in pixel rows), an *exit* where it leaves, and *flat* on a zero-volume tet (no inside). Hits of
//! equal depth are ordered exit, flat, entry (a ray leaves one cell before entering the next at a
//! shared point), then by tet index.
//!
//! **Constraints.** For two consecutive hits of different tets, `far` farther than `near`: edge
//! `far → near`. Along a ray two non-overlapping cells are crossed in disjoint segments, so
//! every such pair is a true constraint for that ray; the gap pairs (exit, next entry) are the
//! ones the face adjacency cannot give. A pixel whose hits alternate entry, exit, entry, … (flat
//! hits aside) is *regular*; its (entry, exit) pairs lie inside the mesh, where the chain of
//! interior faces already orders them, and are left out. A pixel that is not regular (open or
//! non-manifold boundary, overlapping cells) is counted and keeps every pair.

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::camera::{pixel_centre, snap, SUBPIXEL};

/// Most boundary fragments (an upper bound: Σ of the faces' clipped pixel boxes) a frame may
/// rasterise; a larger image is refused with an error naming its size.
pub const MAX_FRAGMENTS: u64 = 1 << 28;

/// Rows of pixels per band of the parallel rasteriser.
const BAND: i64 = 8;

/// Hit kinds, in their tie order at equal depth.
const EXIT: u8 = 0;
const FLAT: u8 = 1;
const ENTRY: u8 = 2;

/// One boundary face: its three vertices (indices into the boundary vertices), its tet and the
/// tet's orientation (+1, −1, or 0 when flat).
#[derive(Clone, Copy, Debug)]
pub struct BoundaryFace {
    pub v: [u32; 3],
    pub tet: u32,
    pub sign: i8,
}

/// A boundary face set up for one frame: positively oriented snapped triangle, depths.
#[derive(Clone, Copy)]
struct Tri {
    p: [[i64; 2]; 3],
    w: [f64; 3],
    inv_area: f64,
    tet: u32,
    kind: u8,
    /// Inclusive pixel box, clipped to the image.
    bx: [i64; 4],
}

/// One crossing of a pixel ray with a boundary face.
#[derive(Clone, Copy)]
struct Hit {
    pix: u32,
    kind: u8,
    tet: u32,
    depth: f64,
}

/// What one frame's exterior pass found.
#[derive(Debug, Default)]
pub struct Exterior {
    /// Distinct constraints `(far << 32) | near`, sorted.
    pub edges: Vec<u64>,
    /// Pixels whose hits do not alternate entry/exit.
    pub irregular_pixels: usize,
    /// Ray–face crossings found.
    pub hits: usize,
}

/// Index of the first pixel whose centre is ≥ `x` (snapped units).
#[inline]
fn first_centre(x: i64) -> i64 {
    let v = x - SUBPIXEL / 2;
    v.div_euclid(SUBPIXEL) + (v.rem_euclid(SUBPIXEL) != 0) as i64
}

/// Index of the last pixel whose centre is ≤ `x`.
#[inline]
fn last_centre(x: i64) -> i64 {
    (x - SUBPIXEL / 2).div_euclid(SUBPIXEL)
}

/// `(b − a) × (c − a)`, exact for snapped coordinates.
#[inline]
fn cross(a: [i64; 2], b: [i64; 2], c: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// 1 when the edge from `a` to `b` owns the centres on it: the centre moved by (+ε, −ε²) is on
/// its inner (left, positive) side, `E(p + δ) = −d.y·ε − d.x·ε²` (the fan rasterizer's rule).
#[inline]
fn bias(a: [i64; 2], b: [i64; 2]) -> i64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    (d[1] < 0 || (d[1] == 0 && d[0] < 0)) as i64
}

/// The constraints of `camera`'s image. `pos`: boundary vertices, centred, f32 (as `cpu-pt`
/// holds them); `faces`: the boundary faces.
pub fn exterior(camera: &Camera, pos: &[[f32; 3]], faces: &[BoundaryFace]) -> Result<Exterior> {
    let (w, h) = (camera.width as i64, camera.height as i64);
    let persp = camera.projection == Projection::Persp;
    // Snapped position and depth quantity per boundary vertex (None: behind the eye).
    let proj: Vec<Option<([i64; 2], f64)>> = pos
        .par_iter()
        .map(|p| {
            let (x, y, z) = camera.project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            if persp && (z.is_nan() || z <= 0.0) {
                return None;
            }
            let wq = if persp { -1.0 / z } else { z };
            Some(([snap(x), snap(y)], wq))
        })
        .collect();
    let tris: Vec<Tri> = faces
        .par_iter()
        .filter_map(|f| setup(f, &proj, w, h))
        .collect();
    let bound: u64 = tris
        .iter()
        .map(|t| ((t.bx[2] - t.bx[0] + 1) * (t.bx[3] - t.bx[1] + 1)) as u64)
        .sum();
    if bound > MAX_FRAGMENTS {
        return Err(Error::Input(format!(
            "xmpvo: a {w}x{h} image would need up to {bound} boundary fragments per frame \
             (at most {MAX_FRAGMENTS}); use a smaller image"
        )));
    }
    // Bin the faces by bands of rows.
    let bands = (h.max(0) as usize).div_ceil(BAND as usize);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (k, t) in tris.iter().enumerate() {
        for bin in &mut bins[(t.bx[1] / BAND) as usize..=(t.bx[3] / BAND) as usize] {
            bin.push(k as u32);
        }
    }
    let per_band: Vec<(Vec<u64>, usize, usize)> = bins
        .par_iter()
        .enumerate()
        .map(|(b, ids)| band(&tris, ids, w, b as i64 * BAND, h))
        .collect();
    let mut out = Exterior::default();
    let mut edges = Vec::with_capacity(per_band.iter().map(|b| b.0.len()).sum());
    for (e, irr, hits) in per_band {
        edges.extend_from_slice(&e);
        out.irregular_pixels += irr;
        out.hits += hits;
    }
    edges.par_sort_unstable();
    edges.dedup();
    out.edges = edges;
    Ok(out)
}

/// Sets up one face for the frame, or `None` when it covers no pixel centre of the image
/// (edge-on, behind the eye, outside).
fn setup(f: &BoundaryFace, proj: &[Option<([i64; 2], f64)>], w: i64, h: i64) -> Option<Tri> {
    let v = [
        proj[f.v[0] as usize]?,
        proj[f.v[1] as usize]?,
        proj[f.v[2] as usize]?,
    ];
    let outward = cross(v[0].0, v[1].0, v[2].0);
    if outward == 0 {
        return None;
    }
    // Clockwise in pixel rows (y down) = counter-clockwise seen from the eye = front-facing.
    let kind = match f.sign {
        0 => FLAT,
        s if (outward < 0) == (s > 0) => ENTRY,
        _ => EXIT,
    };
    let mut v = v;
    v.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut area = cross(v[0].0, v[1].0, v[2].0);
    if area < 0 {
        v.swap(1, 2);
        area = -area;
    }
    let lo = [0, 1].map(|a| v[0].0[a].min(v[1].0[a]).min(v[2].0[a]));
    let hi = [0, 1].map(|a| v[0].0[a].max(v[1].0[a]).max(v[2].0[a]));
    let bx = [
        first_centre(lo[0]).max(0),
        first_centre(lo[1]).max(0),
        last_centre(hi[0]).min(w - 1),
        last_centre(hi[1]).min(h - 1),
    ];
    if bx[0] > bx[2] || bx[1] > bx[3] {
        return None;
    }
    Some(Tri {
        p: v.map(|x| x.0),
        w: v.map(|x| x.1),
        inv_area: 1.0 / area as f64,
        tet: f.tet,
        kind,
        bx,
    })
}

/// Whether the non-flat hits alternate entry, exit, entry, …, ending on an exit.
fn is_regular(px: &[Hit]) -> bool {
    let mut expect = ENTRY;
    for hit in px.iter().filter(|h| h.kind != FLAT) {
        if hit.kind != expect {
            return false;
        }
        expect = if expect == ENTRY { EXIT } else { ENTRY };
    }
    expect == ENTRY
}

/// Relative depth difference under which two crossings count as one point of the ray (≈1e-4·L).
/// Measured on the NASA post grid at 128², 50 views: with 1e-6, 8–34 pixels per view stayed
/// irregular (faces that should meet but are apart by more, at the grid's seams) and made up to
/// 8 false cycles; with 1e-4, none.
const TIE: f64 = 1e-4;

/// Swaps an entry followed by an exit of another cell at a depth within [`TIE`] (relative) of
/// it: two faces that meet there (a seam of duplicate vertices whose coordinates differ by
/// rounding, a flat gap), which the ray leaves before it enters. Returns whether it swapped.
fn repair_ties(px: &mut [Hit]) -> bool {
    let mut any = false;
    let mut i = 0;
    while i + 1 < px.len() {
        let (a, b) = (px[i], px[i + 1]);
        if a.kind == ENTRY
            && b.kind == EXIT
            && a.tet != b.tet
            && (b.depth - a.depth) <= TIE * a.depth.abs().max(b.depth.abs())
        {
            px.swap(i, i + 1);
            any = true;
            i += 2;
        } else {
            i += 1;
        }
    }
    any
}

/// Rasterises the faces `ids` over the rows `row0 .. row0 + BAND` and turns each pixel's sorted
/// hits into constraints; returns (sorted distinct edges, irregular pixels, hits).
fn band(tris: &[Tri], ids: &[u32], w: i64, row0: i64, h: i64) -> (Vec<u64>, usize, usize) {
    let row1 = (row0 + BAND).min(h) - 1;
    let mut hits: Vec<Hit> = Vec::new();
    for &k in ids {
        let t = &tris[k as usize];
        let [a, b, c] = t.p;
        // Edges a→b, b→c, c→a; the weight of a vertex is the edge function of the opposite edge.
        let edges = [(b, c), (c, a), (a, b)];
        let bias = edges.map(|(p, q)| bias(p, q));
        for j in t.bx[1].max(row0)..=t.bx[3].min(row1) {
            let py = pixel_centre(j);
            let mut inside = false;
            for i in t.bx[0]..=t.bx[2] {
                let p = [pixel_centre(i), py];
                let e = edges.map(|(p0, p1)| cross(p0, p1, p));
                if (0..3).all(|n| e[n] + bias[n] > 0) {
                    inside = true;
                    let depth =
                        (e[0] as f64 * t.w[0] + e[1] as f64 * t.w[1] + e[2] as f64 * t.w[2])
                            * t.inv_area;
                    hits.push(Hit {
                        pix: ((j - row0) * w + i) as u32,
                        kind: t.kind,
                        tet: t.tet,
                        depth,
                    });
                } else if inside {
                    break; // the covered centres of a row are contiguous
                }
            }
        }
    }
    hits.sort_unstable_by(|x, y| {
        x.pix
            .cmp(&y.pix)
            .then(x.depth.total_cmp(&y.depth))
            .then(x.kind.cmp(&y.kind))
            .then(x.tet.cmp(&y.tet))
    });
    let n = hits.len();
    let mut edges = Vec::new();
    let mut irregular = 0;
    for px in hits.chunk_by_mut(|x, y| x.pix == y.pix) {
        let mut regular = is_regular(px);
        if !regular && repair_ties(px) {
            regular = is_regular(px);
        }
        irregular += !regular as usize;
        for pair in px.windows(2) {
            let (near, far) = (pair[0], pair[1]);
            if near.tet == far.tet || (regular && near.kind == ENTRY && far.kind == EXIT) {
                continue;
            }
            edges.push(((far.tet as u64) << 32) | near.tet as u64);
        }
    }
    edges.sort_unstable();
    edges.dedup();
    (edges, irregular, n)
}
