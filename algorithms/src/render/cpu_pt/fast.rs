//! The fast path of `cpu-pt`'s draw stage: orthographic views with an f32 integrator
//! ([`FastIntegrator`]: `average`, `partial`, `preint`), which is what the speed tables run.
//!
//! What makes it fast, against the general path in `general.rs` (which stays the definition for
//! perspective and the f64 integrators, and which `cpu_pt`'s tests compare this one with):
//! - **one record per tet, one cache line** ([`FastRec`], 64 B): the snapped vertices, their
//!   transfer-function coordinates and the thick vertex's `s_f`, `s_b`, `l`, written by the
//!   project stage in mesh order, so that drawing a tet in visibility order is one random
//!   access instead of six (tet, record, four vertices);
//! - **narrowed rows** ([`raster_fan_rows`]) instead of each fan triangle's bounding box, their
//!   pixels tested without branches (every pixel is written to the queue, and the queue
//!   advances only where it is covered), and the attributes as f32 planes stepped along the row;
//! - **batched shading**: fragments are queued (pixel, `s_f`, `s_b`, `l`) and a batch is shaded
//!   at once ([`FastIntegrator::shade_batch`]) and then composited in queue order, which is the
//!   order a per-fragment loop would composite in, so the image is the same.

use crate::optics_f32::{FastIntegrator, ShadeBatch, BATCH};
use crate::pt::{raster_fan_rows, TABLE};

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
    let (x0, y0) = ((tx * TILE) as i64, (ty * TILE) as i64);
    let clip = [
        x0,
        y0,
        (x0 + TILE as i64 - 1).min(w as i64 - 1),
        (y0 + TILE as i64 - 1).min(h as i64 - 1),
    ];
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
        // Attributes (s_f, s_b, l): the thick vertex's, and the silhouette vertices' (l = 0).
        let thick = [r.sf, r.sb, r.l];
        raster_fan_rows(case, &q, clip, |sp| {
            let (sx, sy) = (r.s[case.fan[sp.tri] as usize], r.s[case.fan[sp.tri + 1] as usize]);
            // a = thick + lx·(x − thick) + ly·(y − thick), per channel; l is thick·(1 − lx − ly).
            let (lx, ly) = (sp.lx as f32, sp.ly as f32);
            let (dlx, dly) = (sp.dlx as f32, sp.dly as f32);
            let a0 = [
                thick[0] + lx * (sx - thick[0]) + ly * (sy - thick[0]),
                thick[1] + lx * (sx - thick[1]) + ly * (sy - thick[1]),
                thick[2] * (1.0 - lx - ly),
            ];
            let da = [
                dlx * (sx - thick[0]) + dly * (sy - thick[0]),
                dlx * (sx - thick[1]) + dly * (sy - thick[1]),
                -thick[2] * (dlx + dly),
            ];
            let row = ((sp.j - y0) as usize * ts) as u16;
            let n = (sp.i1 - sp.i0 + 1) as usize;
            let i0 = (sp.i0 - x0) as u16;
            let mut v = sp.v;
            for (k, i) in (i0..).take(n).enumerate() {
                let kf = k as f32;
                let len = batch.len;
                batch.sf[len] = a0[0] + kf * da[0];
                batch.sb[len] = a0[1] + kf * da[1];
                batch.l[len] = a0[2] + kf * da[2];
                pix[len] = row + i;
                let covered = (v[0] > 0) & (v[1] > 0) & (v[2] > 0);
                batch.len += covered as usize;
                v[0] += sp.st[0];
                v[1] += sp.st[1];
                v[2] += sp.st[2];
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
