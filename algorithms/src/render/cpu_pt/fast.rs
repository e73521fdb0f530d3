//! The fast path of `cpu-pt`'s draw stage: orthographic views with an f32 integrator
//! ([`FastIntegrator`]: `average`, `partial`, `preint`), which is what the speed tables run.
//!
//! What makes it fast, against the general path in `general.rs` (which stays the definition for
//! perspective and the f64 integrators, and which `cpu_pt`'s tests compare this one with):
//! - **one record per tet, one cache line** ([`FastRec`], 64 B): the snapped vertices, their
//!   transfer-function coordinates and the thick vertex's `s_f`, `s_b`, `l`, written by the
//!   project stage in mesh order, so that drawing a tet in visibility order is one random
//!   access instead of six (tet, record, four vertices);
//! - **the whole tet at once** ([`TetRaster`]): one set of exact integer edge functions per
//!   tet (silhouette edges and the fan edges from the thick vertex, each shared by the two fan
//!   triangles it separates), the exact span of each silhouette row, and per pixel the fan
//!   triangle from the fan edges' signs without a branch (every pixel of the span is written to
//!   the queue, which advances only where it is in a triangle); the attributes from per-triangle
//!   f64 planes set up once per tet. Against the per-triangle rows of
//!   [`raster_fan_rows`](crate::pt::raster_fan_rows) it is ~15 % fewer instructions for the
//!   rasteriser and ~6 % less CPU per process (docs/performance.md, third pass);
//! - **batched shading**: fragments are queued (pixel, `s_f`, `s_b`, `l`) and a batch is shaded
//!   at once ([`FastIntegrator::shade_batch`]) and then composited in queue order, which is the
//!   order a per-fragment loop would composite in, so the image is the same.

use crate::optics_f32::{FastIntegrator, ShadeBatch, BATCH};
use crate::pt::{fan_bits, wedge, TetRaster, MAX_FAN, TABLE};

use super::TILE;

/// What drawing one tet needs, in one 64-byte line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(super) struct FastRec {
    /// Snapped pixel coordinates of the four vertices.
    pub q: [[i32; 2]; 4],
    /// Transfer-function coordinate of the four vertices.
    pub s: [f32; 4],
    /// The thick vertex's front and back scalars and thickness (optical units).
    pub sf: f32,
    pub sb: f32,
    pub l: f32,
    /// Index into [`TABLE`].
    pub case: u8,
}

/// Renders tile (tx, ty) of a `w`×`h` image from its tets (`items`, back to front); returns the
/// tile's RGBA rows (TILE wide) and its fragment count.
pub(super) fn draw_tile(
    recs: &[FastRec],
    items: &[u32],
    integ: &FastIntegrator,
    (tx, ty): (u32, u32),
    (w, h): (u32, u32),
) -> (Vec<[f32; 4]>, u64) {
    let ts = TILE as usize;
    let mut buf = vec![[0.0f32; 4]; ts * ts];
    let clip = super::bins::tile_clip(tx, ty, w, h);
    let (x0, y0) = (clip[0], clip[1]);
    let mut batch = ShadeBatch::default();
    let mut pix = [0u16; BATCH];
    let mut frags = 0u64;
    for (n, &t) in items.iter().enumerate() {
        // The records are read in visibility order, at random: ask for one a few tets ahead.
        if let Some(&ahead) = items.get(n + PREFETCH) {
            prefetch(&recs[ahead as usize]);
        }
        let r = &recs[t as usize];
        let case = &TABLE[r.case as usize];
        let q = r.q.map(|v| [v[0] as i64, v[1] as i64]);
        let Some(mut tr) = TetRaster::new(case, &q, clip) else {
            continue;
        };
        // Attributes (s_f, s_b, l) over fan triangle k: thick + lx·(x − thick) + ly·(y − thick)
        // with x, y its silhouette vertices (l = 0 there) and lx = −F_{k+1}·inv_x,
        // ly = F_k·inv_y (see `TetRaster`): thick + F_{k+1}·cx[k] + F_k·cy[k], in f64, set up
        // once per tet; `da` is the step per pixel.
        let thick = [r.sf as f64, r.sb as f64, r.l as f64];
        let mut cx = [[0.0f64; 4]; 4];
        let mut cy = [[0.0f64; 4]; 4];
        let mut da = [[0.0f64; 4]; 4];
        for k in 0..tr.ntri {
            let sx = r.s[case.fan[k] as usize] as f64;
            let sy = r.s[case.fan[k + 1] as usize] as f64;
            let dx = [sx - thick[0], sx - thick[1], -thick[2]];
            let dy = [sy - thick[0], sy - thick[1], -thick[2]];
            for ch in 0..3 {
                cx[k][ch] = -tr.inv_x[k] * dx[ch];
                cy[k][ch] = tr.inv_y[k] * dy[ch];
                da[k][ch] = tr.gst[k + 1] as f64 * cx[k][ch] + tr.gst[k] as f64 * cy[k][ch];
            }
        }
        let (gbias, gst, valid, ntri) = (tr.gbias, tr.gst, tr.valid, tr.ntri);
        tr.rows(|row| {
            let n = (row.i1 - row.i0 + 1) as usize;
            // The attributes at the row's first pixel, per triangle.
            let f: [f64; MAX_FAN] = std::array::from_fn(|m| (row.g[m] - gbias[m]) as f64);
            let mut base = [[0.0f64; 4]; 4];
            for k in 0..ntri {
                for ch in 0..3 {
                    base[k][ch] = thick[ch] + f[k + 1] * cx[k][ch] + f[k] * cy[k][ch];
                }
            }
            let p0 = ((row.j - y0) as usize * ts + (row.i0 - x0) as usize) as u16;
            let mut g = row.g;
            // Every pixel of the row is written to the queue; the queue advances only where it
            // is in one of the fan's triangles (no branch: the rows are a few pixels long).
            for kk in 0..n {
                let t = wedge(fan_bits(&g), valid);
                let tri = (t.trailing_zeros() & 3) as usize;
                let kf = kk as f64;
                let (b, d) = (&base[tri], &da[tri]);
                let len = batch.len;
                batch.sf[len] = (b[0] + kf * d[0]) as f32;
                batch.sb[len] = (b[1] + kf * d[1]) as f32;
                batch.l[len] = (b[2] + kf * d[2]) as f32;
                pix[len] = p0 + kk as u16;
                batch.len += (t != 0) as usize;
                for (v, s) in g.iter_mut().zip(&gst) {
                    *v += s;
                }
                if batch.len == BATCH {
                    frags += BATCH as u64;
                    flush(integ, &mut batch, &pix, &mut buf);
                }
            }
        });
    }
    frags += batch.len as u64;
    flush(integ, &mut batch, &pix, &mut buf);
    (buf, frags)
}

/// How many tets ahead `draw_tile` prefetches.
const PREFETCH: usize = 8;

/// A hint to bring `r`'s cache line in (a no-op where there is no such instruction).
#[inline(always)]
fn prefetch(r: &FastRec) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch has no architectural effect (SSE is baseline on x86-64).
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((r as *const FastRec).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

/// Shades the queued fragments and composites them in queue order.
#[inline]
fn flush(integ: &FastIntegrator, batch: &mut ShadeBatch, pix: &[u16; BATCH], buf: &mut [[f32; 4]]) {
    let n = batch.len;
    if n == 0 {
        return;
    }
    integ.shade_batch(batch);
    let [r, g, b, a] = &batch.out;
    for k in 0..n {
        // Back-to-front "over" (premultiplied): I ← I_seg + (1 − α_seg)·I.
        let p = &mut buf[pix[k] as usize];
        let keep = 1.0 - a[k];
        p[0] = r[k] + keep * p[0];
        p[1] = g[k] + keep * p[1];
        p[2] = b[k] + keep * p[2];
        p[3] = a[k] + keep * p[3];
    }
    batch.len = 0;
}
