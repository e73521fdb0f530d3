//! The fast path of the `bilateral` filter: the same arithmetic as the scalar definition
//! [`Filter::edge_aware`] in the same order (so the images are bit-identical for a finite guide;
//! tests/tests/renderers/jbu.rs checks it on meshes), laid out for speed:
//!
//! - the low-res samples as three flat arrays (colour, `K` layers, layer count) instead of one
//!   array of tuples, and the bilinear products `t_x·t_y` per pixel computed once;
//! - a background shortcut: a pixel with no boundary crossing whose four samples have none
//!   either, away from the image border, has zero minmod slopes (each one-sided difference
//!   of the all-ones vector against a neighbour in [0, 1] is ≥ 0 backwards and ≤ 0 forwards),
//!   so every range distance is exactly 0, `g = e⁰ = 1`, and the pixel is the bilinear sum
//!   `Σ t_x t_y I_q / Σ t_x t_y` the definition computes — without slopes, distances or `exp`;
//! - interior slopes without the border tests (minmod of the two differences);
//! - the four range weights computed as one vector (the `exp` is branch-free), and not at
//!   all where every exponent is below [`super::filter::EXP_ONE`], where `exp_neg` is exactly
//!   1 (the planar guide of a smooth surface extrapolates to its samples to rounding);
//! - of background pixels, those whose four samples are empty (no crossing, colour +0.0) are
//!   +0.0 without arithmetic: every weighted colour and sum in the definition is +0.0.
//!
//! Rows run in parallel (rayon); nothing is allocated per pixel.

use rayon::prelude::*;

use super::filter::{axis, exp_neg, slopes, Axis, Filter, EXP_ONE};
use super::filter::{bilinear4, colour_consistent, G_FLAT, G_MATCH, W_MIN};
use super::range::{range_d2, refine_equal};
use crate::image::Image;

/// [`super::filter::minmod`] for finite arguments, as selects instead of branches.
#[inline(always)]
fn minmod_select(a: f32, b: f32) -> f32 {
    let m = if a.abs() < b.abs() { a } else { b };
    if a * b > 0.0 {
        m
    } else {
        0.0
    }
}

impl Filter<'_> {
    /// [`Filter::edge_aware`], fast (see the module doc).
    pub(super) fn edge_aware_fast<const K: usize>(
        &self,
        out: &mut Image,
        cols: &[Axis],
        uy: &[f64],
        omega: f64,
        lh: u32,
    ) {
        let (w, h) = (self.full.width as usize, self.full.height as usize);
        let (lw, inv2s2, inv2c2, flat) = (self.lw, self.inv2s2, self.inv2c2, self.flat_d2);
        let depth = &self.full.depth;
        let count = &self.full.count;
        // Structure of arrays of the low-res samples.
        let colour: Vec<[f32; 4]> = self.samples.iter().map(|s| s.0).collect();
        let lay: Vec<[f32; K]> = self
            .samples
            .iter()
            .map(|s| std::array::from_fn(|c| s.1[c]))
            .collect();
        let cnt: Vec<u8> = self.samples.iter().map(|s| s.2 as u8).collect();
        // Samples with no crossing and colour +0.0 (the empty background of every renderer).
        let empty: Vec<bool> = self
            .samples
            .iter()
            .map(|s| s.2 == 0 && s.0.iter().all(|v| v.to_bits() == 0))
            .collect();
        out.pixels
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(j, row)| {
                let ay = axis(uy[j], lh, omega);
                let rb = [ay.a0 as usize * lw, ay.a1 as usize * lw];
                let ty = [1.0 - ay.f, ay.f];
                let dy = [ay.d0, ay.d1];
                let inner_row = j > 0 && j + 1 < h;
                for (i, (o, ax)) in row.iter_mut().zip(cols).enumerate() {
                    let ca = [ax.a0 as usize, ax.a1 as usize];
                    let tx = [1.0 - ax.f, ax.f];
                    let dx = [ax.d0, ax.d1];
                    // Sample order (y, x): (0,0), (0,1), (1,0), (1,1), as in the definition.
                    let q = [rb[0] + ca[0], rb[0] + ca[1], rb[1] + ca[0], rb[1] + ca[1]];
                    let tw = [tx[0] * ty[0], tx[1] * ty[0], tx[0] * ty[1], tx[1] * ty[1]];
                    let np = count[j * w + i] as usize;
                    let inner = inner_row && i > 0 && i + 1 < w;
                    if np == 0 && inner && q.iter().all(|&s| empty[s]) {
                        // Background over empty samples: each product and sum is +0.0.
                        *o = [0.0; 4];
                        continue;
                    }
                    if np == 0 && inner && q.iter().all(|&s| cnt[s] == 0) {
                        // Background: g = 1 for every sample (module doc).
                        let mut acc = [0.0f32; 4];
                        let mut wsum = 0.0f32;
                        for m in 0..4 {
                            let wgt = tw[m] * 1.0;
                            for (a, v) in acc.iter_mut().zip(&colour[q[m]]) {
                                *a += wgt * v;
                            }
                            wsum += wgt;
                        }
                        if wsum >= W_MIN {
                            *o = acc.map(|v| v / wsum);
                            continue;
                        }
                    }
                    let base = (j * w + i) * K;
                    let rp: [f32; K] = std::array::from_fn(|c| depth[base + c]);
                    let p = j * w + i;
                    let c0 = count[p];
                    let (px, py) = if inner
                        && count[p - 1] == c0
                        && count[p + 1] == c0
                        && count[p - w] == c0
                        && count[p + w] == c0
                    {
                        (
                            std::array::from_fn(|c| {
                                let v = rp[c];
                                minmod_select(v - depth[base - K + c], depth[base + K + c] - v)
                            }),
                            std::array::from_fn(|c| {
                                let v = rp[c];
                                minmod_select(
                                    v - depth[base - w * K + c],
                                    depth[base + w * K + c] - v,
                                )
                            }),
                        )
                    } else {
                        slopes::<K>(depth, count, i, j, w, h)
                    };
                    // Range distances: with every count equal (the common case) the plain
                    // squared distance of eq. (4), over the four samples at once.
                    let mut d2 = [0.0f32; 4];
                    if q.iter().all(|&s| cnt[s] as usize == np) {
                        for c in 0..K {
                            for m in 0..4 {
                                let pred = rp[c] + px[c] * dx[m & 1] + py[c] * dy[m >> 1];
                                let e = pred - lay[q[m]][c];
                                d2[m] += e * e;
                            }
                        }
                        for m in 0..4 {
                            if d2[m] > flat {
                                let pred: [f32; K] = std::array::from_fn(|c| {
                                    rp[c] + px[c] * dx[m & 1] + py[c] * dy[m >> 1]
                                });
                                let mut rq = [0.0f32; 4];
                                rq[..K].copy_from_slice(&lay[q[m]]);
                                d2[m] = refine_equal::<K>(d2[m], flat, &pred, &rp, np, &rq);
                            }
                        }
                    } else {
                        for m in 0..4 {
                            let s = q[m];
                            let pred: [f32; K] = std::array::from_fn(|c| {
                                rp[c] + px[c] * dx[m & 1] + py[c] * dy[m >> 1]
                            });
                            let mut rq = [0.0f32; 4];
                            rq[..K].copy_from_slice(&lay[s]);
                            d2[m] = range_d2::<K>(&pred, &rp, np, &rq, cnt[s] as usize, flat);
                        }
                    }
                    let mut acc = [0.0f32; 4];
                    let mut wsum = 0.0f32;
                    let x: [f32; 4] = std::array::from_fn(|m| d2[m] * inv2s2);
                    let gd: [f32; 4] = if x.iter().all(|&x| x < EXP_ONE) {
                        [1.0; 4] // what exp_neg gives there (module doc)
                    } else {
                        x.map(exp_neg)
                    };
                    let mut edge = false;
                    for m in 0..4 {
                        let g = gd[m];
                        edge |= g < G_FLAT;
                        let wgt = tw[m] * g;
                        for (a, v) in acc.iter_mut().zip(&colour[q[m]]) {
                            *a += wgt * v;
                        }
                        wsum += wgt;
                    }
                    let colour4 = std::array::from_fn(|m| &colour[q[m]]);
                    if edge && gd.iter().all(|&g| g < G_MATCH) {
                        *o = bilinear4(colour4, &tw);
                        continue;
                    }
                    let same = if wsum >= W_MIN {
                        acc.map(|v| v / wsum)
                    } else {
                        let pad =
                            |a: [f32; K]| std::array::from_fn(|c| if c < K { a[c] } else { 0.0 });
                        let range = |pred: &[f32; 4], q: usize| {
                            let p: [f32; K] = std::array::from_fn(|c| pred[c]);
                            let mut rq = [0.0f32; 4];
                            rq[..K].copy_from_slice(&lay[q]);
                            range_d2::<K>(&p, &rp, np, &rq, cnt[q] as usize, flat)
                        };
                        self.window(i, j, &pad(rp), Some((pad(px), pad(py))), Some(&range))
                    };
                    if !edge {
                        *o = same;
                        continue;
                    }
                    *o = colour_consistent(colour4, &tw, &gd, same, inv2c2);
                }
            });
    }
}
