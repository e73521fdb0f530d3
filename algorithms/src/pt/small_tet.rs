//! The tets of `cpu-pt`'s fast path whose pixel box holds only a few centres: each centre is
//! tested on its own, with no row set-up.
//!
//! Half of the tets of a grid like `post` at 512² cover one pixel centre or none, yet
//! [`TetRaster`](super::TetRaster) sets each up for rows: the silhouette edges' exact bounds
//! (an f64 estimate and two integer tests each) and the stepping of every edge from row to row.
//! A box of a few centres needs none of that: per centre, the fan edges `F_k + b_k` give the
//! bits `β_k` and the silhouette edges their signs, and triangle k holds the centre iff
//! `β_k ∧ ¬β_{k+1}` and its silhouette edge is positive — [`raster_fan`](super::raster_fan)'s
//! three tests of triangle k, the fan edges evaluated once (see `tet_raster.rs` for why
//! `¬β_{k+1}` is its third test). The same centres, triangles and weights as `raster_fan`
//! (test: `small_tet_matches_per_pixel_rasteriser`).

use super::raster::Edge;
use super::tet_raster::{fan_bits, fan_dirs, normalisers, silhouette_edge, wedge, MAX_FAN};
use super::{pixel_box_in, pixel_centre, Case, Fragment};

/// How a tet fits [`SmallTet::set_up`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fit {
    /// No centre inside the clip, a class that is not drawn, or no centre of the box inside
    /// the silhouette: nothing to draw.
    Empty,
    /// A box of at most the centres asked for, every fan triangle valid: set up.
    Small,
    /// A larger box, or a fan triangle that is not valid: the caller rasterises it by rows.
    Large,
}

/// A tet set up for its centres one by one: columns `ia..ia + w`, rows `ja..ja + h`.
#[derive(Clone, Copy, Debug, Default)]
pub struct SmallTet {
    pub ia: i64,
    pub ja: i64,
    pub w: i64,
    pub h: i64,
    /// Fan edges k ≤ ntri: `F_k + b_k` at centre (ia, ja), steps per column and per row, and
    /// `b_k` (as [`TetRaster`](super::TetRaster)'s).
    g: [i64; MAX_FAN],
    gst: [i64; MAX_FAN],
    gsr: [i64; MAX_FAN],
    pub gbias: [i64; MAX_FAN],
    /// Silhouette edge of each fan triangle, biased, at (ia, ja), and its steps.
    sil: [i64; 4],
    sst: [i64; 4],
    ssr: [i64; 4],
    /// Barycentric normalisers per triangle (as [`TetRaster`](super::TetRaster)'s).
    pub inv_x: [f64; 4],
    pub inv_y: [f64; 4],
    /// Bit k for each of the fan's triangles.
    valid: u32,
}

impl SmallTet {
    /// Sets up the tet of table entry `c` with snapped vertices `q` in the inclusive pixel
    /// rectangle `clip` when its box there holds at most `max_centres` centres. (In place: the
    /// draw keeps one, and a returned value of this size was copied by `memcpy`.)
    #[inline(always)]
    pub fn set_up(&mut self, c: &Case, q: &[[i64; 2]; 4], clip: [i64; 4], max_centres: i64) -> Fit {
        if !c.drawn() {
            return Fit::Empty;
        }
        let Some([ia, ja, ib, jb]) = pixel_box_in(q, clip) else {
            return Fit::Empty;
        };
        let (w, h) = (ib - ia + 1, jb - ja + 1);
        if w * h > max_centres {
            return Fit::Large;
        }
        let n = c.ntri as usize;
        let p = [pixel_centre(ia), pixel_centre(ja)];
        let t = self;
        for tri in 0..n {
            [t.sil[tri], t.sst[tri], t.ssr[tri]] = silhouette_edge(c, q, tri).stepped(p);
        }
        if !t.any_centre_inside(n, w, h) {
            // Many few-centre tets cover no centre at all (on post at 512², 89 844 of 197 947
            // a frame); they need neither fan edges, nor normalisers, nor their centres queued.
            return Fit::Empty;
        }
        let dirs = fan_dirs(c, q);
        (t.ia, t.ja, t.w, t.h, t.valid) = (ia, ja, w, h, (1 << n) - 1);
        // (Fan edges past n and their steps stay 0: their bits are never set. The silhouette
        // slots past n are masked by `valid`.)
        t.g = [0; MAX_FAN];
        t.gst = [0; MAX_FAN];
        t.gsr = [0; MAX_FAN];
        for k in 0..=n {
            let e = Edge::new(q[c.fan[k] as usize], dirs[k]);
            [t.g[k], t.gst[k], t.gsr[k]] = e.stepped(p);
            t.gbias[k] = e.bias;
        }
        for tri in 0..n {
            let (n_x, n_y) = normalisers(c, q, &dirs, tri);
            if n_y <= 0 || n_x <= 0 {
                return Fit::Large;
            }
            t.inv_x[tri] = 1.0 / n_x as f64;
            t.inv_y[tri] = 1.0 / n_y as f64;
        }
        Fit::Small
    }

    /// Whether some centre of the `w`×`h` box is on the inner side of (or on) the silhouette
    /// edge of every fan triangle, `sil[..n]`. That is necessary for a centre to be covered:
    /// the fan tiles the silhouette, a convex polygon, and each triangle's silhouette edge is
    /// one of the polygon's edges (for the open fans of classes 3 and 4 the others lie on the
    /// line through the thick vertex), positive on the polygon's side. So a centre in a
    /// (closed) fan triangle has each such edge's unbiased value ≥ 0, and its biased one
    /// (`+ b`, b ∈ {0, 1}) too. A box where no centre passes draws nothing.
    #[inline(always)]
    fn any_centre_inside(&self, n: usize, w: i64, h: i64) -> bool {
        let mut any = false;
        for dj in 0..h {
            for di in 0..w {
                let mut all = true;
                for k in 0..n {
                    all &= self.sil[k] + di * self.sst[k] + dj * self.ssr[k] >= 0;
                }
                any |= all;
            }
        }
        any
    }

    /// Centre `(ia + di, ja + dj)`: its fan triangle as one bit (bit k: triangle k; 0 where it
    /// is in none) and the unbiased fan edges `F` there.
    #[inline(always)]
    pub fn centre(&self, di: i64, dj: i64) -> (u32, [i64; MAX_FAN]) {
        let g: [i64; MAX_FAN] =
            std::array::from_fn(|k| self.g[k] + di * self.gst[k] + dj * self.gsr[k]);
        let mut inside = 0u32;
        for k in 0..4 {
            inside |= ((self.sil[k] + di * self.sst[k] + dj * self.ssr[k] > 0) as u32) << k;
        }
        let f = std::array::from_fn(|k| g[k] - self.gbias[k]);
        (wedge(fan_bits(&g), self.valid) & inside, f)
    }

    /// Calls `f` for every centre covered, as [`raster_fan`](super::raster_fan) would (the same
    /// centres, triangles and weights; the order is by rows).
    pub fn fragments(&self, mut f: impl FnMut(Fragment)) {
        for dj in 0..self.h {
            for di in 0..self.w {
                let (hit, g) = self.centre(di, dj);
                if hit != 0 {
                    let tri = hit.trailing_zeros() as usize;
                    f(Fragment {
                        i: self.ia + di,
                        j: self.ja + dj,
                        tri,
                        lx: -(g[tri + 1] as f64) * self.inv_x[tri],
                        ly: g[tri] as f64 * self.inv_y[tri],
                    });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pt::tests::{assert_same_fragments, fan_points, Rng};
    use crate::pt::{classify, raster_fan, FanGeometry, ProjVertex};

    /// The same centres, triangles and weights as the per-triangle rasteriser, on the fans of
    /// `tet_rasteriser_matches_per_pixel_rasteriser` shrunk to a few pixels (lattice, random,
    /// degenerate) and clipped; a box of more centres than asked for is left to the rows, a
    /// tet with nothing inside the clip draws nothing, and neither does a fan whose box has no
    /// centre inside its silhouette (`culled`: those must be fans `raster_fan` draws
    /// nothing of, centres on the silhouette's edges included).
    #[test]
    fn small_tet_matches_per_pixel_rasteriser() {
        let mut rng = Rng::new(31);
        let (mut small, mut empty, mut large, mut frags, mut culled) = (0, 0, 0, 0, 0);
        for it in 0..20_000 {
            // Kinds 1–3 are a few pixels wide; kind 0 shrunk by 8 to a few pixels too.
            let mode = it % 4;
            let mut q = fan_points(&mut rng, mode);
            if mode == 0 {
                q = q.map(|p| p.map(|x| x / 8));
            }
            let v = q.map(|q| ProjVertex {
                q,
                ..Default::default()
            });
            let g = FanGeometry::new(q, &classify(&v, false, 1.0));
            let (x, y) = (rng.int(6) - 1, rng.int(6) - 1);
            for clip in [[0, 0, 40, 40], [x, y, x + rng.int(3), y + rng.int(3)]] {
                let mut want = Vec::new();
                raster_fan(&g, clip, |f| want.push(f));
                let mut got = Vec::new();
                let mut t = SmallTet::default();
                match t.set_up(g.case, &q, clip, 6) {
                    Fit::Empty => {
                        empty += 1;
                        culled += (g.case.drawn() && pixel_box_in(&q, clip).is_some()) as usize;
                    }
                    Fit::Large => {
                        large += 1;
                        continue;
                    }
                    Fit::Small => {
                        small += 1;
                        assert!(t.w * t.h <= 6);
                        t.fragments(|f| got.push(f));
                    }
                }
                assert_same_fragments(want, &got, &(q, clip));
                frags += got.len();
            }
        }
        assert!(
            small > 5_000 && empty > 1_000 && large > 1_000 && culled > 1_000,
            "{small} {empty} {large} {culled}"
        );
        assert!(frags > 5_000, "{frags}");
    }
}
