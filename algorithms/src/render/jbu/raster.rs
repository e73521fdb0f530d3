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

/// Rows per band of the parallel rasteriser (16: a 1024-wide band of k = 4 layers is 256 KB, in L2;
/// faces a few pixels tall are set up in fewer bands than with 8, 8.8 -> 8.3 ms on blunt).
const BAND: usize = 16;

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

/// The depth quantity of a face as a plane over the image, `q = q0 + gx·(x − x0) + gy·(y − y0)`
/// (the linear interpolation of its vertices' `q`; clamped to their range against rounding on
/// slivers). Both scans evaluate it the same way, so they give the same depth bits.
struct Plane {
    x0: f64,
    y0: f64,
    q0: f64,
    gx: f64,
    gy: f64,
    qlo: f64,
    qhi: f64,
}

impl Plane {
    /// `area`: the (positive) doubled area of the counter-clockwise face `v0 v1 v2`.
    fn new(v0: &Proj, v1: &Proj, v2: &Proj, area: f64) -> Plane {
        let (x1, y1, q1) = (v1.x - v0.x, v1.y - v0.y, v1.q - v0.q);
        let (x2, y2, q2) = (v2.x - v0.x, v2.y - v0.y, v2.q - v0.q);
        // Cramer's rule on q1 = gx·x1 + gy·y1, q2 = gx·x2 + gy·y2 (determinant x1·y2 − x2·y1).
        Plane {
            x0: v0.x,
            y0: v0.y,
            q0: v0.q,
            gx: (q1 * y2 - q2 * y1) / area,
            gy: (x1 * q2 - x2 * q1) / area,
            qlo: v0.q.min(v1.q).min(v2.q),
            qhi: v0.q.max(v1.q).max(v2.q),
        }
    }
    #[inline(always)]
    fn row(&self, py: f64) -> f64 {
        self.q0 + self.gy * (py - self.y0)
    }
    #[inline(always)]
    fn at(&self, qrow: f64, px: f64) -> f64 {
        (qrow + self.gx * (px - self.x0)).clamp(self.qlo, self.qhi)
    }
}

/// `x.ceil()` and `x.floor()` for the span ends (the baseline x86-64 target has no rounding
/// instruction and calls libm); exact for |x| < 2^52, and the ends are clamped to the image.
#[inline(always)]
fn ceil_fast(x: f64) -> f64 {
    let x = x.clamp(-1e15, 1e15);
    let t = x as i64 as f64;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

#[inline(always)]
fn floor_fast(x: f64) -> f64 {
    let x = x.clamp(-1e15, 1e15);
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// One edge `a → b` of a counter-clockwise face as a bound on each row's span: inside is
/// `e(px) = s·px + c ≥ 0` with `s = a.y − b.y`, so the edge bounds the span from below where
/// s > 0 and from above where s < 0, at its crossing `x(py) = a.x + (py − a.y)·m` of the row,
/// m = (b.x − a.x)/(b.y − a.y). `err` bounds the rounding of that crossing over the face's
/// rows (five roundings of terms no larger than |a.x| + |py − a.y|·|m|, taken 16 ulps).
#[derive(Clone, Copy)]
struct EdgeRow {
    ax: f64,
    ay: f64,
    m: f64,
    err: f64,
    /// `s > 0`: a lower bound on px; `s < 0`: an upper one; `s == 0`: horizontal.
    lower: bool,
    horizontal: bool,
}

impl EdgeRow {
    fn new(a: &Proj, b: &Proj, rows: f64) -> EdgeRow {
        let dy = b.y - a.y;
        let m = (b.x - a.x) / dy;
        EdgeRow {
            ax: a.x,
            ay: a.y,
            m,
            err: 16.0 * f64::EPSILON * (a.x.abs() + rows * m.abs()) + 1e-9,
            lower: a.y - b.y > 0.0,
            horizontal: dy == 0.0,
        }
    }
}

/// The pixel columns of row centre `py` to test, `[lo, hi]`, and those inside the face for
/// certain, `[lo_in, hi_in]` (empty when `lo_in > hi_in`): the pixels whose centres lie
/// beyond every edge's crossing by more than its rounding bound. Only the pixels between
/// (a centre within `err` of an edge, about 1e-9 px) need the exact predicate. A horizontal
/// edge (the face's top or bottom) bounds nothing: rows strictly inside the face's height are
/// inside it, the row through it is tested exactly. An edge whose bound is not finite makes
/// every pixel of the row be tested.
#[inline(always)]
fn row_span(edges: &[EdgeRow; 3], py: f64) -> [f64; 4] {
    let mut sp = [
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
    ];
    let mut certain = true;
    for e in edges {
        if e.horizontal {
            certain &= py != e.ay;
            continue;
        }
        let x = e.ax + (py - e.ay) * e.m - 0.5;
        if !(x.is_finite() && e.err.is_finite()) {
            certain = false;
            continue;
        }
        if e.lower {
            sp[0] = sp[0].max(ceil_fast(x - e.err));
            sp[2] = sp[2].max(floor_fast(x + e.err) + 1.0);
        } else {
            sp[1] = sp[1].min(floor_fast(x + e.err));
            sp[3] = sp[3].min(ceil_fast(x - e.err) - 1.0);
        }
    }
    if certain {
        sp
    } else {
        [sp[0], sp[1], 1.0, 0.0]
    }
}

/// Counts a crossing at a pixel and inserts its depth `d` into the sorted list of the `k`
/// nearest.
#[inline(always)]
fn insert(c: &mut u8, layers: &mut [f32], d: f32) {
    let k = layers.len();
    *c = c.saturating_add(1);
    if *c as usize > k && d >= layers[k - 1] {
        return;
    }
    let mut at = (*c as usize).min(k) - 1;
    while at > 0 && layers[at - 1] > d {
        layers[at] = layers[at - 1];
        at -= 1;
    }
    layers[at] = d;
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
    /// only the pixel centres between its edges' crossings of the row (widened by their
    /// rounding bound, [`row_span`]); those beyond every crossing by more than the bound are
    /// inside, the rest are tested by the exact predicate: the same pixels and depths as
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

        // Missing layers are 1.0; filled in parallel so that each band's pages are first
        // touched by the thread that rasterises it.
        let mut depth: Vec<f32> = Vec::new();
        depth.par_extend(rayon::iter::repeat_n(1.0f32, w * h * k));
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
                    let (xlo, xhi) = (v0.x.min(v1.x).min(v2.x), v0.x.max(v1.x).max(v2.x));
                    let (ylo, yhi) = (v0.y.min(v1.y).min(v2.y), v0.y.max(v1.y).max(v2.y));
                    let i0 = (xlo - 0.5).ceil().max(0.0);
                    let i1 = (xhi - 0.5).floor().min(w as f64 - 1.0);
                    let j0 = (ylo - 0.5).ceil().max(row0 as f64);
                    let j1 = (yhi - 0.5).floor().min((row0 + rows) as f64 - 1.0);
                    if [i0, i1, j0, j1].iter().any(|v| v.is_nan()) || i0 > i1 || j0 > j1 {
                        continue;
                    }
                    let plane = Plane::new(&v0, &v1, &v2, area.abs());
                    let own = [
                        owns_edge(&v1, &v2),
                        owns_edge(&v2, &v0),
                        owns_edge(&v0, &v1),
                    ];
                    let hgt = yhi - ylo + 1.0;
                    let edges = [
                        EdgeRow::new(&v1, &v2, hgt),
                        EdgeRow::new(&v2, &v0, hgt),
                        EdgeRow::new(&v0, &v1, hgt),
                    ];
                    for j in j0 as usize..=j1 as usize {
                        let py = j as f64 + 0.5;
                        // Pixels [lo, hi] are tested; [lo_in, hi_in] are inside for certain.
                        let (mut lo, mut hi) = (i0, i1);
                        let (mut lo_in, mut hi_in) = (i0, i1);
                        if narrow {
                            let sp = row_span(&edges, py);
                            lo = lo.max(sp[0]);
                            hi = hi.min(sp[1]);
                            lo_in = lo_in.max(sp[2]);
                            hi_in = hi_in.min(sp[3]);
                            if lo > hi {
                                continue;
                            }
                        } else {
                            (lo_in, hi_in) = (1.0, 0.0);
                        }
                        let qrow = plane.row(py);
                        let (lo, hi) = (lo as usize, hi as usize);
                        let (lo_in, hi_in) = if lo_in <= hi_in {
                            (lo_in as usize, hi_in as usize)
                        } else {
                            (usize::MAX, 0)
                        };
                        let line = &mut cband[(j - row0) * w..(j - row0 + 1) * w];
                        let dline = &mut dband[(j - row0) * w * k..(j - row0 + 1) * w * k];
                        for i in lo..=hi {
                            let px = i as f64 + 0.5;
                            if !(lo_in..=hi_in).contains(&i) {
                                let e = [
                                    orient(&v1, &v2, px, py),
                                    orient(&v2, &v0, px, py),
                                    orient(&v0, &v1, px, py),
                                ];
                                if !(0..3).all(|n| e[n] > 0.0 || (e[n] == 0.0 && own[n])) {
                                    continue;
                                }
                            }
                            let d = to_depth(plane.at(qrow, px));
                            insert(&mut line[i], &mut dline[i * k..i * k + k], d);
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
