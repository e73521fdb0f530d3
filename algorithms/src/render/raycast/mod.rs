//! The tetrahedral ray caster: every ray enters the mesh through a boundary face (found in a
//! BVH over the boundary faces), walks from cell to cell through the face adjacency, and
//! re-enters at the next boundary face along the ray where the mesh is not convex
//! (Garrity 1990; Bunyk, Kaufman & Silva 1997). With the `exact` integrator it is `reference`,
//! the yardstick every image error is measured against, and it works in f64 throughout.
//!
//! **Watertightness.** Which face a ray crosses is decided from the signs of the Plücker
//! products of the ray with the face's edges (Platis & Theoharis 2003). Each edge's product is
//! computed once per ray from the edge oriented by global vertex index, so the two cells that
//! share an edge always agree on its sign. A product that is exactly zero (the ray meets the
//! edge's line) gets its sign by Simulation of Simplicity: the ray is shifted by ε·r + ε²·u (r, u
//! the camera's right and up vectors), which decides every edge not parallel to the ray in one
//! consistent way. So a ray through a shared edge or vertex is neither lost nor counted twice.
//! The same products give the barycentric coordinates of the crossing point on the face, from
//! which the depth and scalar are interpolated; the exit of one cell is the entry of the next.

mod bvh;
mod entry;
mod predicate;
mod projected;
mod shade;
mod walk;

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::{
    ms_since, Description, Family, Frame, FrameTimes, RenderOptions, Renderer, RendererInfo,
};
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::{signed_volume6, Mesh, BOUNDARY};
use crate::optics::INTEGRATORS;
use crate::util::schedule::heaviest_first;
use crate::tf::TransferFunction;
use bvh::Bvh;
use predicate::{DirTerms, RayCtx};
use projected::SharedFrame;
use shade::{Shade, Shader};

/// Registry entry for `raycast` (any integrator; `partial` by default).
pub static RAYCAST: RendererInfo = RendererInfo {
    name: "raycast",
    description: "CPU ray caster walking cell to cell through face adjacency (rayon over rows)",
    sorts: &[],
    integrators: &INTEGRATORS,
    family: Family::RayCasting,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "partial",
    params: &[],
    // Measured (worst of the two views) ×1.5; `exact` is the reference's own code.
    max_rmse: &[("average", 2.3e-3), ("partial", 3.3e-3), ("preint", 4.0e-5), ("exact", 1e-9)],
    make: |_, o| {
        Ok(Box::new(RayCaster::new(
            o.integrator.as_deref().unwrap_or("partial"),
            "raycast",
        )))
    },
};

/// Registry entry for `reference`: `raycast` with the `exact` integrator.
pub static REFERENCE: RendererInfo = RendererInfo {
    name: "reference",
    description: "the exact reference: raycast with the exact integrator, f64 throughout",
    sorts: &[],
    integrators: &["exact"],
    family: Family::RayCasting,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "exact",
    params: &[],
    // It is the reference.
    max_rmse: &[("exact", 1e-9)],
    make: |_, _: &RenderOptions| Ok(Box::new(RayCaster::new("exact", "reference"))),
};

/// Side of the square pixel tiles rays are cast in.
const TILE: usize = 16;

/// Remaining transmittance below which a ray stops (its further contribution is < 1e-12).
const TERMINATE_T: f64 = 1e-12;

pub struct RayCaster {
    name: &'static str,
    integrator_name: String,
    state: Option<Prepared>,
    /// Whether the walk is the projected walk (the default; see `projected.rs`) rather than the
    /// reference walk of `walk.rs`.
    projected_walk: bool,
}

/// A vertex as the walk reads it: position (centred frame) and transfer-function coordinate.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Vert {
    p: DVec3,
    s: f64,
}

struct Prepared {
    /// Vertex positions in the frame centred on the bounding box (CONVENTIONS §1) and
    /// transfer-function coordinates `s`, side by side: half a cache line per vertex read.
    verts: Vec<Vert>,
    /// Orientation of each tet: +1, −1 (0 never stored: flat tets take +1 and are retried).
    sign: Vec<i8>,
    /// The walk's cell links: per tet and face, `4 · neighbour + the neighbour's face back to
    /// this tet`, or [`BOUNDARY`] (16 B/tet; the mesh's adjacency is not kept beside it).
    next: Vec<[u32; 4]>,
    /// Largest |coordinate| of `pos`, for the predicate filter's static error bound.
    max_abs: f64,
    bvh: Bvh,
    shader: Shader,
    /// 1 / L: world length to optical length.
    inv_l: f64,
    /// Tolerance for re-entry at the same depth (concave boundary edges).
    t_eps: f64,
    max_steps: usize,
}

impl RayCaster {
    pub fn new(integrator: &str, name: &'static str) -> RayCaster {
        RayCaster {
            name,
            integrator_name: integrator.to_string(),
            state: None,
            projected_walk: true,
        }
    }

    /// Chooses the walk: the projected walk (`true`, the default) or the reference walk of
    /// `walk.rs` (`false`; the same cells, decided by the same exact signs, with the crossings
    /// interpolated in three dimensions). For the tests that hold the two walks together.
    pub fn set_projected_walk(&mut self, on: bool) {
        self.projected_walk = on;
    }
}

/// Counters of a frame: cell steps, rays that hit the step limit, walks that found no
/// consistent exit face (flat cells), re-entries through the boundary, and rays that cross the
/// boundary without entering it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayStats {
    pub steps: u64,
    pub lost: u64,
    pub fallbacks: u64,
    pub reentries: u64,
    /// Rays that cross the mesh boundary (their pixel centre is covered by the projected
    /// boundary) but found no face to enter through: a hole. 0 for a watertight entry test.
    pub missed: u64,
    /// Edge predicates the f64 filter could not decide, computed by the exact orient3d.
    pub filter_fallbacks: u64,
    /// Bytes of the frame's scratch: the camera's enterable faces, the entry grid and the
    /// shared frame's vertex table (0 per ray; the frame's total).
    pub scratch_bytes: u64,
}

impl std::ops::AddAssign for RayStats {
    fn add_assign(&mut self, o: RayStats) {
        self.steps += o.steps;
        self.lost += o.lost;
        self.fallbacks += o.fallbacks;
        self.reentries += o.reentries;
        self.missed += o.missed;
        self.filter_fallbacks += o.filter_fallbacks;
        self.scratch_bytes += o.scratch_bytes;
    }
}

impl Renderer for RayCaster {
    fn describe(&self) -> Description {
        Description::cpu(self.name, "", &self.integrator_name)
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        let shader = Shader::new(&self.integrator_name, tf)?;
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let map = tf.scalar_map(mesh.scalar_range());
        // Built in the order that keeps the peak low: the links (and the few bytes a tet the
        // matching of faces holds beside them) first, then the signs and the vertex table.
        let next = mesh.face_links();
        // The boundary faces in `Mesh::boundary_faces` order.
        let boundary: Vec<u32> = next
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, n)| {
                (0..4)
                    .filter(move |&f| n[f] == BOUNDARY)
                    .map(move |f| (4 * t + f) as u32)
            })
            .collect();
        // The sign of `Mesh::volumes` (the same expression), without caching 8 B/tet there.
        let sign: Vec<i8> = (0..mesh.num_tets())
            .into_par_iter()
            .map(|t| {
                let v = signed_volume6(mesh.tet_points(t).map(|p| p - c)) / 6.0;
                if v < 0.0 {
                    -1
                } else {
                    1
                }
            })
            .collect();
        let verts: Vec<Vert> = mesh
            .positions()
            .par_iter()
            .zip(mesh.scalars().par_iter())
            .map(|(p, &v)| Vert {
                p: *p - c,
                s: map.s(v),
            })
            .collect();
        let max_abs = verts
            .par_iter()
            .map(|v| v.p.abs().max_element())
            .reduce(|| 0.0, f64::max);
        let bvh = Bvh::build(mesh, &verts, boundary);
        self.state = Some(Prepared {
            verts,
            sign,
            next,
            max_abs,
            bvh,
            shader,
            inv_l: if l > 0.0 { 1.0 / l } else { 0.0 },
            t_eps: 1e-10 * l.max(f64::MIN_POSITIVE),
            max_steps: 64 + 8 * mesh.num_tets(),
        });
        Ok(())
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let t0 = Instant::now();
        let (px, stats) = self.render_f64(mesh, camera)?;
        let mut image = Image::try_new(camera.width, camera.height)?;
        for (o, p) in image.pixels.iter_mut().zip(&px) {
            *o = p.map(|c| c as f32);
        }
        let draw_ms = ms_since(t0);
        let rays = camera.width as u64 * camera.height as u64;
        Ok(Frame {
            image,
            times: FrameTimes {
                draw_ms,
                total_ms: draw_ms,
                ..Default::default()
            },
            counters: vec![
                ("rays", rays as f64),
                ("cell_steps", stats.steps as f64),
                ("lost_rays", stats.lost as f64),
                ("walk_fallbacks", stats.fallbacks as f64),
                ("reentries", stats.reentries as f64),
                ("missed_rays", stats.missed as f64),
                ("filter_fallbacks", stats.filter_fallbacks as f64),
                ("scratch_bytes", stats.scratch_bytes as f64),
            ],
        })
    }
}

impl RayCaster {
    /// Renders in f64 (premultiplied RGBA per pixel, row-major), with the ray counters. The
    /// `Renderer::render` image is this rounded to f32.
    pub fn render_f64(&self, mesh: &Mesh, camera: &Camera) -> Result<(Vec<[f64; 4]>, RayStats)> {
        let st = self
            .state
            .as_ref()
            .ok_or_else(|| Error::Internal("raycast: render before prepare".into()))?;
        let w = camera.width.max(1) as usize;
        let mut px = crate::util::alloc::try_vec(w * camera.height as usize, [0.0f64; 4])
            .map_err(|e| Error::Input(format!("raycast: {}x{}: {e}", camera.width, camera.height)))?;
        let stats = match &st.shader {
            Shader::Partial(p) => st.tiles(mesh, camera, p, self.projected_walk, &mut px),
            Shader::Exact(e) => st.tiles(mesh, camera, e, self.projected_walk, &mut px),
            Shader::Other(i) => st.tiles(mesh, camera, i, self.projected_walk, &mut px),
        };
        Ok((px, stats))
    }
}

impl Prepared {
    /// Casts every pixel's ray into `px` (row-major, width `camera.width`).
    ///
    /// Bands of TILE rows in parallel, each walked tile by tile (TILE × TILE rays in row
    /// order): neighbouring rays cross the same cells, and a tile's cells (~16·26 per row of
    /// it on the NASA grids at 512²) stay in cache for its next row, where a whole image row
    /// (~13K cells) does not. Every pixel is computed alone, so the order changes no bit.
    ///
    /// The bands are handed out one at a time, the heaviest first by the entry grid's guess
    /// ([`entry::EntryGrid::band_weights`], [`heaviest_first`]), so that the threads end
    /// within about a light band of each other: stolen one at a time in image order they
    /// ended 0–39 ms apart on post at 512² (a heavy band last), heaviest first under 1 ms.
    fn tiles<S: Shade>(
        &self,
        mesh: &Mesh,
        camera: &Camera,
        shade: &S,
        projected: bool,
        px: &mut [[f64; 4]],
    ) -> RayStats {
        let w = camera.width.max(1) as usize;
        let tets = mesh.tets();
        let front = self.bvh.front(&self.verts, tets, camera);
        let grid = if projected {
            entry::EntryGrid::new(self, tets, &front, camera)
        } else {
            None
        };
        // Orthographic rays share their direction, so a projected walk can share its frame.
        let shared = match camera.projection {
            Projection::Ortho if projected => SharedFrame::new(&self.verts, camera.pixel_ray(0, 0).dir),
            _ => None,
        };
        let dir = match camera.projection {
            Projection::Ortho => Some(DirTerms::new(camera.pixel_ray(0, 0).dir, camera)),
            Projection::Persp => None,
        };
        let scratch = front.bytes()
            + grid.as_ref().map_or(0, |g| g.bytes())
            + shared.as_ref().map_or(0, |f| f.bytes());
        let cast_band = |(b, band): (usize, &mut [[f64; 4]])| {
            let mut rs = RayStats::default();
            let rows = band.len() / w;
            // The previous ray's entry face, per band (tile order keeps it a neighbour).
            let mut seed = u32::MAX;
            // The projected walk's queue, one per band (not cleared per ray: 1.2 KB a ray).
            let mut run = projected::Run::default();
            for i0 in (0..w).step_by(TILE) {
                for dj in 0..rows {
                    let j = b * TILE + dj;
                    for i in i0..(i0 + TILE).min(w) {
                        // A ray of the projected walk whose pixel centre is in no boundary
                        // face's box crosses no face (`EntryGrid::may_cross`): it enters
                        // nowhere and is no hole. Most rays beside a mesh.
                        if grid.as_ref().is_some_and(|g| !g.may_cross(i, j)) {
                            band[dj * w + i] = [0.0; 4];
                            continue;
                        }
                        let ray = camera.pixel_ray(i as u32, j as u32);
                        let ctx = RayCtx::new(&ray, camera, self.max_abs, dir.as_ref());
                        let (seg, s) = if projected {
                            let pre = (grid.as_ref(), shared.as_ref());
                            self.cast_projected(
                                tets,
                                shade,
                                &front,
                                &ctx,
                                pre,
                                (i, j),
                                &mut seed,
                                &mut run,
                            )
                        } else {
                            self.cast(tets, shade, &front, &ctx, &mut seed)
                        };
                        rs += s;
                        band[dj * w + i] = [seg.rgb[0], seg.rgb[1], seg.rgb[2], seg.alpha];
                    }
                }
            }
            rs
        };
        // The bands heaviest first by the entry grid's guess (in image order without a grid).
        let bands: Vec<(usize, &mut [[f64; 4]])> = px.chunks_mut(w * TILE).enumerate().collect();
        let weights = grid.as_ref().map(|g| g.band_weights(TILE)).unwrap_or_default();
        let weight = |b: usize, _: &_| weights.get(b).copied().unwrap_or(0);
        let mut stats = RayStats::default();
        for s in heaviest_first(bands, weight, cast_band) {
            stats += s;
        }
        stats.scratch_bytes = scratch as u64;
        stats
    }
}
