//! `cpu-pt`'s general draw path: perspective, and the f64 integrators behind `dyn Integrator`
//! (`exact` always). It is the definition the fast path (`fast.rs`) is tested against.

use glam::DVec3;

use super::bins::Bins;
use super::project::{TetProj, VertProj};
use super::TILE;
use crate::camera::Camera;
use crate::optics::Integrator;
use crate::optics::fast::FastIntegrator;
use crate::render::pt::{fan_segment, raster_fan, FaceVertex, FanGeometry};

/// Per-fragment integration: premultiplied `[r, g, b, α]` of a segment.
pub(super) trait Shade: Sync {
    fn shade(&self, sf: f64, sb: f64, l: f64) -> [f32; 4];
}

impl Shade for &dyn Integrator {
    #[inline]
    fn shade(&self, sf: f64, sb: f64, l: f64) -> [f32; 4] {
        let seg = self.segment(sf, sb, l);
        [
            seg.rgb[0] as f32,
            seg.rgb[1] as f32,
            seg.rgb[2] as f32,
            seg.alpha as f32,
        ]
    }
}

impl Shade for &FastIntegrator {
    #[inline(always)]
    fn shade(&self, sf: f64, sb: f64, l: f64) -> [f32; 4] {
        self.segment(sf as f32, sb as f32, l as f32)
    }
}

/// Renders the tets of one part of the order into every tile's buffer, the tiles in parallel
/// (monomorphised per [`Shade`]); returns the fragments drawn.
pub(super) fn draw_tiles<S: Shade>(
    ctx: DrawCtx<'_, S>,
    bins: &Bins,
    ntx: u32,
    bufs: &mut [Vec<[f32; 4]>],
) -> u64 {
    bins.per_tile(bufs, |k, buf| {
        let (tx, ty) = (k as u32 % ntx, k as u32 / ntx);
        ctx.draw_tile(tx, ty, bins.tile(k), buf)
    })
}

pub(super) struct DrawCtx<'a, S> {
    pub(super) tets: &'a [[u32; 4]],
    /// The part of the visibility order drawn: the tet at each place.
    pub(super) part: &'a [u32],
    /// Centred positions, for the unsnapped projection of [`fan_segment`].
    pub(super) pos: &'a [[f32; 3]],
    pub(super) verts: &'a [VertProj],
    /// The classified tets of the part, by place.
    pub(super) rec: &'a [TetProj],
    pub(super) s: &'a [f32],
    pub(super) integ: S,
    pub(super) camera: &'a Camera,
    pub(super) persp: bool,
    pub(super) inv_l: f64,
}

impl<S: Shade> DrawCtx<'_, S> {
    /// Renders tile (tx, ty) from its bin (places of the part, in order) over what `buf` (its
    /// RGBA rows, TILE wide) holds; returns its fragment count.
    fn draw_tile(&self, tx: u32, ty: u32, bin: &[u32], buf: &mut [[f32; 4]]) -> u64 {
        let ts = TILE as usize;
        let clip = super::bins::tile_clip(tx, ty, self.camera.width, self.camera.height);
        let (x0, y0) = (clip[0], clip[1]);
        // sec θ per pixel of the tile (perspective): |ray| / (ray · f) with the ray from the eye
        // through the pixel centre on the plane through C at distance 3R.
        let sec: Vec<f64> = if self.persp {
            let d = 3.0 * self.camera.radius;
            (0..ts * ts)
                .map(|k| {
                    let (x, y) = self.camera.plane_xy(
                        (x0 + (k % ts) as i64) as f64 + 0.5,
                        (y0 + (k / ts) as i64) as f64 + 0.5,
                    );
                    (x * x + y * y + d * d).sqrt() / d
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut frags = 0u64;
        for &i in bin {
            frags += self.draw_tet(i as usize, clip, buf, &sec);
        }
        frags
    }

    /// Rasterises the tet at place `i` of the part into the tile buffer (origin clip[0],
    /// clip[1]).
    #[inline]
    fn draw_tet(&self, i: usize, clip: [i64; 4], buf: &mut [[f32; 4]], sec: &[f64]) -> u64 {
        let tet = self.tets[self.part[i] as usize];
        let th = &self.rec[i].thick;
        let q = tet.map(|v| {
            let p = self.verts[v as usize].q;
            [p[0] as i64, p[1] as i64]
        });
        let g = FanGeometry::new(q, th);
        let case = g.case;
        // Attributes at the thick vertex (index 4) and at the four vertices (thin: l = 0).
        // Ortho: (s_f, s_b, l). Persp: (1/z_f, 1/z_b, 1/z_f − 1/z_b, s_f/z_f, s_b/z_b).
        let mut attr = [[0.0f64; 5]; 5];
        if self.persp {
            let (qf, qb) = (1.0 / th.zf, 1.0 / th.zb);
            let dq = ((th.zb - th.zf) * qf * qb).max(0.0);
            attr[4] = [qf, qb, dq, th.sf * qf, th.sb * qb];
            for k in 0..4 {
                let v = tet[k] as usize;
                let qz = 1.0 / self.verts[v].z;
                let s = self.s[v] as f64 * qz;
                attr[k] = [qz, qz, 0.0, s, s];
            }
        } else {
            attr[4] = [th.sf, th.sb, th.l, 0.0, 0.0];
            for k in 0..4 {
                let s = self.s[tet[k] as usize] as f64;
                attr[k] = [s, s, 0.0, 0.0, 0.0];
            }
        }
        let ts = TILE as i64;
        let mut n = 0u64;
        // Per fan triangle, the attribute differences of its two silhouette vertices from the
        // thick vertex.
        let mut diff = [[[0.0f64; 5]; 2]; 4];
        for (tri, d) in diff.iter_mut().enumerate().take(case.ntri as usize) {
            for (e, v) in d.iter_mut().zip([case.fan[tri], case.fan[tri + 1]]) {
                for c in 0..5 {
                    e[c] = attr[v as usize][c] - attr[4][c];
                }
            }
        }
        // The unsnapped projection: the segment comes from the two faces over each fan
        // triangle there (crate::render::pt::faces), the snapped interpolation is the fallback for a
        // centre outside a true face or a face edge-on in f64.
        let fv: [FaceVertex; 4] = std::array::from_fn(|k| {
            let v = tet[k] as usize;
            let p = self.pos[v];
            let (x, y, z) = self
                .camera
                .project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            FaceVertex {
                x,
                y,
                z,
                s: self.s[v] as f64,
            }
        });
        raster_fan(&g, clip, |f| {
            let k = ((f.j - clip[1]) * ts + (f.i - clip[0])) as usize;
            let centre = [f.i as f64 + 0.5, f.j as f64 + 0.5];
            let (sf, sb, l) = if let Some(seg) = fan_segment(&fv, case, f.tri, centre, self.persp)
            {
                let sec = if self.persp { sec[k] } else { 1.0 };
                (seg.sf, seg.sb, (seg.zb - seg.zf) * sec * self.inv_l)
            } else {
                let [dx, dy] = &diff[f.tri];
                let a = |c: usize| attr[4][c] + f.lx * dx[c] + f.ly * dy[c];
                if self.persp {
                    let (qf, qb) = (a(0), a(1));
                    let l = a(2) / (qf * qb) * sec[k] * self.inv_l;
                    (a(3) / qf, a(4) / qb, l)
                } else {
                    (a(0), a(1), a(2))
                }
            };
            n += 1;
            if l <= 0.0 {
                return;
            }
            let seg = self.integ.shade(sf, sb, l);
            // Back-to-front "over" (premultiplied): I ← I_seg + (1 − α_seg)·I.
            let p = &mut buf[k];
            let keep = 1.0 - seg[3];
            p[0] = seg[0] + keep * p[0];
            p[1] = seg[1] + keep * p[1];
            p[2] = seg[2] + keep * p[2];
            p[3] = seg[3] + keep * p[3];
        });
        n
    }
}

