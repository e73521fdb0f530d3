//! `cpu-pt`: projected tetrahedra on the CPU (Shirley & Tuchman 1990, with PTINT's
//! classification, Maximo et al. 2008, and HAPT's per-fragment integration, Maximo et al. 2010).
//!
//! Per frame:
//! 1. **project** — every vertex to snapped pixel coordinates and depth; every tet classified by
//!    the ternary truth table of [`crate::pt`] (thick vertex, `s_f`, `s_b`, `l`, fan);
//! 2. **sort** — the visibility order, back to front (farthest first);
//! 3. **draw** — the drawn tets are binned to 64×64-pixel tiles in sorted order; tiles are
//!    rendered in parallel (rayon), each compositing its tets in that order into its own f32
//!    RGBA buffer, so the result is the same as one sequential back-to-front pass. Per fragment,
//!    (`s_f`, `s_b`, `l`) are interpolated over the fan triangle (thick vertex: its values; the
//!    silhouette vertices: `s_f = s_b = s_v`, `l = 0`), the integrator gives the premultiplied
//!    segment and it is composited "over": `I ← I_seg + (1 − α_seg)·I` (CONVENTIONS §4).
//!
//! **Interpolation.** In ortho, the ray through a fan triangle enters and leaves the tet through
//! the same two faces everywhere in it, so for a field linear in the tet `s_f`, `s_b` and `l` are
//! linear in screen space: barycentric interpolation is exact. In perspective the projected edges
//! are still straight and the fan still tiles the faces, but the depths are hyperbolic: the
//! interpolated quantities are `1/z_f`, `1/z_b`, `1/z_f − 1/z_b`, `s_f/z_f`, `s_b/z_b` (linear in
//! screen space, z the depth along the view axis), from which `s_f`, `s_b` and
//! `l = (z_b − z_f)·sec θ / L`, `z_b − z_f = (1/z_f − 1/z_b)/(1/z_f · 1/z_b)` (no cancellation), with
//! `sec θ = |ray| / (ray · f)` per pixel. So perspective is exact too, up to rounding.
//! That is exact for the snapped vertices; the f64 path (`exact`, and perspective) takes each
//! fragment's segment from the two faces over its fan triangle on the unsnapped projection
//! instead ([`crate::pt::fan_segment`]), exact for the true tet even where a face is nearly
//! edge-on and the snapping error, times the thickness gradient, would be ~1 % of `l`.
//!
//! **Memory.** `prepare` keeps the centred f32 positions and the f32 transfer-function
//! coordinate per vertex (16 bytes a vertex) and the integrator's tables. The per-frame scratch
//! (16 bytes a vertex, 72 a tet, 4 a tet for the order, 4 per tet-tile pair for the bins) is
//! allocated on the first frame and reused; its size is the `scratch_bytes` counter.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

mod bins;
mod fast;

use self::bins::Bins;
use self::fast::FastRec;
use super::{ms_since, Family, Frame, FrameTimes, Renderer, RendererInfo};
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::optics::{integrator, Integrator, INTEGRATORS};
use crate::optics_f32::FastIntegrator;
use crate::pt::{
    classify, fan_segment, raster_fan, snap, FaceVertex, FanGeometry, ProjVertex, Thick, TABLE,
};
use crate::sort::{Sort, SortStats};
use crate::tf::TransferFunction;

/// Registry entry for `cpu-pt` (`partial` and `centroid` by default).
pub static CPU_PT: RendererInfo = RendererInfo {
    name: "cpu-pt",
    description: "CPU projected tetrahedra: PTINT classification, fans rasterised in 64x64 tiles \
                  (rayon), composited back to front",
    sorts: crate::sort::SORTS,
    integrators: &INTEGRATORS,
    family: Family::Pt,
    needs_gpu: false,
    default_sort: "centroid",
    table_sorts: &["*"],
    default_integrator: "partial",
    params: &[],
    make: |o| {
        Ok(Box::new(CpuPt::new(
            o.sort.as_deref().unwrap_or("centroid"),
            o.integrator.as_deref().unwrap_or("partial"),
        )?))
    },
};

/// Tile side in pixels.
pub const TILE: u32 = 64;

pub struct CpuPt {
    /// The registry name this instance reports (`cpu-pt`, or a variant's).
    name: &'static str,
    sort_name: String,
    integrator_name: String,
    state: Option<Prepared>,
    scratch: Scratch,
    sort: Box<dyn Sort>,
    /// The last frame's sort counters.
    sort_stats: SortStats,
    /// Use the f32 fast path of the integrator where there is one (default).
    fast: bool,
}

struct Prepared {
    /// Vertex positions in the frame centred on the bounding box, then f32 (CONVENTIONS §1).
    pos: Vec<[f32; 3]>,
    /// Transfer-function coordinate per vertex.
    s: Vec<f32>,
    integrator: Box<dyn Integrator>,
    /// The f32 fast path of `integrator` (none for `exact`, or when disabled).
    fast: Option<FastIntegrator>,
    /// 1 / L.
    inv_l: f64,
    tets: usize,
}

/// A projected vertex: snapped pixel coordinates and depth along the view axis.
#[derive(Clone, Copy, Default)]
struct VertProj {
    q: [i32; 2],
    z: f64,
}

/// A classified tet (general path).
#[derive(Clone, Copy, Default)]
struct TetProj {
    thick: Thick,
}

/// The tile range of a tet, inclusive (empty, `[1, 1, 0, 0]`, when not drawn).
type TileRect = [u16; 4];
const NO_TILES: TileRect = [1, 1, 0, 0];

#[derive(Default)]
struct Scratch {
    verts: Vec<VertProj>,
    /// General path: the classified tets.
    tets: Vec<TetProj>,
    /// Fast path: one record per tet.
    fast: Vec<FastRec>,
    /// The tile range per tet.
    rects: Vec<TileRect>,
    order: Vec<u32>,
    bins: Bins,
}

impl Scratch {
    fn bytes(&self) -> usize {
        self.verts.capacity() * std::mem::size_of::<VertProj>()
            + self.tets.capacity() * std::mem::size_of::<TetProj>()
            + self.fast.capacity() * std::mem::size_of::<FastRec>()
            + self.rects.capacity() * std::mem::size_of::<TileRect>()
            + self.order.capacity() * 4
            + self.bins.bytes()
    }
}


impl CpuPt {
    /// Reports itself under a variant's registry name.
    pub fn named(mut self, name: &'static str) -> CpuPt {
        self.name = name;
        self
    }

    /// `sort`: any name [`crate::sort::make`] knows (`bucket:N` included).
    pub fn new(sort: &str, integrator: &str) -> Result<CpuPt> {
        let sorter = crate::sort::make(sort)?;
        Ok(CpuPt {
            name: "cpu-pt",
            sort_name: sort.to_string(),
            integrator_name: integrator.to_string(),
            state: None,
            scratch: Scratch::default(),
            sort: sorter,
            sort_stats: SortStats::default(),
            fast: true,
        })
    }

    /// Whether per-fragment integration uses the f32 fast path of [`crate::optics_f32`]
    /// (`average`, `partial`, `preint`; default) or the f64 [`Integrator`] (`exact` always does).
    /// Takes effect at the next `prepare`.
    pub fn set_fast_path(&mut self, on: bool) {
        self.fast = on;
    }

    /// The visibility order, back to front (farthest first), into `order`; returns the number
    /// of cells in visibility cycles (0 but for MPVONC on cyclic configurations).
    fn order(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<usize> {
        self.sort_stats = self.sort.sort(mesh, camera, order)?;
        Ok(self.sort_stats.cells_in_cycles)
    }
}

impl Renderer for CpuPt {
    fn name(&self) -> String {
        self.name.to_string()
    }
    fn sort_name(&self) -> String {
        self.sort_name.clone()
    }
    fn integrator_name(&self) -> String {
        self.integrator_name.clone()
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        self.scratch = Scratch::default();
        let integrator = integrator(&self.integrator_name, tf)?;
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let map = tf.scalar_map(mesh.scalar_range());
        let pos = mesh
            .positions()
            .par_iter()
            .map(|p| (*p - c).as_vec3().to_array())
            .collect();
        let s = mesh
            .scalars()
            .par_iter()
            .map(|&v| map.s(v) as f32)
            .collect();
        let fast = if self.fast {
            FastIntegrator::new(&self.integrator_name, tf)
        } else {
            None
        };
        self.state = Some(Prepared {
            pos,
            s,
            integrator,
            fast,
            inv_l: if l > 0.0 { 1.0 / l } else { 0.0 },
            tets: mesh.num_tets(),
        });
        self.sort.prepare(mesh)?;
        self.sort.set_transfer_function(mesh, tf)?;
        Ok(())
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let t_start = Instant::now();
        let st = self
            .state
            .as_ref()
            .ok_or_else(|| Error::Internal("cpu-pt: render before prepare".into()))?;
        if st.tets != mesh.num_tets() || st.pos.len() != mesh.num_vertices() {
            return Err(Error::Internal(
                "cpu-pt: render with a mesh other than the prepared one".into(),
            ));
        }
        let (w, h) = (camera.width, camera.height);
        if w > 32768 || h > 32768 {
            return Err(Error::Input(format!(
                "cpu-pt: image {w}x{h} too large (at most 32768 per side)"
            )));
        }
        let persp = camera.projection == Projection::Persp;
        // The fast path: ortho with an f32 integrator (see `fast`).
        let fast = st.fast.as_ref().filter(|_| !persp);
        let (ntx, nty) = (w.div_ceil(TILE), h.div_ceil(TILE));

        // 1. Project and classify.
        let t0 = Instant::now();
        let mut sc = std::mem::take(&mut self.scratch);
        st.pos
            .par_iter()
            .map(|p| {
                let (x, y, z) = camera.project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                VertProj {
                    q: [snap(x) as i32, snap(y) as i32],
                    z,
                }
            })
            .collect_into_vec(&mut sc.verts);
        let verts = &sc.verts;
        let classify_tet = |t: &[u32; 4]| {
            let v: [ProjVertex; 4] = std::array::from_fn(|k| {
                let i = t[k] as usize;
                let p = st.pos[i];
                ProjVertex {
                    q: [verts[i].q[0] as i64, verts[i].q[1] as i64],
                    z: verts[i].z,
                    p: DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64),
                    s: st.s[i] as f64,
                }
            });
            let thick = classify(&v, persp, st.inv_l);
            let mut tiles = NO_TILES;
            if TABLE[thick.case as usize].drawn() {
                let g = FanGeometry::new(v.map(|v| v.q), &thick);
                let b = g.pixel_bounds();
                let (i0, j0) = (b[0].max(0), b[1].max(0));
                let (i1, j1) = (b[2].min(w as i64 - 1), b[3].min(h as i64 - 1));
                if i0 <= i1 && j0 <= j1 {
                    let t = TILE as i64;
                    tiles = [
                        (i0 / t) as u16,
                        (j0 / t) as u16,
                        (i1 / t) as u16,
                        (j1 / t) as u16,
                    ];
                }
            }
            (thick, tiles)
        };
        if fast.is_some() {
            sc.tets = Vec::new();
            sc.fast.resize(mesh.num_tets(), FastRec::default());
            sc.rects.resize(mesh.num_tets(), NO_TILES);
            let (fr, rects) = (&mut sc.fast, &mut sc.rects);
            mesh.tets()
                .par_iter()
                .zip(fr.par_iter_mut().zip(rects.par_iter_mut()))
                .for_each(|(t, (f, r))| {
                    let (th, tiles) = classify_tet(t);
                    *r = tiles;
                    *f = FastRec {
                        q: t.map(|v| verts[v as usize].q),
                        s: t.map(|v| st.s[v as usize]),
                        sf: th.sf as f32,
                        sb: th.sb as f32,
                        l: th.l as f32,
                        case: th.case,
                    };
                });
        } else {
            sc.fast = Vec::new();
            sc.tets.resize(mesh.num_tets(), TetProj::default());
            sc.rects.resize(mesh.num_tets(), NO_TILES);
            let (tp, rects) = (&mut sc.tets, &mut sc.rects);
            mesh.tets()
                .par_iter()
                .zip(tp.par_iter_mut().zip(rects.par_iter_mut()))
                .for_each(|(t, (p, r))| {
                    let (thick, tiles) = classify_tet(t);
                    *r = tiles;
                    *p = TetProj { thick };
                });
        }
        let project_ms = ms_since(t0);

        // 2. Sort.
        let t1 = Instant::now();
        let mut order = std::mem::take(&mut sc.order);
        self.scratch = sc;
        let cycles = self.order(mesh, camera, &mut order)?;
        let mut sc = std::mem::take(&mut self.scratch);
        sc.order = order;
        let sort_ms = ms_since(t1);
        let st = self.state.as_ref().expect("prepared");
        let fast = st.fast.as_ref().filter(|_| !persp);

        // 3. Draw: bin in sorted order, then render the tiles in parallel.
        let t2 = Instant::now();
        let ntiles = (ntx * nty) as usize;
        let mut bins = std::mem::take(&mut sc.bins);
        bins.build(&sc.order, &sc.rects, ntx as usize, ntiles);
        let bin_ms = ms_since(t2);
        let drawn = if fast.is_some() {
            sc.fast
                .iter()
                .filter(|f| TABLE[f.case as usize].drawn())
                .count()
        } else {
            sc.tets
                .iter()
                .filter(|t| TABLE[t.thick.case as usize].drawn())
                .count()
        };
        let pairs = bins.items.len();
        let tiles: Vec<(Vec<[f32; 4]>, u64)> = match (fast, &st.fast) {
            (Some(integ), _) => (0..ntiles)
                .into_par_iter()
                .map(|k| {
                    let t = (k as u32 % ntx, k as u32 / ntx);
                    fast::draw_tile(&sc.fast, bins.tile(k), integ, t, (w, h))
                })
                .collect(),
            (None, Some(integ)) => draw_tiles(
                DrawCtx {
                    tets: mesh.tets(),
                    pos: &st.pos,
                    verts: &sc.verts,
                    rec: &sc.tets,
                    s: &st.s,
                    integ,
                    camera,
                    persp,
                    inv_l: st.inv_l,
                },
                &bins,
                ntx,
                ntiles,
            ),
            (None, None) => draw_tiles(
                DrawCtx {
                    tets: mesh.tets(),
                    pos: &st.pos,
                    verts: &sc.verts,
                    rec: &sc.tets,
                    s: &st.s,
                    integ: st.integrator.as_ref(),
                    camera,
                    persp,
                    inv_l: st.inv_l,
                },
                &bins,
                ntx,
                ntiles,
            ),
        };
        sc.bins = bins;
        let mut image = Image::new(w, h);
        let mut fragments = 0u64;
        for (k, (buf, nf)) in tiles.iter().enumerate() {
            fragments += nf;
            let (x0, y0) = ((k as u32 % ntx) * TILE, (k as u32 / ntx) * TILE);
            let tw = TILE.min(w - x0) as usize;
            for (r, row) in buf.chunks(TILE as usize).enumerate() {
                let y = y0 as usize + r;
                if y >= h as usize {
                    break;
                }
                let o = y * w as usize + x0 as usize;
                image.pixels[o..o + tw].copy_from_slice(&row[..tw]);
            }
        }
        let draw_ms = ms_since(t2);
        let scratch_bytes = sc.bytes();
        let skipped = mesh.num_tets() - sc.order.len();
        self.scratch = sc;
        Ok(Frame {
            image,
            times: FrameTimes {
                project_ms,
                sort_ms,
                draw_ms,
                readback_ms: 0.0,
                total_ms: ms_since(t_start),
            },
            counters: vec![
                ("tets_drawn", drawn as f64),
                ("tets_discarded", (mesh.num_tets() - drawn) as f64),
                // Left out of the order by a skipping sort (transparent under the TF).
                ("tets_skipped", skipped as f64),
                ("fragments", fragments as f64),
                ("tet_tile_pairs", pairs as f64),
                ("bin_ms", bin_ms),
                ("sort_cycles", self.sort_stats.cycles as f64),
                ("sort_cells_in_cycles", cycles as f64),
                ("sort_forced", self.sort_stats.forced as f64),
                ("scratch_bytes", scratch_bytes as f64),
            ],
        })
    }
}

/// Per-fragment integration: premultiplied `[r, g, b, α]` of a segment.
trait Shade: Sync {
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

/// Renders every tile in parallel (monomorphised per [`Shade`]).
fn draw_tiles<S: Shade>(
    ctx: DrawCtx<'_, S>,
    bins: &Bins,
    ntx: u32,
    ntiles: usize,
) -> Vec<(Vec<[f32; 4]>, u64)> {
    (0..ntiles)
        .into_par_iter()
        .map(|k| {
            let (tx, ty) = (k as u32 % ntx, k as u32 / ntx);
            ctx.draw_tile(tx, ty, bins.tile(k))
        })
        .collect()
}

struct DrawCtx<'a, S> {
    tets: &'a [[u32; 4]],
    /// Centred positions, for the unsnapped projection of [`fan_segment`].
    pos: &'a [[f32; 3]],
    verts: &'a [VertProj],
    rec: &'a [TetProj],
    s: &'a [f32],
    integ: S,
    camera: &'a Camera,
    persp: bool,
    inv_l: f64,
}

impl<S: Shade> DrawCtx<'_, S> {
    /// Renders tile (tx, ty) from its bins (in order); returns the tile's RGBA rows (TILE wide)
    /// and its fragment count.
    fn draw_tile(&self, tx: u32, ty: u32, bin: &[u32]) -> (Vec<[f32; 4]>, u64) {
        let ts = TILE as usize;
        let mut buf = vec![[0.0f32; 4]; ts * ts];
        let (x0, y0) = ((tx * TILE) as i64, (ty * TILE) as i64);
        let clip = [
            x0,
            y0,
            (x0 + TILE as i64 - 1).min(self.camera.width as i64 - 1),
            (y0 + TILE as i64 - 1).min(self.camera.height as i64 - 1),
        ];
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
        for &t in bin {
            frags += self.draw_tet(t as usize, clip, &mut buf, &sec);
        }
        (buf, frags)
    }

    /// Rasterises one tet into the tile buffer (origin clip[0], clip[1]).
    #[inline]
    fn draw_tet(&self, t: usize, clip: [i64; 4], buf: &mut [[f32; 4]], sec: &[f64]) -> u64 {
        let tet = self.tets[t];
        let th = &self.rec[t].thick;
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
        // triangle there (crate::pt::faces), the snapped interpolation is the fallback for a
        // face edge-on in f64.
        let fv: [FaceVertex; 4] = std::array::from_fn(|k| {
            let v = tet[k] as usize;
            let p = self.pos[v];
            let (x, y, z) =
                self.camera.project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::View;
    use crate::metrics::compare;
    use crate::render::raycast::RayCaster;
    use crate::tf::TfPoint;

    /// A box grid of n[0]×n[1]×n[2] cubes, 6 tets per cube (Kuhn, the readers' structured
    /// split); scalar from `f`.
    pub(crate) fn kuhn_grid(n: [usize; 3], lo: DVec3, hi: DVec3, f: impl Fn(DVec3) -> f64) -> Mesh {
        let dims = n.map(|c| c + 1);
        let mut pos = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let t = DVec3::new(i as f64, j as f64, k as f64)
                        / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                    pos.push(lo + (hi - lo) * t);
                }
            }
        }
        let tets = crate::io::split::split_structured("grid", dims, &pos, crate::io::Split::Six)
            .unwrap();
        let s = pos.iter().map(|p| f(*p)).collect();
        Mesh::with_scalars("grid", pos, tets, "s", s).unwrap()
    }

    fn tf(points: &[(f64, [f64; 3], f64)]) -> TransferFunction {
        TransferFunction {
            name: "test".into(),
            range: Some([0.0, 1.0]),
            points: points
                .iter()
                .map(|&(s, rgb, tau)| TfPoint { s, rgb, tau })
                .collect(),
        }
    }

    fn smooth_tf() -> TransferFunction {
        tf(&[
            (0.0, [0.1, 0.2, 0.9], 0.5),
            (0.4, [0.2, 0.9, 0.3], 4.0),
            (0.7, [1.0, 0.6, 0.1], 1.0),
            (1.0, [1.0, 1.0, 1.0], 6.0),
        ])
    }

    fn smooth_grid() -> Mesh {
        // 12×10×11 cubes = 7920 tets; a smooth field spanning [0, 1].
        kuhn_grid(
            [12, 10, 11],
            DVec3::new(-1.0, -0.8, -0.9),
            DVec3::new(1.2, 0.9, 1.0),
            |p| 0.5 + 0.3 * (2.0 * p.x).sin() * (1.5 * p.y).cos() + 0.2 * p.z,
        )
    }

    fn reference(mesh: &Mesh, tf: &TransferFunction, cam: &Camera) -> Image {
        let mut rc = RayCaster::new("exact", "reference");
        rc.prepare(mesh, tf).unwrap();
        rc.render(mesh, cam).unwrap().image
    }

    fn pt(mesh: &Mesh, tf: &TransferFunction, cam: &Camera, integ: &str) -> Frame {
        pt_sorted(mesh, tf, cam, integ, false)
    }

    fn pt_sorted(
        mesh: &Mesh,
        tf: &TransferFunction,
        cam: &Camera,
        integ: &str,
        topological: bool,
    ) -> Frame {
        let sort = if topological { "mpvonc" } else { "centroid" };
        let mut r = CpuPt::new(sort, integ).unwrap();
        r.prepare(mesh, tf).unwrap();
        let f = r.render(mesh, cam).unwrap();
        assert_eq!(f.image.non_finite_pixels(), 0);
        f
    }

    const VIEWS: [(f64, f64); 3] = [(30.0, 20.0), (-70.0, 35.0), (145.0, -50.0)];

    /// `exact` against `reference` with the centroid order and with MPVONC's order (exact on
    /// this convex mesh); both within 1e-4 RMSE on this grid and these views.
    fn exact_against_reference(proj: Projection) {
        let mesh = smooth_grid();
        let tf = smooth_tf();
        for (a, e) in VIEWS {
            let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, 96, 80);
            let r = reference(&mesh, &tf, &cam);
            for topo in [false, true] {
                let f = pt_sorted(&mesh, &tf, &cam, "exact", topo);
                let err = compare(&f.image, &r).unwrap();
                let c = |n: &str| f.counters.iter().find(|x| x.0 == n).unwrap().1;
                eprintln!(
                    "{} view ({a}, {e}) {}: rmse {:.3e} max {:.3e} cycles {}",
                    proj.name(),
                    if topo { "mpvonc" } else { "centroid" },
                    err.rmse,
                    err.max_abs,
                    c("sort_cycles")
                );
                assert!(err.rmse <= 1e-4, "view ({a}, {e}): {err:?}");
                assert_eq!(
                    c("tets_drawn") + c("tets_discarded"),
                    mesh.num_tets() as f64
                );
                assert!(c("fragments") > 0.0);
                if topo {
                    assert_eq!(c("sort_cycles"), 0.0);
                    assert!(err.max_abs < 1e-4, "view ({a}, {e}): {err:?}");
                }
            }
        }
    }

    #[test]
    fn exact_matches_reference_in_ortho() {
        exact_against_reference(Projection::Ortho);
    }

    #[test]
    fn exact_matches_reference_in_perspective() {
        exact_against_reference(Projection::Persp);
    }

    /// RMSE of every integrator against `reference`, ortho and persp (run with --nocapture to
    /// see the figures).
    #[test]
    fn integrators_against_reference() {
        let mesh = smooth_grid();
        let tf = smooth_tf();
        for proj in [Projection::Ortho, Projection::Persp] {
            let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), proj, 96, 80);
            let r = reference(&mesh, &tf, &cam);
            for integ in INTEGRATORS {
                let err = compare(&pt_sorted(&mesh, &tf, &cam, integ, true).image, &r).unwrap();
                eprintln!(
                    "{} {integ}: rmse {:.3e} max {:.3e}",
                    proj.name(),
                    err.rmse,
                    err.max_abs
                );
                // Loose bounds that still catch a broken integrator or interpolation.
                assert!(err.rmse < 2e-2, "{integ} {proj:?}: {err:?}");
            }
        }
    }

    /// The f32 fast paths (`average`, `partial`, `preint`) against the f64 integrators behind
    /// `dyn Integrator`, same mesh, views and order: RMSE ≤ 1e-5 and max ≤ 2e-4 per image
    /// (measured: RMSE ≤ 5e-7, max ≤ 4e-5; the TF table is exact but within 1/4095 of the s
    /// range of a control point).
    #[test]
    fn fast_path_matches_f64_path() {
        let mesh = smooth_grid();
        let tf = smooth_tf();
        for proj in [Projection::Ortho, Projection::Persp] {
            for (a, e) in VIEWS {
                let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, 96, 80);
                for integ in ["average", "partial", "preint"] {
                    let img = |fast: bool| {
                        let mut r = CpuPt::new("centroid", integ).unwrap();
                        r.set_fast_path(fast);
                        r.prepare(&mesh, &tf).unwrap();
                        assert_eq!(r.state.as_ref().unwrap().fast.is_some(), fast);
                        r.render(&mesh, &cam).unwrap().image
                    };
                    let (f, d) = (img(true), img(false));
                    let err = compare(&f, &d).unwrap();
                    eprintln!(
                        "{} ({a}, {e}) {integ}: fast vs f64 rmse {:.3e} max {:.3e}",
                        proj.name(),
                        err.rmse,
                        err.max_abs
                    );
                    assert!(err.rmse <= 1e-5 && err.max_abs <= 2e-4, "{integ}: {err:?}");
                    assert!(f.pixels.iter().any(|p| p[3] > 0.1));
                }
            }
        }
    }

    /// An axis-aligned grid seen along −z (view (0, 0)) with sizes such that the grid lines fall
    /// on pixel centres (x) or pixel boundaries (y) and the other way round: every tet projects to
    /// class 3 or 4, faces and edges are parallel to the view axis, and a crack or a double blend
    /// at any shared edge would show as a wrong pixel. Constant τ and colour.
    #[test]
    fn no_cracks_on_an_axis_aligned_grid_at_view_0_0() {
        // Box 4 × 4 × 7: L = 9, so with min(W, H) = 36 a pixel is 1/4 unit and grid steps of
        // 1/2 unit are 2 px.
        let mesh = kuhn_grid(
            [8, 8, 7],
            DVec3::new(-2.0, -2.0, -3.5),
            DVec3::new(2.0, 2.0, 3.5),
            |p| 0.5 + 0.05 * p.x,
        );
        let tf = tf(&[(0.0, [0.8, 0.5, 0.2], 0.6), (1.0, [0.8, 0.5, 0.2], 0.6)]);
        for (w, h) in [(37, 36), (36, 37), (36, 36), (40, 36)] {
            let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, w, h);
            let f = pt(&mesh, &tf, &cam, "exact");
            let r = reference(&mesh, &tf, &cam);
            for (k, (a, b)) in f.image.pixels.iter().zip(&r.pixels).enumerate() {
                for c in 0..4 {
                    assert!(
                        (a[c] - b[c]).abs() < 1e-5,
                        "{w}x{h} pixel ({}, {}): {a:?} vs reference {b:?}",
                        k % w as usize,
                        k / w as usize
                    );
                }
            }
            let c = |n: &str| f.counters.iter().find(|x| x.0 == n).unwrap().1;
            assert_eq!(c("tets_discarded"), 0.0);
        }
    }

    /// One tet whose fan edges (class 1 and class 2) run through many pixel centres, with the
    /// thick vertex on a centre: per-pixel agreement with the reference (no crack, no double
    /// blend inside the fan).
    #[test]
    fn single_fans_with_edges_through_pixel_centres() {
        let tf = tf(&[(0.0, [0.3, 0.6, 0.9], 2.0), (1.0, [0.3, 0.6, 0.9], 2.0)]);
        // The bounding box is [-4, 4]³ (two far corners padded by a zero-volume tet would change
        // nothing); here the tets span it themselves. L = 8√3, 32 px: p = L/32.
        let z = |v: f64| v;
        let cases: [[DVec3; 4]; 2] = [
            // Class 1 at view (0, 0): (0, 0) inside the triangle.
            [
                DVec3::new(-4.0, -4.0, z(-4.0)),
                DVec3::new(4.0, -4.0, z(1.0)),
                DVec3::new(0.0, 4.0, z(-2.0)),
                DVec3::new(0.0, 0.0, z(4.0)),
            ],
            // Class 2: diagonals of a square cross at the centre.
            [
                DVec3::new(-4.0, -4.0, -4.0),
                DVec3::new(4.0, 4.0, -4.0),
                DVec3::new(-4.0, 4.0, 4.0),
                DVec3::new(4.0, -4.0, 4.0),
            ],
        ];
        for p in cases {
            let mesh = Mesh::with_scalars("fan", p.to_vec(), vec![[0, 1, 2, 3]], "s", vec![0.5; 4])
                .unwrap();
            for (w, h) in [(32, 32), (33, 33), (31, 32)] {
                let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, w, h);
                let f = pt(&mesh, &tf, &cam, "exact");
                let r = reference(&mesh, &tf, &cam);
                for (k, (a, b)) in f.image.pixels.iter().zip(&r.pixels).enumerate() {
                    assert!(
                        (a[3] - b[3]).abs() < 1e-5,
                        "{w}x{h} pixel {k}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn degenerate_tets_render_finite() {
        let v = DVec3::new;
        let pos = vec![
            v(0., 0., 0.),
            v(1., 0., 0.),
            v(0., 1., 0.),
            v(0., 0., 1.),
            v(1., 1., 0.),      // 4: coplanar with 0, 1, 2 (flat tet)
            v(0.5, 0.5, 1e-9),  // 5: sliver apex
            v(1e-9, 1e-9, 1.0), // 6: needle tip near 3
            v(1., 1., 1.),
        ];
        let tets = vec![
            [0, 1, 2, 3], // regular
            [0, 2, 1, 3], // negative orientation
            [0, 1, 2, 4], // flat
            [0, 1, 2, 5], // sliver
            [0, 3, 6, 1], // needle
            [0, 0, 1, 2], // duplicate vertex
            [7, 7, 7, 7], // a point
            [1, 2, 4, 7],
        ];
        let s: Vec<f64> = (0..pos.len()).map(|i| i as f64 / 7.0).collect();
        let mesh = Mesh::with_scalars("degenerate", pos, tets, "s", s).unwrap();
        let tf = smooth_tf();
        for integ in INTEGRATORS {
            for (a, e) in [
                (0.0, 0.0),
                (90.0, 0.0),
                (0.0, 90.0),
                (45.0, 35.264389682754654),
                (30.0, 20.0),
            ] {
                for proj in [Projection::Ortho, Projection::Persp] {
                    let cam = Camera::new(&mesh.bbox(), View::new(a, e), proj, 48, 40);
                    let f = pt(&mesh, &tf, &cam, integ);
                    assert!(f
                        .image
                        .pixels
                        .iter()
                        .flatten()
                        .all(|c| (0.0..=1.0 + 1e-6).contains(c)));
                }
            }
        }
    }

    /// Process CPU time (user + system) in seconds from /proc/self/stat (None elsewhere): on
    /// a shared machine, CPU time per frame is steadier than wall time.
    fn cpu_seconds() -> Option<f64> {
        let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
        Some(ticks / 100.0)
    }

    /// Throughput at 512² on a ~511K-tet grid with the stage split, for `partial` and `average`
    /// on the f32 fast path and on the f64 `dyn Integrator` path (`-f64`):
    /// `cargo test --release -p tetbench-algorithms --lib cpu_pt_throughput -- --ignored --nocapture`.
    /// Besides wall time it prints tets per CPU-second over the measured frames.
    #[test]
    #[ignore]
    fn cpu_pt_throughput() {
        let mesh = kuhn_grid([44, 44, 44], DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
            0.5 + 0.3 * (2.0 * p.x).sin() * (1.5 * p.y).cos() + 0.2 * p.z
        });
        let tf = smooth_tf();
        let cam = Camera::new(
            &mesh.bbox(),
            View::new(30.0, 20.0),
            Projection::Ortho,
            512,
            512,
        );
        for (integ, fast) in [
            ("partial", true),
            ("partial", false),
            ("average", true),
            ("average", false),
        ] {
            let mut r = CpuPt::new("centroid", integ).unwrap();
            r.set_fast_path(fast);
            r.prepare(&mesh, &tf).unwrap();
            // The counting allocator is not installed in unit tests: the prepared vectors.
            let bytes = r
                .state
                .as_ref()
                .map_or(0, |s| s.pos.capacity() * 12 + s.s.capacity() * 4);
            r.render(&mesh, &cam).unwrap();
            let cpu0 = cpu_seconds();
            let mut frames: Vec<Frame> = (0..5).map(|_| r.render(&mesh, &cam).unwrap()).collect();
            let cpu = cpu_seconds().zip(cpu0).map_or(f64::NAN, |(a, b)| a - b);
            frames.sort_by(|a, b| a.times.total_ms.total_cmp(&b.times.total_ms));
            let f = &frames[frames.len() / 2];
            let t = f.times;
            eprintln!(
                "{integ}{}: {} tets, {} threads: total {:.1} ms (project {:.1}, sort {:.1}, draw {:.1}) \
                 = {:.2} M tet/s, {:.2} M tet per CPU-s; prepare bytes {bytes} ({:.1}/tet); {:?}",
                if fast { "" } else { "-f64" },
                mesh.num_tets(),
                rayon::current_num_threads(),
                t.total_ms,
                t.project_ms,
                t.sort_ms,
                t.draw_ms,
                mesh.num_tets() as f64 / t.total_ms / 1e3,
                5.0 * mesh.num_tets() as f64 / cpu / 1e6,
                bytes as f64 / mesh.num_tets() as f64,
                f.counters
            );
        }
    }

    #[test]
    fn registry_and_sorts() {
        let opts = crate::render::RenderOptions::default();
        let r = crate::render::make("cpu-pt", &opts).unwrap();
        assert_eq!(r.integrator_name(), "partial");
        assert_eq!(r.sort_name(), "centroid");
        for sort in ["mpvonc", "bucket:16", "centroid-radix"] {
            let o = crate::render::RenderOptions {
                sort: Some(sort.into()),
                integrator: None,
                ..Default::default()
            };
            assert_eq!(crate::render::make("cpu-pt", &o).unwrap().sort_name(), sort);
        }
        let bad = crate::render::RenderOptions {
            sort: Some("bubble".into()),
            integrator: None,
            ..Default::default()
        };
        let e = crate::render::make("cpu-pt", &bad).err().unwrap();
        assert!(e.to_string().contains("bubble"), "{e}");
    }
}
