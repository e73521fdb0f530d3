//! The upsampling filters of [`super::upsample`]: `nearest`, `linear`, `bilateral` (the default:
//! bilinear weights times a range term against a first-order prediction of the full-size guide)
//! and `gauss` (the paper's Gaussian-support filter with a plain range term).

use rayon::prelude::*;

use super::range::range_d2;
use super::{DepthLayers, Method, Params};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::Image;

/// Position of full-res pixel `i`'s centre in low-res continuous coordinates along one axis.
#[inline]
fn to_low(i: usize, full: u32, low: u32, scale: f64) -> f64 {
    (i as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64
}

/// The two bilinear samples along one axis (clamped to the outermost sample centres, as a
/// texture unit's clamp-to-edge), the weight `f` of the second, and the offsets `d0`, `d1` from
/// the full-res pixel centre to the two sample centres in full-res pixels.
#[derive(Clone, Copy)]
pub(super) struct Axis {
    pub(super) a0: u32,
    pub(super) a1: u32,
    pub(super) f: f32,
    pub(super) d0: f32,
    pub(super) d1: f32,
}

pub(super) fn axis(u: f64, n: u32, omega: f64) -> Axis {
    let x = (u - 0.5).clamp(0.0, (n - 1) as f64);
    let a0 = (x.floor() as u32).min(n - 1);
    let a1 = (a0 + 1).min(n - 1);
    let d = |a: u32| ((a as f64 + 0.5 - u) * omega) as f32;
    Axis {
        a0,
        a1,
        f: (x - a0 as f64) as f32,
        d0: d(a0),
        d1: d(a1),
    }
}

/// minmod of the backward and forward differences: the smaller one-sided slope when both have
/// the same sign, else 0. Next to a depth edge it takes the slope of the side the pixel is on.
#[inline]
pub(super) fn minmod(a: f32, b: f32) -> f32 {
    if a * b <= 0.0 {
        0.0
    } else if a.abs() < b.abs() {
        a
    } else {
        b
    }
}

/// The guide's slope in x and y at pixel (i, j) per layer (normalised depth per full-res
/// pixel), by [`minmod`] of the one-sided differences. A difference is only taken to a
/// neighbour with the same number of boundary crossings `cnt`: where the count changes, layer
/// `c` of one pixel is another surface than layer `c` of the next (a thin sliver in front
/// shifts every later layer by two), so that side is treated as absent, like the image border;
/// with neither side present the slope is 0.
#[inline]
pub(super) fn slopes<const K: usize>(
    d: &[f32],
    cnt: &[u8],
    i: usize,
    j: usize,
    w: usize,
    h: usize,
) -> ([f32; K], [f32; K]) {
    let p = j * w + i;
    let o = p * K;
    let same = |q: usize| cnt[q] == cnt[p];
    let (l, r) = (i > 0 && same(p - 1), i + 1 < w && same(p + 1));
    let (u, n) = (j > 0 && same(p - w), j + 1 < h && same(p + w));
    let gx = std::array::from_fn(|c| {
        let v = d[o + c];
        let back = if l { v - d[o - K + c] } else { f32::NAN };
        let fwd = if r { d[o + K + c] - v } else { f32::NAN };
        one_or_minmod(back, fwd)
    });
    let gy = std::array::from_fn(|c| {
        let v = d[o + c];
        let back = if u { v - d[o - w * K + c] } else { f32::NAN };
        let fwd = if n { d[o + w * K + c] - v } else { f32::NAN };
        one_or_minmod(back, fwd)
    });
    (gx, gy)
}

#[inline]
fn one_or_minmod(back: f32, fwd: f32) -> f32 {
    match (back.is_nan(), fwd.is_nan()) {
        (true, true) => 0.0,
        (true, false) => fwd,
        (false, true) => back,
        (false, false) => minmod(back, fwd),
    }
}

/// Weight mass (of at most 1: the bilinear weights sum to 1) below which no bilinear sample is
/// taken to lie on the pixel's side of a depth edge, and the wider window decides.
pub(super) const W_MIN: f32 = 1e-3;

/// Range weight above which a sample counts as on the pixel's side (no depth edge).
pub(super) const G_FLAT: f32 = 0.99;

/// Range weight that at least one of the 2×2 samples must reach at a depth edge for the guide
/// to be trusted there. Where none does, no sample lies on the pixel's own surface as the
/// guide sees it — a grazing surface whose depth changes faster than the samples resolve, or
/// a feature thinner than a low-res pixel — and the pixel is bilinear (measured on the six
/// datasets' cube views: it turns comb's 128² corner views from losses into wins and changes
/// no cell's mean by more than 1 %).
pub(super) const G_MATCH: f32 = 0.9;

/// The bilinear sum `Σ t_q I_q / Σ t_q` of four samples (order (0,0), (0,1), (1,0), (1,1)).
#[inline(always)]
pub(super) fn bilinear4(colour: [&[f32; 4]; 4], tw: &[f32; 4]) -> [f32; 4] {
    let mut acc = [0.0f32; 4];
    let mut ws = 0.0f32;
    for m in 0..4 {
        for (a, v) in acc.iter_mut().zip(colour[m]) {
            *a += tw[m] * v;
        }
        ws += tw[m];
    }
    acc.map(|v| v / ws)
}

/// The colour-consistency step of the edge-aware filter at a depth edge: a sample across the
/// edge whose colour continues the pixel's side (a silhouette that fades out) is kept as
/// bilinear keeps it. Each sample's weight is its bilinear weight `tw` times the larger of its
/// range weight `gd` and the colour kernel `exp(−|I_q − same|² / 2σ_c²)` on its distance to
/// `same`, the edge-aware result; where less than [`W_MIN`] of the weight is left, `same`.
/// Samples in the order of [`bilinear4`].
#[inline(always)]
pub(super) fn colour_consistent(
    colour: [&[f32; 4]; 4],
    tw: &[f32; 4],
    gd: &[f32; 4],
    same: [f32; 4],
    inv2c2: f32,
) -> [f32; 4] {
    let mut acc = [0.0f32; 4];
    let mut wsum = 0.0f32;
    for m in 0..4 {
        let cs = colour[m];
        let mut c2 = 0.0f32;
        for (v, mm) in cs.iter().zip(&same) {
            c2 += (v - mm) * (v - mm);
        }
        let g = gd[m].max(exp_neg(c2 * inv2c2));
        let wgt = tw[m] * g;
        for (a, v) in acc.iter_mut().zip(cs) {
            *a += wgt * v;
        }
        wsum += wgt;
    }
    if wsum >= W_MIN {
        acc.map(|v| v / wsum)
    } else {
        same
    }
}

/// A low-res sample with its depth-layer vector (unused layers 0) and its number of boundary
/// crossings (which may exceed the k layers kept).
pub(super) type Sample = ([f32; 4], [f32; 4], usize);

pub(super) fn upsample(
    low: &Image,
    low_cam: &Camera,
    full_cam: &Camera,
    params: &Params,
    layers: Option<(&DepthLayers, &DepthLayers)>,
    fast: bool,
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
    let omega = 1.0 / scale;
    let ux: Vec<f64> = (0..w as usize).map(|i| to_low(i, w, lw, scale)).collect();
    let uy: Vec<f64> = (0..h as usize).map(|j| to_low(j, h, lh, scale)).collect();
    let mut out = Image::try_new(w, h)?;
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
            let cols: Vec<Axis> = ux.iter().map(|&u| axis(u, lw, omega)).collect();
            out.pixels
                .par_chunks_mut(wu)
                .enumerate()
                .for_each(|(j, row)| {
                    let ay = axis(uy[j], lh, omega);
                    for (o, ax) in row.iter_mut().zip(&cols) {
                        let (p00, p10) = (low.get(ax.a0, ay.a0), low.get(ax.a1, ay.a0));
                        let (p01, p11) = (low.get(ax.a0, ay.a1), low.get(ax.a1, ay.a1));
                        *o = std::array::from_fn(|c| {
                            let top = p00[c] + (p10[c] - p00[c]) * ax.f;
                            let bot = p01[c] + (p11[c] - p01[c]) * ax.f;
                            top + (bot - top) * ay.f
                        });
                    }
                });
        }
        Method::Bilateral | Method::Gauss => {
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
            let samples: Vec<Sample> = (0..lh)
                .flat_map(|b| (0..lw).map(move |a| (a, b)))
                .map(|(a, b)| {
                    let d = low_l.at(a, b);
                    (
                        low.get(a, b),
                        std::array::from_fn(|c| if c < k { d[c] } else { 0.0 }),
                        low_l.count[(b * lw + a) as usize] as usize,
                    )
                })
                .collect();
            let win = Window::new(params, &ux, &uy, lw, lh, omega);
            let f = Filter {
                full: full_l,
                samples: &samples,
                lw: lw as usize,
                inv2s2: (1.0 / (2.0 * params.sigma_r * params.sigma_r)) as f32,
                inv2c2: (1.0 / (2.0 * params.sigma_c * params.sigma_c)) as f32,
                flat_d2: (-(G_FLAT as f64).ln() * 2.0 * params.sigma_r * params.sigma_r) as f32,
                win: &win,
            };
            if params.method == Method::Gauss {
                out.pixels
                    .par_chunks_mut(wu)
                    .enumerate()
                    .for_each(|(j, row)| {
                        for (i, o) in row.iter_mut().enumerate() {
                            let rp = f.guide(i, j);
                            *o = f.window(i, j, &rp, None, None);
                        }
                    });
            } else {
                let cols: Vec<Axis> = ux.iter().map(|&u| axis(u, lw, omega)).collect();
                match (k, fast) {
                    (1, false) => f.edge_aware::<1>(&mut out, &cols, &uy, omega, lh),
                    (2, false) => f.edge_aware::<2>(&mut out, &cols, &uy, omega, lh),
                    (3, false) => f.edge_aware::<3>(&mut out, &cols, &uy, omega, lh),
                    (_, false) => f.edge_aware::<4>(&mut out, &cols, &uy, omega, lh),
                    (1, true) => f.edge_aware_fast::<1>(&mut out, &cols, &uy, omega, lh),
                    (2, true) => f.edge_aware_fast::<2>(&mut out, &cols, &uy, omega, lh),
                    (3, true) => f.edge_aware_fast::<3>(&mut out, &cols, &uy, omega, lh),
                    (_, true) => f.edge_aware_fast::<4>(&mut out, &cols, &uy, omega, lh),
                }
            }
        }
    }
    Ok(out)
}

/// The `2r × 2r` window of low-res samples around each full-res pixel, with the spatial
/// exponents `−d²/(2σ²)`, d in full-res pixels, σ = Ω/2 (eq. 4): in low-res pixels `−2·d_low²`.
struct Window {
    n: usize,
    /// Per column: first sample index (may be negative) and the n exponents (−inf off the image).
    cols: Vec<(i64, Vec<f32>)>,
    rows: Vec<(i64, Vec<f32>)>,
    /// Offsets from pixel to sample in full-res pixels, per column / row.
    dcols: Vec<Vec<f32>>,
    drows: Vec<Vec<f32>>,
}

impl Window {
    fn new(params: &Params, ux: &[f64], uy: &[f64], lw: u32, lh: u32, omega: f64) -> Window {
        let r = params.radius as i64;
        let one = |u: f64, n: u32| -> ((i64, Vec<f32>), Vec<f32>) {
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
            let d = (0..2 * r)
                .map(|m| ((a0 + m) as f64 + 0.5 - u) as f32 * omega as f32)
                .collect();
            ((a0, e), d)
        };
        let (cols, dcols) = ux.iter().map(|&u| one(u, lw)).unzip();
        let (rows, drows) = uy.iter().map(|&u| one(u, lh)).unzip();
        Window {
            n: 2 * r as usize,
            cols,
            rows,
            dcols,
            drows,
        }
    }
}

/// A range distance from the pixel's guide extrapolated to a sample (first argument) to the
/// sample of that index: `bilateral`'s fallback window uses the layer alignment of
/// [`range_d2`], `gauss` the plain distance (`None`).
pub(super) type RangeFn<'r> = &'r dyn Fn(&[f32; 4], usize) -> f32;

pub(super) struct Filter<'a> {
    pub(super) full: &'a DepthLayers,
    pub(super) samples: &'a [Sample],
    pub(super) lw: usize,
    pub(super) inv2s2: f32,
    pub(super) inv2c2: f32,
    /// The squared range distance at which g falls to [`G_FLAT`]: beyond it a sample is across
    /// an edge unless a layer alignment explains it ([`range_d2`]).
    pub(super) flat_d2: f32,
    win: &'a Window,
}

impl Filter<'_> {
    #[inline]
    fn guide(&self, i: usize, j: usize) -> [f32; 4] {
        let d = self.full.at(i as u32, j as u32);
        std::array::from_fn(|c| if c < self.full.k { d[c] } else { 0.0 })
    }

    /// The Gaussian window filter at pixel (i, j), its weights normalised in the log domain (the
    /// largest exponent is subtracted), so that a pixel whose samples all differ in depth by many
    /// σ_r takes the best-matching ones. With `grad` the range term compares each sample with
    /// the guide extrapolated to it along the pixel's slopes.
    pub(super) fn window(
        &self,
        i: usize,
        j: usize,
        rp: &[f32; 4],
        grad: Option<([f32; 4], [f32; 4])>,
        range: Option<RangeFn>,
    ) -> [f32; 4] {
        let w = self.win;
        let n = w.n;
        let (a0, ex) = &w.cols[i];
        let (b0, ey) = &w.rows[j];
        let mut xs = [0.0f32; 256];
        let mut idx = [usize::MAX; 256];
        let mut xmin = f32::INFINITY;
        for (y, &eyv) in ey.iter().enumerate().take(n) {
            if eyv == f32::NEG_INFINITY {
                continue;
            }
            for (x, &exv) in ex.iter().enumerate().take(n) {
                if exv == f32::NEG_INFINITY {
                    continue;
                }
                let m = y * n + x;
                let q = (*b0 + y as i64) as usize * self.lw + (*a0 + x as i64) as usize;
                let rq = &self.samples[q].1;
                let pred: [f32; 4] = std::array::from_fn(|c| match &grad {
                    Some((gx, gy)) => rp[c] + gx[c] * w.dcols[i][x] + gy[c] * w.drows[j][y],
                    None => rp[c],
                });
                let d2 = match range {
                    Some(f) => f(&pred, q),
                    None => {
                        let mut d2 = 0.0;
                        for c in 0..4 {
                            d2 += (pred[c] - rq[c]) * (pred[c] - rq[c]);
                        }
                        d2
                    }
                };
                let xr = d2 * self.inv2s2 - exv - eyv;
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
            let p = &self.samples[idx[m]].0;
            for c in 0..4 {
                acc[c] += wgt * p[c];
            }
            wsum += wgt;
        }
        if wsum > 0.0 {
            acc.map(|v| v / wsum)
        } else {
            [0.0; 4]
        }
    }

    /// The default filter's scalar definition ([`Filter::edge_aware_fast`] is its fast path,
    /// bit-identical): eq. (3) with the bilinear tent as spatial kernel f (the support of
    /// the linear interpolation it replaces) and the range kernel g of eq. (4) on the distance
    /// between each sample's layer vector and the full-size guide at the pixel extrapolated to
    /// the sample along its [`minmod`] slopes. Where the guide is planar across the 2×2 samples,
    /// g = 1 and the result is exactly bilinear; across a depth edge g ≈ 0 and the samples
    /// beyond it drop out. When less than [`W_MIN`] of the weight is left (every bilinear sample
    /// is across an edge), the 2r×2r Gaussian window with the same extrapolated range term
    /// decides.
    fn edge_aware<const K: usize>(
        &self,
        out: &mut Image,
        cols: &[Axis],
        uy: &[f64],
        omega: f64,
        lh: u32,
    ) {
        let (w, h) = (self.full.width as usize, self.full.height as usize);
        let (lw, samples, inv2s2, inv2c2) = (self.lw, self.samples, self.inv2s2, self.inv2c2);
        let depth = &self.full.depth;
        let count = &self.full.count;
        out.pixels
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(j, row)| {
                let ay = axis(uy[j], lh, omega);
                let rb = [ay.a0 as usize * lw, ay.a1 as usize * lw];
                let ty = [1.0 - ay.f, ay.f];
                let dy = [ay.d0, ay.d1];
                for (i, (o, ax)) in row.iter_mut().zip(cols).enumerate() {
                    let base = (j * w + i) * K;
                    let rp: [f32; K] = std::array::from_fn(|c| depth[base + c]);
                    let np = count[j * w + i] as usize;
                    let (px, py) = slopes::<K>(depth, count, i, j, w, h);
                    let ca = [ax.a0 as usize, ax.a1 as usize];
                    let tx = [1.0 - ax.f, ax.f];
                    let dx = [ax.d0, ax.d1];
                    let mut acc = [0.0f32; 4];
                    let mut wsum = 0.0f32;
                    let mut gd = [[0.0f32; 2]; 2];
                    let mut edge = false;
                    for y in 0..2 {
                        for x in 0..2 {
                            let s = &samples[rb[y] + ca[x]];
                            let pred: [f32; K] =
                                std::array::from_fn(|c| rp[c] + px[c] * dx[x] + py[c] * dy[y]);
                            let d2 = range_d2::<K>(&pred, &rp, np, &s.1, s.2, self.flat_d2);
                            let g = exp_neg(d2 * inv2s2);
                            edge |= g < G_FLAT;
                            gd[y][x] = g;
                            let wgt = tx[x] * ty[y] * g;
                            for (a, v) in acc.iter_mut().zip(&s.0) {
                                *a += wgt * v;
                            }
                            wsum += wgt;
                        }
                    }
                    // The four samples in the order (y, x) of `bilinear4`.
                    let tw = [tx[0] * ty[0], tx[1] * ty[0], tx[0] * ty[1], tx[1] * ty[1]];
                    let q = [rb[0] + ca[0], rb[0] + ca[1], rb[1] + ca[0], rb[1] + ca[1]];
                    let colour = std::array::from_fn(|m| &samples[q[m]].0);
                    if edge && gd.iter().flatten().all(|&g| g < G_MATCH) {
                        *o = bilinear4(colour, &tw);
                        continue;
                    }
                    let same = if wsum >= W_MIN {
                        acc.map(|v| v / wsum)
                    } else {
                        let pad =
                            |a: [f32; K]| std::array::from_fn(|c| if c < K { a[c] } else { 0.0 });
                        let range = |pred: &[f32; 4], q: usize| {
                            let p: [f32; K] = std::array::from_fn(|c| pred[c]);
                            let s = &samples[q];
                            range_d2::<K>(&p, &rp, np, &s.1, s.2, self.flat_d2)
                        };
                        self.window(i, j, &pad(rp), Some((pad(px), pad(py))), Some(&range))
                    };
                    if !edge {
                        *o = same;
                        continue;
                    }
                    let gd = [gd[0][0], gd[0][1], gd[1][0], gd[1][1]];
                    *o = colour_consistent(colour, &tw, &gd, same, inv2c2);
                }
            });
    }
}

/// Where the range and colour kernels end: e^−x is taken as 0 for x ≥ 24 (e^−24 ≈ 4e-11).
const EXP_END: f32 = 24.0;

/// Below this exponent [`exp_neg`] is exactly 1.0 (its polynomial's 1 + f·p rounds to 1 for
/// |f·p| < 2^−25; 2^−26 leaves a factor 2; `exp_neg_is_one_below_exp_one` checks it).
pub(super) const EXP_ONE: f32 = 1.0 / (1u32 << 26) as f32;

/// e^−x for x ≥ 0 by [`crate::optics::fast::exp_neg`] (branch-free, relative error ≤ 2e-6, so
/// the four weights of a pixel are computed as one vector), 0 for x ≥ [`EXP_END`] and for NaN.
#[inline(always)]
pub(super) fn exp_neg(x: f32) -> f32 {
    let e = crate::optics::fast::exp_neg(x.max(0.0));
    if x < EXP_END {
        e
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::{exp_neg, EXP_ONE};

    #[test]
    fn exp_neg_is_one_below_exp_one() {
        // Every f32 in [0, EXP_ONE) of the top binades, and a sweep of the rest.
        let mut x = EXP_ONE;
        for _ in 0..(1 << 20) {
            x = f32::from_bits(x.to_bits() - 1);
            assert_eq!(exp_neg(x), 1.0, "x = {x:e}");
        }
        for e in 0..200 {
            let x = EXP_ONE * 0.5f32.powi(e);
            assert_eq!(exp_neg(x), 1.0, "x = {x:e}");
        }
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(f32::NAN), 0.0);
        assert_eq!(exp_neg(24.0), 0.0);
        let r = (exp_neg(1.0) as f64 - (-1.0f64).exp()).abs() / (-1.0f64).exp();
        assert!(r < 2e-6, "{r}");
    }
}
