//! The full-size guide: boundary depth layers rasterised on the CPU (see [`super`]).

use glam::DVec3;
use rayon::prelude::*;

use super::MAX_LAYERS;
use crate::camera::{Camera, Projection};
use crate::mesh::Mesh;

/// Per-pixel boundary depth layers, normalised to [0, 1], missing layers 1.0.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthLayers {
    pub width: u32,
    pub height: u32,
    pub k: usize,
    /// `k` depths per pixel, row-major, nearest first.
    pub depth: Vec<f32>,
    /// Number of boundary crossings found per pixel (may exceed `k`; saturates at 255).
    pub count: Vec<u8>,
}

impl DepthLayers {
    #[inline]
    pub fn at(&self, i: u32, j: u32) -> &[f32] {
        let o = (j as usize * self.width as usize + i as usize) * self.k;
        &self.depth[o..o + self.k]
    }
}

/// The boundary surface of a mesh, ready to be rasterised for any camera.
pub struct BoundaryRaster {
    /// Boundary vertices in the frame centred on the bounding-box centre (CONVENTIONS §1).
    pos: Vec<DVec3>,
    /// Boundary faces as indices into `pos`.
    tris: Vec<[u32; 3]>,
}

/// Rows per band of the parallel rasteriser.
const BAND: usize = 8;

/// One projected vertex: pixel coordinates and the interpolated depth quantity (ortho: the
/// normalised depth; persp: 1 / axis distance, which is affine in screen space).
#[derive(Clone, Copy)]
struct Proj {
    x: f64,
    y: f64,
    q: f64,
}

#[inline]
fn orient(a: &Proj, b: &Proj, px: f64, py: f64) -> f64 {
    robust::orient2d(
        robust::Coord { x: a.x, y: a.y },
        robust::Coord { x: b.x, y: b.y },
        robust::Coord { x: px, y: py },
    )
}

/// Top-left tie rule: of an edge and its reverse, exactly one owns the points exactly on it.
#[inline]
fn owns_edge(a: &Proj, b: &Proj) -> bool {
    a.y > b.y || (a.y == b.y && a.x < b.x)
}

impl BoundaryRaster {
    pub fn new(mesh: &Mesh) -> BoundaryRaster {
        let c = mesh.bbox().center();
        let mut map = vec![u32::MAX; mesh.num_vertices()];
        let mut pos = Vec::new();
        let tris = mesh
            .boundary_faces()
            .iter()
            .map(|&bf| {
                mesh.face_vertices(bf as usize / 4, bf as usize % 4)
                    .map(|v| {
                        let m = &mut map[v as usize];
                        if *m == u32::MAX {
                            *m = pos.len() as u32;
                            pos.push(mesh.positions()[v as usize] - c);
                        }
                        *m
                    })
            })
            .collect();
        BoundaryRaster { pos, tris }
    }

    pub fn num_faces(&self) -> usize {
        self.tris.len()
    }

    /// The first `k` boundary depths per pixel of `camera`'s image. Each face scans, per row,
    /// only the pixel centres between its edges' crossings of the row (widened by a pixel on
    /// each side), each tested by the exact predicate: the same pixels and depths as
    /// [`BoundaryRaster::layers_scalar`], which tests every centre of the face's bounding box.
    pub fn layers(&self, camera: &Camera, k: usize) -> DepthLayers {
        self.rasterise(camera, k, true)
    }

    /// [`BoundaryRaster::layers`] by the plain bounding-box scan (the definition).
    pub fn layers_scalar(&self, camera: &Camera, k: usize) -> DepthLayers {
        self.rasterise(camera, k, false)
    }

    fn rasterise(&self, camera: &Camera, k: usize, narrow: bool) -> DepthLayers {
        let k = k.clamp(1, MAX_LAYERS);
        let (w, h) = (camera.width as usize, camera.height as usize);
        let r = camera.radius.max(f64::MIN_POSITIVE);
        let persp = camera.projection == Projection::Persp;
        let proj: Vec<Proj> = self
            .pos
            .par_iter()
            .map(|&p| {
                let (x, y, d) = camera.project(p);
                let q = if persp {
                    1.0 / d.max(f64::MIN_POSITIVE)
                } else {
                    (d - r) / (2.0 * r)
                };
                Proj { x, y, q }
            })
            .collect();
        let to_depth = |q: f64| -> f32 {
            let n = if persp {
                (1.0 / q - 2.0 * r) / (2.0 * r)
            } else {
                q
            };
            n.clamp(0.0, 1.0) as f32
        };

        // Bin the faces by the bands of rows whose pixel centres they may cover.
        let bands = h.div_ceil(BAND).max(1);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
        for (t, tri) in self.tris.iter().enumerate() {
            let ys = tri.map(|v| proj[v as usize].y);
            let lo = ys[0].min(ys[1]).min(ys[2]);
            let hi = ys[0].max(ys[1]).max(ys[2]);
            // Rows j whose centre j + 0.5 lies in [lo, hi].
            let j0 = (lo - 0.5).ceil().max(0.0);
            let j1 = (hi - 0.5).floor().min(h as f64 - 1.0);
            if j0.is_nan() || j1.is_nan() || j0 > j1 {
                continue;
            }
            for bin in &mut bins[j0 as usize / BAND..=j1 as usize / BAND] {
                bin.push(t as u32);
            }
        }

        let mut depth = vec![1.0f32; w * h * k];
        let mut count = vec![0u8; w * h];
        depth
            .par_chunks_mut(BAND * w * k)
            .zip(count.par_chunks_mut(BAND * w))
            .enumerate()
            .for_each(|(b, (dband, cband))| {
                let row0 = b * BAND;
                let rows = cband.len() / w.max(1);
                for &t in &bins[b] {
                    let [v0, mut v1, mut v2] = self.tris[t as usize].map(|v| proj[v as usize]);
                    let area = orient(&v0, &v1, v2.x, v2.y);
                    if area == 0.0 || !area.is_finite() {
                        continue; // edge-on: covers no pixel centre
                    }
                    if area < 0.0 {
                        std::mem::swap(&mut v1, &mut v2);
                    }
                    let area = area.abs();
                    let (xlo, xhi) = (v0.x.min(v1.x).min(v2.x), v0.x.max(v1.x).max(v2.x));
                    let (ylo, yhi) = (v0.y.min(v1.y).min(v2.y), v0.y.max(v1.y).max(v2.y));
                    let i0 = (xlo - 0.5).ceil().max(0.0);
                    let i1 = (xhi - 0.5).floor().min(w as f64 - 1.0);
                    let j0 = (ylo - 0.5).ceil().max(row0 as f64);
                    let j1 = (yhi - 0.5).floor().min((row0 + rows) as f64 - 1.0);
                    if [i0, i1, j0, j1].iter().any(|v| v.is_nan()) || i0 > i1 || j0 > j1 {
                        continue;
                    }
                    let own = [
                        owns_edge(&v1, &v2),
                        owns_edge(&v2, &v0),
                        owns_edge(&v0, &v1),
                    ];
                    let edges = [(&v1, &v2), (&v2, &v0), (&v0, &v1)];
                    for j in j0 as usize..=j1 as usize {
                        let py = j as f64 + 0.5;
                        let (mut lo, mut hi) = (i0, i1);
                        if narrow {
                            // Each edge's function is linear along the row: e(px) = s·px + c
                            // with s = a.y − b.y; inside is e ≥ 0. The root bounds the span on
                            // one side; a pixel of margin covers its rounding (|s| ≥ 1e-3).
                            for (a, b) in edges {
                                let s = a.y - b.y;
                                if s.abs() < 1e-3 {
                                    continue;
                                }
                                let c = a.x * (b.y - py) - (a.y - py) * b.x;
                                let x = -c / s - 0.5;
                                if s > 0.0 {
                                    lo = lo.max((x - 1.0).ceil());
                                } else {
                                    hi = hi.min((x + 1.0).floor());
                                }
                            }
                            if lo > hi {
                                continue;
                            }
                        }
                        for i in lo as usize..=hi as usize {
                            let px = i as f64 + 0.5;
                            let e = [
                                orient(&v1, &v2, px, py),
                                orient(&v2, &v0, px, py),
                                orient(&v0, &v1, px, py),
                            ];
                            if !(0..3).all(|n| e[n] > 0.0 || (e[n] == 0.0 && own[n])) {
                                continue;
                            }
                            let q = (e[0] * v0.q + e[1] * v1.q + e[2] * v2.q) / area;
                            let d = to_depth(q);
                            let pix = (j - row0) * w + i;
                            let c = &mut cband[pix];
                            *c = c.saturating_add(1);
                            // Insert into the sorted list of the k nearest.
                            let layers = &mut dband[pix * k..pix * k + k];
                            let n = (*c as usize).min(k);
                            let mut at = n - 1;
                            if *c as usize > k && d >= layers[k - 1] {
                                continue;
                            }
                            while at > 0 && layers[at - 1] > d {
                                layers[at] = layers[at - 1];
                                at -= 1;
                            }
                            layers[at] = d;
                        }
                    }
                }
            });
        DepthLayers {
            width: camera.width,
            height: camera.height,
            k,
            depth,
            count,
        }
    }
}
