//! `cpu-pt`: projected tetrahedra on the CPU (Shirley & Tuchman 1990, with the classification of
//! PTINT — Marroquim, Maximo, Farias & Esperança, "GPU-Based Cell Projection for Interactive
//! Volume Rendering", SIBGRAPI 2006 — and HAPT's per-fragment integration, Maximo, Marroquim &
//! Farias 2010).
//!
//! Per frame:
//! 1. **sort** — the visibility order, back to front (farthest first), while the rest of the
//!    pool projects every vertex to snapped pixel coordinates and depth;
//! 2. **project** — part after part of the order (a million tets at a time), each tet of the
//!    part classified by the ternary truth table of [`crate::render::pt`] (thick vertex, `s_f`,
//!    `s_b`, `l`, fan) into a record at its place in the part, so that the draw reads a tile's
//!    records in increasing addresses (and tets a skipping sort leaves out are not projected);
//! 3. **draw** — the part's drawn tets are binned to 128×128-pixel tiles in order; tiles are
//!    rendered in parallel (rayon), each compositing its tets in that order over its own f32
//!    RGBA buffer, which holds the parts before. Each pixel meets the same fragments in the
//!    same order as in one sequential back-to-front pass, so the image is the same. Per
//!    fragment, (`s_f`, `s_b`, `l`) are interpolated over the fan triangle (thick vertex: its
//!    values; the silhouette vertices: `s_f = s_b = s_v`, `l = 0`), the integrator gives the
//!    premultiplied segment and it is composited "over": `I ← I_seg + (1 − α_seg)·I`
//!    (CONVENTIONS §4).
//!
//! The sort runs on one thread while the pool projects the vertices, which need no order. So
//! `sort_ms` is the sort's own time and `project_ms` the project stage's wall time beyond it
//! plus the parts' classification: the three stages still add up to the frame.
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
//! instead ([`crate::render::pt::fan_segment`]), exact for the true tet even where a face is nearly
//! edge-on and the snapping error, times the thickness gradient, would be ~1 % of `l`.
//!
//! **Memory.** `prepare` keeps the centred f32 positions and the f32 transfer-function
//! coordinate per vertex (16 bytes a vertex) and the integrator's tables. The per-frame scratch
//! (32 bytes a vertex, 4 a tet for the order, and for one part of it 72 bytes a tet and 4 per
//! tet-tile pair for the bins, plus one buffer per tile) is allocated on the first frame and
//! reused; its size is the `scratch_bytes` counter. Only the order grows with the mesh.

use std::time::Instant;

use rayon::prelude::*;

mod bins;
mod composite;
mod fast;
mod general;
mod project;
mod queue;
#[cfg(test)]
mod tests;

use self::bins::Bins;
use self::fast::FastRec;
use self::general::{draw_tiles, DrawCtx};
use self::project::{TetProj, TileRect, VertProj};
use super::{ms_since, Description, Family, Frame, FrameTimes, Renderer, RendererInfo};
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::optics::{integrator, Integrator, INTEGRATORS};
use crate::optics::fast::FastIntegrator;
use crate::sort::{Sort, SortStats};
use crate::tf::TransferFunction;

/// Registry entry for `cpu-pt` (`partial` and `centroid` by default).
pub static CPU_PT: RendererInfo = RendererInfo {
    name: "cpu-pt",
    description: "CPU projected tetrahedra: PTINT classification, fans rasterised in 128x128 tiles \
                  (rayon), composited back to front",
    sorts: crate::sort::SORTS,
    integrators: &INTEGRATORS,
    family: Family::Pt,
    needs_gpu: false,
    default_sort: "centroid",
    table_sorts: &["*"],
    default_integrator: "partial",
    params: &[],
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 4.0e-3), ("partial", 4.6e-3), ("preint", 2.8e-3), ("exact", 2.8e-3)],
    make: |_, o| {
        Ok(Box::new(CpuPt::new(
            o.sort.as_deref().unwrap_or("centroid"),
            o.integrator.as_deref().unwrap_or("partial"),
        )?))
    },
};

/// Tile side in pixels.
pub const TILE: u32 = 128;

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
    /// Tets of the order classified and drawn at a time ([`PART`]; smaller in tests).
    part: usize,
}

/// The integrator, held once: its f32 fast path where it has one (and it is enabled), which
/// then shades every fragment, else the f64 integrator.
enum Shading {
    F32(FastIntegrator),
    F64(Box<dyn Integrator>),
}

impl Shading {
    fn f32(&self) -> Option<&FastIntegrator> {
        match self {
            Shading::F32(f) => Some(f),
            Shading::F64(_) => None,
        }
    }
}

struct Prepared {
    /// Vertex positions in the frame centred on the bounding box, then f32 (CONVENTIONS §1).
    pos: Vec<[f32; 3]>,
    /// Transfer-function coordinate per vertex.
    s: Vec<f32>,
    shading: Shading,
    /// 1 / L.
    inv_l: f64,
    tets: usize,
}

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
    /// One RGBA buffer per tile (TILE² pixels), composited part after part.
    tiles: Vec<Vec<[f32; 4]>>,
}

impl Scratch {
    fn bytes(&self) -> usize {
        self.verts.capacity() * std::mem::size_of::<VertProj>()
            + self.tets.capacity() * std::mem::size_of::<TetProj>()
            + self.fast.capacity() * std::mem::size_of::<FastRec>()
            + self.rects.capacity() * std::mem::size_of::<TileRect>()
            + self.order.capacity() * 4
            + self.bins.bytes()
            + self.tiles.iter().map(|t| t.capacity() * 16).sum::<usize>()
    }
}

/// Tets of the visibility order classified and drawn at a time (see `render`): their records
/// and tile ranges, 72 bytes a tet on the fast path, are the part of the frame's scratch that
/// does not grow with the mesh.
const PART: usize = 1 << 20;

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
            part: PART,
        })
    }

    /// Whether per-fragment integration uses the f32 fast path of [`crate::optics::fast`]
    /// (`average`, `partial`, `preint`; default) or the f64 [`Integrator`] (`exact` always does).
    /// Takes effect at the next `prepare`.
    pub fn set_fast_path(&mut self, on: bool) {
        self.fast = on;
    }
}

impl Renderer for CpuPt {
    fn describe(&self) -> Description {
        Description::cpu(self.name, &self.sort_name, &self.integrator_name)
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        self.scratch = Scratch::default();
        let fast = self.fast.then(|| FastIntegrator::new(&self.integrator_name, tf));
        let shading = match fast.flatten() {
            Some(f) => Shading::F32(f),
            None => Shading::F64(integrator(&self.integrator_name, tf)?),
        };
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
        self.state = Some(Prepared {
            pos,
            s,
            shading,
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
        let fast = st.shading.f32().filter(|_| !persp);
        let (ntx, nty) = (w.div_ceil(TILE), h.div_ceil(TILE));

        // 1. Project the vertices and 2. sort: the sort runs on this thread while the pool
        // projects the vertices beside it. `sort_ms` is the sort's own time and `project_ms`
        // the project stage's wall time beyond it, so the stages still add up to the frame.
        let mut sc = std::mem::take(&mut self.scratch);
        let mut order = std::mem::take(&mut sc.order);
        let sorter = &mut self.sort;
        let t1 = Instant::now();
        let ((sorted, sort_ms), ()) = rayon::join(
            || {
                let t = Instant::now();
                let sorted = sorter.sort(mesh, camera, &mut order);
                (sorted, ms_since(t))
            },
            || project::project_verts(st, camera, &mut sc.verts),
        );
        let mut project_ms = (ms_since(t1) - sort_ms).max(0.0);
        self.sort_stats = match sorted {
            Ok(stats) => stats,
            Err(e) => {
                sc.order = order;
                self.scratch = sc;
                return Err(e);
            }
        };
        let cycles = self.sort_stats.cells_in_cycles;

        // Then, part after part of the order (back to front), 1. classify its tets into
        // records at their places in the part, and 3. draw: bin the part's records to tiles in
        // order and composite each tile's over what its buffer holds from the parts before.
        // Each pixel sees the same fragments in the same order as in one pass over all tets,
        // so the image is the same; only one part's records are held at a time.
        let ntiles = (ntx * nty) as usize;
        // The image and the tiles' buffers (together the image's size again) must fit, or the
        // frame fails with "out of memory" before any tile is drawn.
        let mut bufs = std::mem::take(&mut sc.tiles);
        bufs.resize_with(ntiles, Vec::new);
        bufs.truncate(ntiles);
        let px = (TILE * TILE) as usize;
        let room = Image::try_new(w, h).and_then(|image| {
            for b in bufs.iter_mut() {
                b.clear();
                crate::util::alloc::try_grow(b, px)?;
            }
            Ok(image)
        });
        let mut image = match room {
            Ok(image) => image,
            Err(e) => {
                sc.order = order;
                sc.tiles = bufs;
                self.scratch = sc;
                return Err(e);
            }
        };
        bufs.par_iter_mut().for_each(|b| b.resize(px, [0.0; 4]));
        let (mut drawn, mut pairs, mut fragments) = (0usize, 0usize, 0u64);
        let (mut draw_ms, mut bin_ms) = (0.0, 0.0);
        let mut bins = std::mem::take(&mut sc.bins);
        for part in order.chunks(self.part) {
            let t0 = Instant::now();
            drawn += project::project(st, mesh, camera, part, fast.is_some(), &mut sc);
            project_ms += ms_since(t0);
            let t2 = Instant::now();
            bins.build(&sc.rects, ntx as usize, ntiles);
            bin_ms += ms_since(t2);
            pairs += bins.items.len();
            fragments += match (fast, &st.shading) {
                (Some(integ), _) => bins.per_tile(&mut bufs, |k, buf| {
                    let t = (k as u32 % ntx, k as u32 / ntx);
                    fast::draw_tile(&sc.fast, bins.tile(k), integ, t, (w, h), buf)
                }),
                (None, Shading::F32(integ)) => draw_tiles(
                    DrawCtx {
                        tets: mesh.tets(),
                        part,
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
                    &mut bufs,
                ),
                (None, Shading::F64(integ)) => draw_tiles(
                    DrawCtx {
                        tets: mesh.tets(),
                        part,
                        pos: &st.pos,
                        verts: &sc.verts,
                        rec: &sc.tets,
                        s: &st.s,
                        integ: integ.as_ref(),
                        camera,
                        persp,
                        inv_l: st.inv_l,
                    },
                    &bins,
                    ntx,
                    &mut bufs,
                ),
            };
            draw_ms += ms_since(t2);
        }
        sc.order = order;
        sc.bins = bins;
        let t3 = Instant::now();
        for (k, buf) in bufs.iter().enumerate() {
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
        sc.tiles = bufs;
        draw_ms += ms_since(t3);
        let scratch_bytes = sc.bytes();
        let (skipped, discarded) = (mesh.num_tets() - sc.order.len(), sc.order.len() - drawn);
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
                ("tets_discarded", discarded as f64),
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
