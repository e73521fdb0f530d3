//! Joint bilateral upsampling (Callahan & Silva 2008, after Kopf et al. 2007): a small rendered
//! image is upsampled to full size guided by full-size depth layers of the mesh boundary.
//!
//! - [`BoundaryRaster`] rasterises the boundary faces of a mesh on the CPU and keeps, per pixel,
//!   the first `k` depths along the pixel's ray (k = 1..=4) — the CPU equivalent of `k` depth-peeling
//!   passes. Depths are normalised to [0, 1] over the bounding sphere (ortho: distance from the
//!   eye plane in [R, 3R]; persp: distance along the view axis in [2R, 4R]); a pixel with fewer
//!   than `k` layers gets 1.0 in the missing ones (so background is the vector of ones).
//!   Coverage is decided at the pixel centre with exact 2-D orientation predicates and a
//!   top-left tie rule, so a pixel centre on an edge shared by two faces is counted once.
//! - [`upsample`] is the filter: `nearest`, `linear` (bilinear) or `bilateral`, the joint
//!   bilateral filter of the paper, eq. (3)–(4):
//!   `S_p = 1/k_p Σ_q I_q f(‖p − q‖) g(‖R_p − R_q‖)` over the low-res samples `q` around `p`, with a
//!   Gaussian spatial kernel of σ = Ω/2 full-res pixels (Ω the upsampling factor, i.e. half a
//!   low-res pixel) and a Gaussian range kernel of σ_r (default 0.01) on the Euclidean distance
//!   between the full-res pixel's depth-layer vector `R_p` and the low-res sample's `R_q` (the
//!   depth layers rasterised at the low-res pixel centre, i.e. the full-size layers sampled
//!   there). The weights are normalised in the log domain (the largest exponent is subtracted),
//!   so a pixel whose neighbours all differ in depth by many σ_r takes the best-matching samples
//!   instead of dividing by zero.
//!
//! Low-res and full-res images cover the same image-plane square (CONVENTIONS §2), so a
//! full-res pixel centre maps to low-res continuous coordinates by the ratio of pixel sizes.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;

/// Most depth layers a [`BoundaryRaster`] keeps.
pub const MAX_LAYERS: usize = 4;

/// How the low-res image is brought to full size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    Nearest,
    Linear,
    #[default]
    Bilateral,
}

impl Method {
    pub const ALL: [Method; 3] = [Method::Nearest, Method::Linear, Method::Bilateral];
    pub fn name(self) -> &'static str {
        match self {
            Method::Nearest => "nearest",
            Method::Linear => "linear",
            Method::Bilateral => "bilateral",
        }
    }
    pub fn parse(s: &str) -> Result<Method> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                Error::Input(format!(
                    "unknown upsampling method '{s}' (known: nearest, linear, bilateral)"
                ))
            })
    }
}

/// Filter parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub method: Method,
    /// Depth layers in the range vector (1..=4; bilateral only).
    pub k: usize,
    /// σ of the Gaussian range kernel on normalised depth (bilateral only).
    pub sigma_r: f64,
    /// Low-res samples on each side of the point: `2·radius` per axis (bilateral only; 1 is the
    /// 2×2 bilinear footprint, 2 the 4×4 default).
    pub radius: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            method: Method::Bilateral,
            k: 2,
            sigma_r: 0.01,
            radius: 2,
        }
    }
}

impl Params {
    /// Checks the ranges; `Error::Input` names the bad value.
    pub fn check(&self) -> Result<()> {
        if !(1..=MAX_LAYERS).contains(&self.k) {
            return Err(Error::Input(format!(
                "jbu: k={} must be 1..={MAX_LAYERS} depth layers",
                self.k
            )));
        }
        if !(self.sigma_r.is_finite() && self.sigma_r > 0.0) {
            return Err(Error::Input(format!(
                "jbu: sigma={} must be a positive number",
                self.sigma_r
            )));
        }
        if !(1..=8).contains(&self.radius) {
            return Err(Error::Input(format!(
                "jbu: r={} must be 1..=8 low-res pixels",
                self.radius
            )));
        }
        Ok(())
    }
}

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

    /// The first `k` boundary depths per pixel of `camera`'s image.
    pub fn layers(&self, camera: &Camera, k: usize) -> DepthLayers {
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
                    for j in j0 as usize..=j1 as usize {
                        let py = j as f64 + 0.5;
                        for i in i0 as usize..=i1 as usize {
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

/// Position of full-res pixel `i`'s centre in low-res continuous coordinates along one axis.
#[inline]
fn to_low(i: usize, full: u32, low: u32, scale: f64) -> f64 {
    (i as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64
}

/// Upsamples `low` (rendered with `low_cam`) to the size of `full_cam`. `layers` are the depth
/// layers of the full image and of the low image (bilateral only; same `k`).
pub fn upsample(
    low: &Image,
    low_cam: &Camera,
    full_cam: &Camera,
    params: &Params,
    layers: Option<(&DepthLayers, &DepthLayers)>,
) -> Result<Image> {
    let (w, h) = (full_cam.width, full_cam.height);
    let (lw, lh) = (low.width, low.height);
    if (lw, lh) != (low_cam.width, low_cam.height) || lw == 0 || lh == 0 {
        return Err(Error::Internal(format!(
            "jbu: low image {lw}x{lh} does not match its camera {}x{}",
            low_cam.width, low_cam.height
        )));
    }
    // Full-res pixel size in low-res pixels (1/Ω).
    let scale = full_cam.pixel / low_cam.pixel;
    let ux: Vec<f64> = (0..w as usize).map(|i| to_low(i, w, lw, scale)).collect();
    let uy: Vec<f64> = (0..h as usize).map(|j| to_low(j, h, lh, scale)).collect();
    let mut out = Image::new(w, h);
    let wu = w as usize;
    match params.method {
        Method::Nearest => {
            let ix: Vec<u32> = ux
                .iter()
                .map(|&u| (u.floor().max(0.0) as u32).min(lw - 1))
                .collect();
            out.pixels
                .par_chunks_mut(wu)
                .enumerate()
                .for_each(|(j, row)| {
                    let b = (uy[j].floor().max(0.0) as u32).min(lh - 1);
                    for (o, &a) in row.iter_mut().zip(&ix) {
                        *o = low.get(a, b);
                    }
                });
        }
        Method::Linear => {
            // Clamp to the outermost sample centres (texture clamp-to-edge).
            let lin = |u: f64, n: u32| -> (u32, u32, f32) {
                let x = (u - 0.5).clamp(0.0, (n - 1) as f64);
                let a = (x.floor() as u32).min(n - 1);
                let b = (a + 1).min(n - 1);
                (a, b, (x - a as f64) as f32)
            };
            let lx: Vec<(u32, u32, f32)> = ux.iter().map(|&u| lin(u, lw)).collect();
            out.pixels
                .par_chunks_mut(wu)
                .enumerate()
                .for_each(|(j, row)| {
                    let (b0, b1, fy) = lin(uy[j], lh);
                    for (o, &(a0, a1, fx)) in row.iter_mut().zip(&lx) {
                        let (p00, p10) = (low.get(a0, b0), low.get(a1, b0));
                        let (p01, p11) = (low.get(a0, b1), low.get(a1, b1));
                        *o = std::array::from_fn(|c| {
                            let top = p00[c] + (p10[c] - p00[c]) * fx;
                            let bot = p01[c] + (p11[c] - p01[c]) * fx;
                            top + (bot - top) * fy
                        });
                    }
                });
        }
        Method::Bilateral => {
            let (full_l, low_l) = layers.ok_or_else(|| {
                Error::Internal("jbu: bilateral upsampling without depth layers".into())
            })?;
            if (full_l.width, full_l.height) != (w, h)
                || (low_l.width, low_l.height) != (lw, lh)
                || full_l.k != low_l.k
            {
                return Err(Error::Internal(
                    "jbu: depth layers of the wrong size".into(),
                ));
            }
            let k = full_l.k;
            let r = params.radius as i64;
            // Spatial exponent −d²/(2σ²) with d in full-res pixels and σ = Ω/2: in low-res
            // pixels that is −2·d_low². Precomputed per column and per row (separable).
            let axis = |u: f64, n: u32| -> (i64, Vec<f32>) {
                let a0 = (u - 0.5).floor() as i64 - r + 1;
                let e = (0..2 * r)
                    .map(|m| {
                        let a = a0 + m;
                        if a < 0 || a >= n as i64 {
                            f32::NEG_INFINITY
                        } else {
                            let d = a as f64 + 0.5 - u;
                            (-2.0 * d * d) as f32
                        }
                    })
                    .collect();
                (a0, e)
            };
            let cols: Vec<(i64, Vec<f32>)> = ux.iter().map(|&u| axis(u, lw)).collect();
            let inv2s2 = (1.0 / (2.0 * params.sigma_r * params.sigma_r)) as f32;
            let n = 2 * r as usize;
            // Low-res samples packed with their depth vectors (unused layers 0 on both sides).
            let samples: Vec<([f32; 4], [f32; 4])> = (0..lh)
                .flat_map(|b| (0..lw).map(move |a| (a, b)))
                .map(|(a, b)| {
                    let d = low_l.at(a, b);
                    (
                        low.get(a, b),
                        std::array::from_fn(|c| if c < k { d[c] } else { 0.0 }),
                    )
                })
                .collect();
            out.pixels
                .par_chunks_mut(wu)
                .enumerate()
                .for_each(|(j, row)| {
                    let (b0, ey) = axis(uy[j], lh);
                    let mut xs = vec![0.0f32; n * n];
                    let mut idx = vec![usize::MAX; n * n];
                    for (i, o) in row.iter_mut().enumerate() {
                        let (a0, exs) = &cols[i];
                        let d = full_l.at(i as u32, j as u32);
                        let rp: [f32; 4] = std::array::from_fn(|c| if c < k { d[c] } else { 0.0 });
                        // Range exponents, and the smallest (the best depth match).
                        let mut xmin = f32::INFINITY;
                        for (y, &eyv) in ey.iter().enumerate() {
                            for (x, &exv) in exs.iter().enumerate() {
                                let m = y * n + x;
                                if eyv == f32::NEG_INFINITY || exv == f32::NEG_INFINITY {
                                    idx[m] = usize::MAX;
                                    continue;
                                }
                                let q = (b0 + y as i64) as usize * lw as usize
                                    + (*a0 + x as i64) as usize;
                                let rq = &samples[q].1;
                                let d2 = (rp[0] - rq[0]) * (rp[0] - rq[0])
                                    + (rp[1] - rq[1]) * (rp[1] - rq[1])
                                    + (rp[2] - rq[2]) * (rp[2] - rq[2])
                                    + (rp[3] - rq[3]) * (rp[3] - rq[3]);
                                let xr = d2 * inv2s2 - exv - eyv;
                                xs[m] = xr;
                                idx[m] = q;
                                xmin = xmin.min(xr);
                            }
                        }
                        let mut acc = [0.0f32; 4];
                        let mut wsum = 0.0f32;
                        for m in 0..n * n {
                            if idx[m] == usize::MAX {
                                continue;
                            }
                            let wgt = exp_neg(xs[m] - xmin);
                            if wgt == 0.0 {
                                continue;
                            }
                            let p = &samples[idx[m]].0;
                            for c in 0..4 {
                                acc[c] += wgt * p[c];
                            }
                            wsum += wgt;
                        }
                        *o = if wsum > 0.0 {
                            acc.map(|v| v / wsum)
                        } else {
                            [0.0; 4]
                        };
                    }
                });
        }
    }
    Ok(out)
}

/// Steps per unit of the [`exp_neg`] table, and where it ends (e^−24 ≈ 4e-11).
const EXP_STEPS: f32 = 64.0;
const EXP_END: f32 = 24.0;

/// e^−x for x ≥ 0 from a table with linear interpolation (relative error < 1e-4), 0 beyond
/// [`EXP_END`] and for NaN/inf. The filter spends most of its time here.
#[inline]
fn exp_neg(x: f32) -> f32 {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let t = TABLE.get_or_init(|| {
        (0..=(EXP_END * EXP_STEPS) as usize + 1)
            .map(|i| (-(i as f64) / EXP_STEPS as f64).exp() as f32)
            .collect()
    });
    if x.is_nan() || x >= EXP_END {
        return 0.0;
    }
    let f = x.max(0.0) * EXP_STEPS;
    let i = f as usize;
    let a = t[i];
    a + (t[i + 1] - a) * (f - i as f32)
}

/// The low-res camera for `full`: same view and projection, `lw`×`lh` pixels over the same
/// image-plane square.
pub fn low_camera(mesh: &Mesh, full: &Camera, lw: u32, lh: u32) -> Camera {
    Camera::new(&mesh.bbox(), full.view, full.projection, lw, lh)
}

/// The filter with its boundary prepared for one mesh: the part of the JBU wrapper after the
/// low-res render, usable on its own (the harness filters one low-res image several ways).
pub struct Upsampler {
    pub params: Params,
    raster: Option<BoundaryRaster>,
}

/// An upsampled image and the time of its two stages.
pub struct Upsampled {
    pub image: Image,
    pub depth_ms: f64,
    pub filter_ms: f64,
}

impl Upsampler {
    pub fn new(params: Params) -> Result<Upsampler> {
        params.check()?;
        Ok(Upsampler {
            params,
            raster: None,
        })
    }

    /// Collects the boundary of `mesh` (bilateral only).
    pub fn prepare(&mut self, mesh: &Mesh) {
        self.raster = (self.params.method == Method::Bilateral).then(|| BoundaryRaster::new(mesh));
    }

    /// Upsamples `low` (rendered with `low_cam`) to `full_cam`'s size. A low image of the full
    /// size is returned as it is (factor 1: nothing to upsample).
    pub fn run(&self, low: &Image, low_cam: &Camera, full_cam: &Camera) -> Result<Upsampled> {
        if (low.width, low.height) == (full_cam.width, full_cam.height) {
            return Ok(Upsampled {
                image: low.clone(),
                depth_ms: 0.0,
                filter_ms: 0.0,
            });
        }
        let t0 = Instant::now();
        let layers = match (&self.raster, self.params.method) {
            (Some(r), Method::Bilateral) => Some((
                r.layers(full_cam, self.params.k),
                r.layers(low_cam, self.params.k),
            )),
            (None, Method::Bilateral) => {
                return Err(Error::Internal("jbu: run before prepare".into()))
            }
            _ => None,
        };
        let depth_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let image = upsample(
            low,
            low_cam,
            full_cam,
            &self.params,
            layers.as_ref().map(|(a, b)| (a, b)),
        )?;
        Ok(Upsampled {
            image,
            depth_ms,
            filter_ms: t1.elapsed().as_secs_f64() * 1e3,
        })
    }
}
