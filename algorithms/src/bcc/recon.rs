//! Ray casting regular CC and BCC volumes with the BCC paper's reconstruction schemes (§3), and
//! the analytic ground truth both are measured against.
//!
//! **Volumes.** [`CcVolume`]: samples at `o + h·(i, j, k)`. [`BccVolume`]: the primary grid
//! `o + h·(i, j, k)` (`i < n`) and the secondary grid `o + h·(i − ½, j − ½, k − ½)` (`i ≤ n`),
//! the layout of `datasets-gen`'s `bcc` meshes. In lattice coordinates `ξ = (x − o)/h` the BCC
//! volume is also a stack of 2D CC planes along any axis `c`, at `ξ_c = k/2`: even `k` hold
//! primary samples (integer in-plane coordinates), odd `k` secondary ones (half-integer).
//!
//! **Ray casting.** Orthographic rays of the [`Camera`] are clipped to the volume's box
//! (the primary box for BCC) and sampled at a fixed world step (or, for `bil`, where the ray
//! meets the planes); consecutive samples make a segment `(s_f, s_b, l)` integrated by the
//! given [`Integrator`] and composited front to back (CONVENTIONS §4), `l` = world length / `L`.
//!
//! **Schemes** ([`Scheme`]), with `c` the plane axis most perpendicular to the ray (largest
//! `|g_c|`, `g = f / h` the ray direction in lattice space):
//! - `tril` — trilinear on the CC volume.
//! - `bil` (§3.1) — bilinear in the plane at each ray–plane intersection; plane spacing `h/2`.
//! - `bilspat` (§3.2, eq. 1) — bilinear in the two planes around the sample, `S_i` and
//!   `S_{i+1}`, then linear across them: `S_α = (1 − α) S_i + α S_{i+1}` with `α` the distance
//!   to plane `i` in units of the plane spacing (the paper's `(√2/2 − α)S_i + αS_{i+1}` with
//!   spacing `√2/2`, normalised).
//! - `bary` (§3.3) — linear on the BCC Delaunay tet containing the sample: the octahedron of
//!   the primary edge `q → q + e_a` is `{|d_a| + max(|d_b|, |d_c|) ≤ ½}` around the edge's
//!   midpoint, so the one of the three candidate edges (per axis, the nearest midpoint) with the
//!   least such norm contains the sample; inside it the sub-tet is the one whose secondary edge
//!   lies on the side of the largest of `±d_b, ±d_c`; the barycentric coordinates come from one
//!   of 12 precomputed inverse matrices (one per tet type, as the paper says).
//! - `shtril` (§3.4) — trilinear in a sheared cube between planes `k` and `k+1`: each corner
//!   `G` of the plane-`k` cell is joined to the plane-`k+1` sample `G + σ`, `σ = (±½, ±½)`
//!   in-plane with the signs of the ray's in-plane drift `g_a/g_c`, `g_b/g_c` (the short edges
//!   as parallel to the ray as possible); the sample is moved back along the shear to plane
//!   `k`, the four short edges are interpolated linearly at the sample's fraction `α` between
//!   the planes, and the four values bilinearly at its position in the cell.
//!
//! **Ground truth** ([`ground_truth`]): the analytic field itself, sampled along each ray at a
//! fine step inside a domain given as a point test (a box, or a BCC mesh's octahedra, [`BccDomain`]),
//! with the boundary crossings found by bisection to 1e-9 of the step, integrated with the
//! given integrator (`exact` for a ground truth) on the linear pieces between samples.
//!
//! One file past 600 lines: the volumes, the five schemes and the ray casting share the lattice
//! algebra above, and split apart each would need the others' internals.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Aabb;
use crate::optics::{composite_under, Integrator, Segment};
use crate::tf::ScalarMap;

/// A reconstruction scheme (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    Trilinear,
    Bilinear,
    BilinearSpatial,
    Barycentric,
    ShearedTrilinear,
}

impl Scheme {
    pub const ALL: [Scheme; 5] = [
        Scheme::Trilinear,
        Scheme::Bilinear,
        Scheme::BilinearSpatial,
        Scheme::Barycentric,
        Scheme::ShearedTrilinear,
    ];
    /// The paper's short name (Fig. 9): `tril`, `bil`, `bilspat`, `bary`, `shtril`.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Trilinear => "tril",
            Scheme::Bilinear => "bil",
            Scheme::BilinearSpatial => "bilspat",
            Scheme::Barycentric => "bary",
            Scheme::ShearedTrilinear => "shtril",
        }
    }
    /// The grid the scheme reconstructs on.
    pub fn lattice(self) -> &'static str {
        if self == Scheme::Trilinear {
            "CC"
        } else {
            "BCC"
        }
    }
}

/// The box of grid points `o + h·(i, j, k)`, `i < n`.
fn grid_box(n: [usize; 3], origin: DVec3, h: DVec3) -> Aabb {
    let last = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) - 1.0;
    Aabb {
        min: origin,
        max: origin + h * last,
    }
}

/// A regular CC volume.
#[derive(Clone, Debug)]
pub struct CcVolume {
    pub n: [usize; 3],
    pub origin: DVec3,
    pub h: DVec3,
    pub values: Vec<f64>,
}

impl CcVolume {
    /// Samples `f` at `o + h·(i, j, k)`.
    pub fn sample(n: [usize; 3], origin: DVec3, h: DVec3, f: impl Fn(DVec3) -> f64 + Sync) -> Self {
        let values = (0..n[0] * n[1] * n[2])
            .into_par_iter()
            .map(|g| {
                let ijk = [g % n[0], (g / n[0]) % n[1], g / (n[0] * n[1])];
                f(origin + h * DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64))
            })
            .collect();
        CcVolume {
            n,
            origin,
            h,
            values,
        }
    }

    pub fn samples(&self) -> usize {
        self.values.len()
    }

    fn bbox(&self) -> Aabb {
        grid_box(self.n, self.origin, self.h)
    }

    #[inline]
    fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.values[i + self.n[0] * (j + self.n[1] * k)]
    }

    /// Trilinear interpolation at lattice coordinates `x` (clamped to the grid).
    pub fn trilinear(&self, x: [f64; 3]) -> f64 {
        let mut i0 = [0usize; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            let m = (self.n[a] - 1) as f64;
            let xa = x[a].clamp(0.0, m);
            let f = xa.floor().min((m - 1.0).max(0.0));
            i0[a] = f as usize;
            t[a] = xa - f;
        }
        let i1 = std::array::from_fn::<usize, 3, _>(|a| (i0[a] + 1).min(self.n[a] - 1));
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c = |di: usize, dj: usize, dk: usize| {
            self.at(
                if di == 0 { i0[0] } else { i1[0] },
                if dj == 0 { i0[1] } else { i1[1] },
                if dk == 0 { i0[2] } else { i1[2] },
            )
        };
        let x00 = lerp(c(0, 0, 0), c(1, 0, 0), t[0]);
        let x10 = lerp(c(0, 1, 0), c(1, 1, 0), t[0]);
        let x01 = lerp(c(0, 0, 1), c(1, 0, 1), t[0]);
        let x11 = lerp(c(0, 1, 1), c(1, 1, 1), t[0]);
        lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
    }
}

/// A regular BCC volume: primary and secondary grids (see the module docs).
#[derive(Clone, Debug)]
pub struct BccVolume {
    pub n: [usize; 3],
    pub origin: DVec3,
    pub h: DVec3,
    /// `n[0]·n[1]·n[2]` primary samples, `i`-fastest.
    pub primary: Vec<f64>,
    /// `(n[0]+1)·(n[1]+1)·(n[2]+1)` secondary samples at `o + h·(i − ½, …)`, `i`-fastest.
    pub secondary: Vec<f64>,
    /// Per tet type `(axis, sub)`: the inverse of `[P1 − P0, S_u − P0, S_{u+1} − P0]`.
    bary: [[DMat3; 4]; 3],
}

/// The secondary ring around a primary edge along `a`: `(b, c)` offsets (−,−) (+,−) (+,+) (−,+).
const RING: [[f64; 2]; 4] = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];

/// Lattice vector with `va` on axis `a`, `vb` on `a+1`, `vc` on `a+2` (mod 3).
#[inline]
fn along(a: usize, va: f64, vb: f64, vc: f64) -> DVec3 {
    let mut v = [0.0; 3];
    v[a] = va;
    v[(a + 1) % 3] = vb;
    v[(a + 2) % 3] = vc;
    DVec3::from_array(v)
}

impl BccVolume {
    /// Samples `f` on both grids.
    pub fn sample(n: [usize; 3], origin: DVec3, h: DVec3, f: impl Fn(DVec3) -> f64 + Sync) -> Self {
        let grid = |m: [usize; 3], shift: f64| -> Vec<f64> {
            (0..m[0] * m[1] * m[2])
                .into_par_iter()
                .map(|g| {
                    let ijk = [g % m[0], (g / m[0]) % m[1], g / (m[0] * m[1])];
                    f(origin
                        + h * (DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64) - shift))
                })
                .collect()
        };
        Self::from_samples(n, origin, h, grid(n, 0.0), grid(n.map(|x| x + 1), 0.5))
    }

    /// A volume of samples already taken (e.g. a `bcc` mesh's vertex scalars): `primary`
    /// holds `n[0]·n[1]·n[2]` values and `secondary` `(n[0]+1)·(n[1]+1)·(n[2]+1)`, both
    /// `i`-fastest.
    pub fn from_samples(
        n: [usize; 3],
        origin: DVec3,
        h: DVec3,
        primary: Vec<f64>,
        secondary: Vec<f64>,
    ) -> Self {
        debug_assert_eq!(primary.len(), n[0] * n[1] * n[2]);
        debug_assert_eq!(secondary.len(), (n[0] + 1) * (n[1] + 1) * (n[2] + 1));
        let bary = std::array::from_fn(|a| {
            std::array::from_fn(|u| {
                let s0 = along(a, 0.5, RING[u][0], RING[u][1]);
                let s1 = along(a, 0.5, RING[(u + 1) % 4][0], RING[(u + 1) % 4][1]);
                DMat3::from_cols(along(a, 1.0, 0.0, 0.0), s0, s1).inverse()
            })
        });
        BccVolume {
            n,
            origin,
            h,
            primary,
            secondary,
            bary,
        }
    }

    pub fn samples(&self) -> usize {
        self.primary.len() + self.secondary.len()
    }

    fn bbox(&self) -> Aabb {
        grid_box(self.n, self.origin, self.h)
    }

    #[inline]
    fn prim(&self, p: [i64; 3]) -> f64 {
        let n = self.n;
        let c = |a: usize| p[a].clamp(0, n[a] as i64 - 1) as usize;
        self.primary[c(0) + n[0] * (c(1) + n[1] * c(2))]
    }

    /// Secondary sample with index `s` (at lattice position `s − ½`).
    #[inline]
    fn sec(&self, s: [i64; 3]) -> f64 {
        let m = self.n.map(|x| x + 1);
        let c = |a: usize| s[a].clamp(0, m[a] as i64 - 1) as usize;
        self.secondary[c(0) + m[0] * (c(1) + m[1] * c(2))]
    }

    /// Sample of plane `k` (at `ξ_c = k/2`) with in-plane index `(i, j)` along axes
    /// `(c+1, c+2)`: primary at `(i, j)` for even `k`, secondary at `(i − ½, j − ½)` for odd.
    #[inline]
    fn plane_value(&self, c: usize, k: i64, i: i64, j: i64) -> f64 {
        let mut p = [0i64; 3];
        p[(c + 1) % 3] = i;
        p[(c + 2) % 3] = j;
        if k.rem_euclid(2) == 0 {
            p[c] = k.div_euclid(2);
            self.prim(p)
        } else {
            p[c] = (k + 1).div_euclid(2);
            self.sec(p)
        }
    }

    /// Bilinear interpolation in plane `k` at in-plane lattice coordinates `(x, y)` (§3.1).
    #[inline]
    fn plane_bilinear(&self, c: usize, k: i64, x: f64, y: f64) -> f64 {
        // Secondary planes: index i sits at i − ½.
        let shift = if k.rem_euclid(2) == 1 { 0.5 } else { 0.0 };
        let (xi, yi) = (x + shift, y + shift);
        let (i0, j0) = (xi.floor(), yi.floor());
        let (tx, ty) = (xi - i0, yi - j0);
        let (i0, j0) = (i0 as i64, j0 as i64);
        let v = |di: i64, dj: i64| self.plane_value(c, k, i0 + di, j0 + dj);
        let a = v(0, 0) + (v(1, 0) - v(0, 0)) * tx;
        let b = v(0, 1) + (v(1, 1) - v(0, 1)) * tx;
        a + (b - a) * ty
    }

    /// `bilspat` at lattice coordinates `x` with plane axis `c` (§3.2, eq. 1).
    pub fn bilinear_spatial(&self, x: [f64; 3], c: usize) -> f64 {
        let z = 2.0 * x[c];
        let k = z.floor();
        let alpha = z - k;
        let (u, v) = (x[(c + 1) % 3], x[(c + 2) % 3]);
        let si = self.plane_bilinear(c, k as i64, u, v);
        let sj = self.plane_bilinear(c, k as i64 + 1, u, v);
        si + (sj - si) * alpha
    }

    /// `shtril` at lattice coordinates `x`, plane axis `c`, shear signs `sigma` (±1 along
    /// `c+1`, `c+2` per half step up in `c`) (§3.4).
    pub fn sheared_trilinear(&self, x: [f64; 3], c: usize, sigma: [f64; 2]) -> f64 {
        let z = 2.0 * x[c];
        let k = z.floor();
        let alpha = z - k;
        let k = k as i64;
        // Back along the shear to plane k.
        let u = x[(c + 1) % 3] - alpha * 0.5 * sigma[0];
        let v = x[(c + 2) % 3] - alpha * 0.5 * sigma[1];
        let shift = if k.rem_euclid(2) == 1 { 0.5 } else { 0.0 };
        let (ui, vi) = (u + shift, v + shift);
        let (i0, j0) = (ui.floor(), vi.floor());
        let (tx, ty) = (ui - i0, vi - j0);
        let (i0, j0) = (i0 as i64, j0 as i64);
        // Plane k+1's index of the point G + σ·½: with the half-cell offset between the planes,
        // index i on plane k (at i − shift) maps to i + (σ+1)/2 − 1 + … ; written out per parity.
        let up = |i: i64, s: f64| -> i64 {
            // position on plane k: i − shift; plus s/2; plane k+1 index = pos + shift'.
            let pos = i as f64 - shift + 0.5 * s;
            let shift1 = 0.5 - shift;
            (pos + shift1).round() as i64
        };
        let edge = |di: i64, dj: i64| {
            let (i, j) = (i0 + di, j0 + dj);
            let a = self.plane_value(c, k, i, j);
            let b = self.plane_value(c, k + 1, up(i, sigma[0]), up(j, sigma[1]));
            a + (b - a) * alpha
        };
        let a = edge(0, 0) + (edge(1, 0) - edge(0, 0)) * tx;
        let b = edge(0, 1) + (edge(1, 1) - edge(0, 1)) * tx;
        a + (b - a) * ty
    }

    /// The BCC Delaunay tet containing lattice point `x`: `(lo, axis, sub, d)` with the primary
    /// edge `lo → lo + e_axis` and `d = x − lo` (BCC paper §3.3, see the module docs).
    pub fn locate(x: [f64; 3]) -> ([i64; 3], usize, usize, DVec3) {
        let mut best = (f64::INFINITY, 0usize, [0.0f64; 3]);
        for a in 0..3 {
            let mut m = [0.0; 3];
            for (b, mb) in m.iter_mut().enumerate() {
                *mb = if b == a {
                    x[b].floor() + 0.5
                } else {
                    x[b].round()
                };
            }
            let d: [f64; 3] = std::array::from_fn(|b| x[b] - m[b]);
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            let norm = d[a].abs() + d[b].abs().max(d[c].abs());
            if norm < best.0 {
                best = (norm, a, m);
            }
        }
        let (_, a, m) = best;
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let (db, dc) = (x[b] - m[b], x[c] - m[c]);
        let sub = if dc <= -db.abs() {
            0
        } else if db >= dc.abs() {
            1
        } else if dc >= db.abs() {
            2
        } else {
            3
        };
        let mut lo = [0i64; 3];
        for (e, l) in lo.iter_mut().enumerate() {
            *l = if e == a {
                (m[e] - 0.5) as i64
            } else {
                m[e] as i64
            };
        }
        let d = DVec3::new(
            x[0] - lo[0] as f64,
            x[1] - lo[1] as f64,
            x[2] - lo[2] as f64,
        );
        (lo, a, sub, d)
    }

    /// `bary` at lattice coordinates `x` (§3.3).
    pub fn barycentric(&self, x: [f64; 3]) -> f64 {
        let (lo, a, u, d) = Self::locate(x);
        let l = self.bary[a][u] * d;
        let mut p1 = lo;
        p1[a] += 1;
        // Secondary sample at lo + ½e_a + ring offset, index = position + ½.
        let s = |r: [f64; 2]| {
            let off = along(a, 0.5, r[0], r[1]);
            let idx = |e: usize| (lo[e] as f64 + off[e] + 0.5).round() as i64;
            self.sec([idx(0), idx(1), idx(2)])
        };
        let v0 = self.prim(lo);
        let v1 = self.prim(p1);
        let v2 = s(RING[u]);
        let v3 = s(RING[(u + 1) % 4]);
        v0 + l.x * (v1 - v0) + l.y * (v2 - v0) + l.z * (v3 - v0)
    }
}

/// The domain of a `bcc` mesh (the union of the octahedra of its primary edges), as a point
/// test in world coordinates.
#[derive(Clone, Copy, Debug)]
pub struct BccDomain {
    pub n: [usize; 3],
    pub origin: DVec3,
    pub h: DVec3,
}

impl BccDomain {
    pub fn contains(&self, p: DVec3) -> bool {
        let x = ((p - self.origin) / self.h).to_array();
        let (lo, a, _, _) = BccVolume::locate(x);
        (0..3).all(|e| {
            let hi = if e == a {
                self.n[e] as i64 - 2
            } else {
                self.n[e] as i64 - 1
            };
            lo[e] >= 0 && lo[e] <= hi
        })
    }
}

/// How samples along a ray become a pixel: the TF's scalar map, the per-segment integrator,
/// the world step between samples and `L` (optical length = world length / `L`).
#[derive(Clone, Copy)]
pub struct Sampling<'a> {
    pub map: ScalarMap,
    pub integ: &'a dyn Integrator,
    pub step: f64,
    pub diag: f64,
}

/// The volume a ray caster reads.
#[derive(Clone, Copy)]
pub enum Volume<'a> {
    Cc(&'a CcVolume),
    Bcc(&'a BccVolume),
}

/// Ray box intersection `[t0, t1]` (None when missed).
fn clip(b: &Aabb, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if d[a].abs() < 1e-300 {
            if o[a] < b.min[a] || o[a] > b.max[a] {
                return None;
            }
            continue;
        }
        let (u, v) = ((b.min[a] - o[a]) / d[a], (b.max[a] - o[a]) / d[a]);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
    }
    (t0 < t1).then_some((t0, t1))
}

/// Composites one pixel from scalar samples `(t, s)` (s already the TF's coordinate), front
/// to back.
fn integrate(samples: &[(f64, f64)], integ: &dyn Integrator, inv_l: f64) -> [f32; 4] {
    let mut acc = Segment::default();
    for w in samples.windows(2) {
        let (t0, s0) = w[0];
        let (t1, s1) = w[1];
        if t1 > t0 {
            composite_under(&mut acc, integ.segment(s0, s1, (t1 - t0) * inv_l));
        }
        if acc.alpha >= 1.0 - 1e-12 {
            break;
        }
    }
    [
        acc.rgb[0] as f32,
        acc.rgb[1] as f32,
        acc.rgb[2] as f32,
        acc.alpha as f32,
    ]
}

/// Shades every pixel whose orthographic ray meets `bbox`: `shade(scratch, o, dir, t0, t1)`
/// with the ray's world origin `o`, direction and clip interval; rows in parallel.
fn per_pixel(
    camera: &Camera,
    bbox: &Aabb,
    shade: impl Fn(&mut Vec<(f64, f64)>, DVec3, DVec3, f64, f64) -> [f32; 4] + Sync,
) -> Result<Image> {
    let (w, hgt) = (camera.width, camera.height);
    let mut img = Image::try_new(w, hgt)?;
    img.pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, row)| {
            let mut scratch = Vec::new();
            for (i, px) in row.iter_mut().enumerate() {
                let ray = camera.pixel_ray(i as u32, j as u32);
                let o = camera.center + ray.origin;
                if let Some((t0, t1)) = clip(bbox, o, ray.dir) {
                    scratch.clear();
                    *px = shade(&mut scratch, o, ray.dir, t0, t1);
                }
            }
        });
    Ok(img)
}

impl Sampling<'_> {
    /// The set-up both ray casters ([`raycast`], [`ground_truth`]) start with: the view must be
    /// orthographic (their rays share one direction), and world lengths become optical ones
    /// by the returned `1 / L`.
    fn ortho_inv_l(&self, camera: &Camera) -> Result<f64> {
        if camera.projection != Projection::Ortho {
            return Err(Error::Input(
                "bcc ray casting: orthographic views only".to_string(),
            ));
        }
        Ok(1.0 / self.diag)
    }
}

/// Ray casts `vol` with `scheme` at the world step of `sampling` (`bil`: at the plane
/// intersections), `l` normalised by its `diag` (the `L` of the images compared).
pub fn raycast(
    vol: Volume<'_>,
    scheme: Scheme,
    camera: &Camera,
    sampling: Sampling<'_>,
) -> Result<Image> {
    let inv_l = sampling.ortho_inv_l(camera)?;
    let (bbox, h, origin) = match (&vol, scheme) {
        (Volume::Cc(v), Scheme::Trilinear) => (v.bbox(), v.h, v.origin),
        (Volume::Bcc(v), s) if s != Scheme::Trilinear => (v.bbox(), v.h, v.origin),
        _ => {
            return Err(Error::Input(format!(
                "scheme {} does not apply to this volume",
                scheme.name()
            )))
        }
    };
    let f = camera.forward;
    let g = (f / h).to_array();
    let c = (0..3)
        .max_by(|&a, &b| g[a].abs().total_cmp(&g[b].abs()))
        .unwrap_or(2);
    let sgn = |x: f64| if x >= 0.0 { 1.0 } else { -1.0 };
    let sigma = [
        sgn(g[(c + 1) % 3] * g[c].signum()),
        sgn(g[(c + 2) % 3] * g[c].signum()),
    ];
    per_pixel(camera, &bbox, |samples, o, dir, t0, t1| {
        let lat = |t: f64| ((o + t * dir - origin) / h).to_array();
        let value = |t: f64| -> f64 {
            let x = lat(t);
            match (&vol, scheme) {
                (Volume::Cc(v), _) => v.trilinear(x),
                (Volume::Bcc(v), Scheme::BilinearSpatial) => v.bilinear_spatial(x, c),
                (Volume::Bcc(v), Scheme::Barycentric) => v.barycentric(x),
                (Volume::Bcc(v), Scheme::ShearedTrilinear) => v.sheared_trilinear(x, c, sigma),
                (Volume::Bcc(v), _) => {
                    // At a plane: ξ_c = k/2 exactly up to rounding.
                    let k = (2.0 * x[c]).round();
                    v.plane_bilinear(c, k as i64, x[(c + 1) % 3], x[(c + 2) % 3])
                }
            }
        };
        if scheme == Scheme::Bilinear {
            // The ray parameter of plane k: ξ_c(t) = k/2.
            let (z0, z1) = (2.0 * lat(t0)[c], 2.0 * lat(t1)[c]);
            let (k0, k1) = (z0.min(z1).ceil() as i64, z0.max(z1).floor() as i64);
            let dz = 2.0 * g[c];
            let t_of = |k: i64| {
                let x0 = 2.0 * lat(0.0)[c];
                (k as f64 - x0) / dz
            };
            let ks: Vec<i64> = if dz > 0.0 {
                (k0..=k1).collect()
            } else {
                (k0..=k1).rev().collect()
            };
            for k in ks {
                let t = t_of(k);
                let x = lat(t);
                if let Volume::Bcc(v) = &vol {
                    let s = v.plane_bilinear(c, k, x[(c + 1) % 3], x[(c + 2) % 3]);
                    samples.push((t, sampling.map.s(s)));
                }
            }
        } else {
            let m = ((t1 - t0) / sampling.step).ceil().max(1.0) as usize;
            for q in 0..=m {
                let t = (t0 + q as f64 * sampling.step).min(t1);
                samples.push((t, sampling.map.s(value(t))));
            }
        }
        integrate(samples, sampling.integ, inv_l)
    })
}

/// Ray-integrates the analytic field `field` over the domain `inside` (a point test; `bbox`
/// bounds it), sampled every `step` along the ray, boundary crossings found by bisection.
pub fn ground_truth(
    field: &(dyn Fn(DVec3) -> f64 + Sync),
    inside: &(dyn Fn(DVec3) -> bool + Sync),
    bbox: &Aabb,
    camera: &Camera,
    sampling: Sampling<'_>,
) -> Result<Image> {
    let inv_l = sampling.ortho_inv_l(camera)?;
    // A hair larger, so that points on the box face count.
    let pad = 1e-9 * sampling.diag;
    let big = Aabb {
        min: bbox.min - pad,
        max: bbox.max + pad,
    };
    per_pixel(camera, &big, |run, o, dir, t0, t1| {
        let at = |t: f64| o + t * dir;
        let mut acc = Segment::default();
        let m = ((t1 - t0) / sampling.step).ceil().max(1.0) as usize;
        let mut prev_t = t0;
        let mut prev_in = inside(at(t0));
        run.clear();
        if prev_in {
            run.push((t0, sampling.map.s(field(at(t0)))));
        }
        let flush = |run: &mut Vec<(f64, f64)>, acc: &mut Segment| {
            let seg = integrate(run, sampling.integ, inv_l);
            let s = Segment {
                rgb: [seg[0] as f64, seg[1] as f64, seg[2] as f64],
                alpha: seg[3] as f64,
            };
            composite_under(acc, s);
            run.clear();
        };
        for q in 1..=m {
            let t = (t0 + q as f64 * sampling.step).min(t1);
            let now_in = inside(at(t));
            if now_in != prev_in {
                // Bisect the crossing.
                let (mut a, mut b) = (prev_t, t);
                while b - a > 1e-9 * sampling.step {
                    let mid = 0.5 * (a + b);
                    if inside(at(mid)) == prev_in {
                        a = mid;
                    } else {
                        b = mid;
                    }
                }
                if prev_in {
                    run.push((a, sampling.map.s(field(at(a)))));
                    flush(run, &mut acc);
                } else {
                    run.push((b, sampling.map.s(field(at(b)))));
                }
            }
            if now_in {
                run.push((t, sampling.map.s(field(at(t)))));
            }
            prev_t = t;
            prev_in = now_in;
        }
        if !run.is_empty() {
            flush(run, &mut acc);
        }
        [
            acc.rgb[0] as f32,
            acc.rgb[1] as f32,
            acc.rgb[2] as f32,
            acc.alpha as f32,
        ]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(p: DVec3) -> f64 {
        0.3 + 0.2 * p.x - 0.1 * p.y + 0.25 * p.z
    }

    /// Every scheme reproduces a linear field exactly (all are affine-exact interpolants).
    #[test]
    fn schemes_are_exact_on_linear_fields() {
        let o = DVec3::splat(-1.0);
        let h = DVec3::new(0.25, 0.2, 0.4);
        let bcc = BccVolume::sample([9, 11, 6], o, h, linear);
        let cc = CcVolume::sample([9, 11, 6], o, h, linear);
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            // A cell away from the border, where the sheared cells stay inside (clamped beyond).
            let x = [1.0 + rnd() * 6.0, 1.0 + rnd() * 8.0, 1.0 + rnd() * 3.0];
            let p = o + h * DVec3::from_array(x);
            let want = linear(p);
            assert!((cc.trilinear(x) - want).abs() < 1e-12);
            assert!((bcc.barycentric(x) - want).abs() < 1e-12, "bary {x:?}");
            for c in 0..3 {
                assert!(
                    (bcc.bilinear_spatial(x, c) - want).abs() < 1e-12,
                    "bilspat {x:?}"
                );
                for sigma in [[1.0, 1.0], [-1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]] {
                    let v = bcc.sheared_trilinear(x, c, sigma);
                    assert!((v - want).abs() < 1e-12, "shtril {x:?} {c} {sigma:?}");
                }
            }
        }
    }

    /// The located tet contains the point (barycentric coordinates in [0, 1]) and the domain
    /// test agrees with the primary box inside it.
    #[test]
    fn locate_finds_the_containing_tet() {
        let bcc = BccVolume::sample([4, 4, 4], DVec3::ZERO, DVec3::ONE, linear);
        let mut state = 99u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let dom = BccDomain {
            n: [4, 4, 4],
            origin: DVec3::ZERO,
            h: DVec3::ONE,
        };
        for _ in 0..5000 {
            let x = [rnd() * 3.0, rnd() * 3.0, rnd() * 3.0];
            let (_, a, u, d) = BccVolume::locate(x);
            let l = bcc.bary[a][u] * d;
            let l0 = 1.0 - l.x - l.y - l.z;
            for v in [l0, l.x, l.y, l.z] {
                assert!((-1e-12..=1.0 + 1e-12).contains(&v), "{x:?}: {l:?}");
            }
            assert!(dom.contains(DVec3::from_array(x)));
        }
        // Beyond the secondary shell (more than half a cell out) nothing is inside.
        assert!(!dom.contains(DVec3::new(-0.6, 1.5, 1.5)));
        assert!(!dom.contains(DVec3::new(1.5, 3.7, 1.5)));
    }
}
