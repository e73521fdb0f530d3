//! `hapt`: hardware-assisted projected tetrahedra in one GPU pass (Maximo, Marroquim, Farias,
//! EuroVis 2010, §3), on wgpu.
//!
//! **Per frame** (resident mode): the centroid keys are computed and sorted on the GPU
//! ([`crate::sort::gpu`]: `gpu-radix` by default, or `gpu-bitonic`; any CPU sort is also
//! accepted, computed on the CPU and its order uploaded), then ONE instanced draw,
//! `draw(0..12, 0..n_tets)`: instance i reads the i-th sorted tet index straight from the sort's
//! buffer (no readback between sort and draw), its tet and four vertices, projects and snaps them
//! and runs the shared classification (`classify.wgsl`, the table generated from
//! [`crate::render::pt::TABLE`]); its 12 vertices are the up-to-4 fan triangles (unused ones degenerate).
//! The fragment stage (`volume.frag.wgsl`) integrates the pixel's ray segment with the chosen
//! integrator (`average`, `partial`, `preint`; the same tables as `cpu-pt`'s f32 path) and blends
//! it "over" into the float target. Then the target is read back.
//!
//! **Early discard** (HAPT §3): a tet whose scalar range lies in transfer-function cells where τ
//! is identically 0 emits only degenerate triangles. The test is exact for the tables the
//! integrators read (see `hapt.wgsl`), so it changes no pixel. `tets_discarded_empty` is
//! counted on the CPU with the same test (once per scalar field), not read back from the GPU.
//!
//! **Parameters** (`RenderOptions::params`, `--param KEY=VALUE`):
//! - `mode=dvr|iso|dvr+iso` and `iso=v1,v2,…` (up to 4 values, in *scalar units* of the active
//!   field, or `P%` of its range; mapped to the TF coordinate with the TF's range), `iso_alpha=A` (default 1):
//!   iso-surfaces by marching tetrahedra evaluated per fragment (`hapt_iso.frag.wgsl`): the
//!   pixel's segment through the tet is split where the linear field crosses each value, which is
//!   a point of the tet's marching-tetrahedra polygon; the surface is flat shaded per tet (the
//!   field gradient = the facet normal, a headlight) in the TF colour at the value, and
//!   composited front to back with the volume pieces inside the tet, the tet "over" the image.
//! - `stream=N`: streaming (HAPT §3 / §5): the mesh is not resident; per frame the order comes
//!   from a CPU sort (`centroid-radix` unless another CPU sort is named: the GPU sorts would
//!   need every key resident), and the sorted tets are uploaded in chunks of N (default 65536)
//!   with their four vertices' (x, y, z, s) gathered, 64 bytes a tet, into one fixed-size buffer
//!   and drawn chunk by chunk: GPU memory does not grow with the mesh. N below [`MIN_CHUNK`] is
//!   raised to it (counter `chunk_tets`), and at most a few chunks are in flight,
//!   so host memory does not grow with the mesh either.
//! - `timevarying=1`: the active field's time steps are streamed: frame k uploads step k mod n
//!   (only the scalar buffer, 4 bytes a vertex) before drawing; `upload_ms` is the counter.
//!
//! **Timing** (CONVENTIONS §7): with timestamp queries, `sort_ms` = the GPU key+sort pass (plus
//! the CPU sort and its upload for CPU sorts), `draw_ms` = the render pass; without them the
//! wall clock around each submit and wait. `readback_ms` is the target read back, `total_ms` the
//! wall clock of the frame.
//!
//! **Memory**: `gpu_bytes` counts every buffer and the target; `gpu_fixed_bytes` the
//! mesh-independent part (integrator tables, the TF-cell table, uniforms, the target).
//!
//! Files: `params.rs` reads the parameters, `pipeline.rs` builds what a mesh needs (shaders,
//! uniforms, buffers), `stream.rs` draws a frame in either mode; this file is the renderer.

use std::time::Instant;

use super::{
    ms_since, Description, Family, Frame, FrameTimes, Memory, RenderOptions, Renderer,
    RendererInfo,
};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gpu::shader::{self, ViewUniform};
use crate::gpu::{wgpu, Gpu};
use crate::mesh::Mesh;
use crate::optics::gpu::GPU_INTEGRATORS;
use crate::sort::gpu::GpuSortKind;
use crate::sort::{self, Sort};
use crate::tf::TransferFunction;

mod params;
mod pipeline;
mod stream;

pub use params::MIN_CHUNK;
pub use pipeline::HAPT_LIB;
use params::Settings;
use pipeline::State;

/// Sorts `hapt` takes: the GPU sorts and every CPU sort.
pub const HAPT_SORTS: &[&str] = &sort::with_sorts::<2, { 2 + sort::CPU_SORTS.len() }>([
    "gpu-radix",
    "gpu-bitonic",
]);

pub static HAPT: RendererInfo = RendererInfo {
    name: "hapt",
    description: "GPU single-pass projected tetrahedra (HAPT): GPU sort, one instanced draw that \
                  classifies and decomposes every tet in the vertex stage; params mode=dvr|iso|\
                  dvr+iso, iso=v1,.., stream=N, timevarying=1",
    sorts: HAPT_SORTS,
    integrators: &GPU_INTEGRATORS,
    family: Family::Pt,
    needs_gpu: true,
    default_sort: "gpu-radix",
    // HAPT's own rows: GPU radix (for its GPU quicksort), GPU bitonic, a CPU sort, MPVONC.
    table_sorts: &["gpu-radix", "gpu-bitonic", "centroid", "mpvonc"],
    default_integrator: "partial",
    params: params::PARAMS,
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 4.0e-3), ("partial", 4.6e-3), ("preint", 2.8e-3)],
    make: |_, o| Ok(Box::new(Hapt::new(o)?)),
};

/// Default tets per chunk of `stream`.
pub const DEFAULT_CHUNK: usize = 65536;

/// Where the order comes from.
enum SortChoice {
    Gpu(GpuSortKind),
    Cpu(Box<dyn Sort>),
}

pub struct Hapt {
    sort_name: String,
    integrator_name: String,
    sort: SortChoice,
    settings: Settings,
    state: Option<State>,
    frame: u64,
}

impl Hapt {
    pub fn new(o: &RenderOptions) -> Result<Hapt> {
        let settings = Settings::read(&o.params)?;
        let integrator_name = o.integrator.clone().unwrap_or_else(|| "partial".into());
        let mut sort_name = o.sort.clone().unwrap_or_else(|| "gpu-radix".into());
        let sort = match GpuSortKind::parse(&sort_name) {
            Some(_) if settings.stream.is_some() => {
                // Streaming keeps no keys on the GPU: the order comes from the CPU.
                sort_name = "centroid-radix".into();
                SortChoice::Cpu(sort::make(&sort_name)?)
            }
            Some(k) => SortChoice::Gpu(k),
            None => SortChoice::Cpu(sort::make(&sort_name)?),
        };
        Ok(Hapt {
            sort_name,
            integrator_name,
            sort,
            settings,
            state: None,
            frame: 0,
        })
    }
}

/// Makes (or remakes, when the size changed) the float target of `w`×`h`; its bytes are
/// counted as fixed (mesh-independent).
fn ensure_target(st: &mut State, gpu: &Gpu, w: u32, h: u32) -> Result<()> {
    if st.target.as_ref().map(|t| (t.0, t.1)) != Some((w, h)) {
        if let Some(t) = st.target.take() {
            st.acct.bytes -= t.3;
            st.fixed_bytes -= t.3;
        }
        let before = st.acct.bytes;
        let tex = st.acct.target(gpu, w, h)?;
        let bytes = st.acct.bytes - before;
        st.fixed_bytes += bytes;
        st.target = Some((w, h, tex, bytes));
    }
    Ok(())
}

impl Renderer for Hapt {
    fn describe(&self) -> Description {
        Description {
            name: "hapt".into(),
            sort: self.sort_name.clone(),
            integrator: self.integrator_name.clone(),
            device: Gpu::label(self.state.as_ref().map(|s| &*s.gpu)),
        }
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        self.frame = 0;
        if let SortChoice::Cpu(s) = &mut self.sort {
            s.prepare(mesh)?;
            s.set_transfer_function(mesh, tf)?;
        }
        self.state = Some(pipeline::build(
            &self.settings,
            &self.sort,
            &self.integrator_name,
            mesh,
            tf,
        )?);
        Ok(())
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let t_start = Instant::now();
        let frame_no = self.frame;
        self.frame += 1;
        let st = self
            .state
            .as_mut()
            .ok_or_else(|| Error::Internal("hapt: render before prepare".into()))?;
        if st.tets != mesh.num_tets() || st.verts != mesh.num_vertices() {
            return Err(Error::Internal(
                "hapt: render with a mesh other than the prepared one".into(),
            ));
        }
        let gpu = st.gpu.clone();
        ensure_target(st, &gpu, camera.width, camera.height)?;
        let view = ViewUniform::new(camera, st.inv_l);
        gpu.queue.write_buffer(&st.view_buf, 0, bytemuck::bytes_of(&view));
        let view_layout = shader::view_layout(&gpu);
        let view_bind = shader::bind_buffers(&gpu, "view", &view_layout, &[&st.view_buf]);
        let mut counters: Vec<(&'static str, f64)> = Vec::new();
        // Time-varying: this frame's step.
        let step = if self.settings.timevarying {
            let step = (frame_no % st.steps.len() as u64) as usize;
            let t = Instant::now();
            if let Some(b) = &st.scal {
                gpu.queue
                    .write_buffer(b, 0, bytemuck::cast_slice(&st.steps[step]));
            }
            gpu.wait()?;
            counters.push(("upload_ms", ms_since(t)));
            counters.push(("time_step", step as f64));
            step
        } else {
            0
        };
        let mut n = st.tets as u32;
        let mut cpu_sort_ms = 0.0;
        if let SortChoice::Cpu(s) = &mut self.sort {
            let t = Instant::now();
            s.sort(mesh, camera, &mut st.order)?;
            // A skipping sort (`bcc-implicit-skip`) leaves out fully transparent tets.
            n = st.order.len() as u32;
            if let Some(b) = &st.order_buf {
                gpu.queue.write_buffer(b, 0, bytemuck::cast_slice(&st.order));
            }
            cpu_sort_ms = ms_since(t);
        }
        let st = &*st;
        let tex = &st.target.as_ref().expect("target").2;
        let tview = tex.create_view(&wgpu::TextureViewDescriptor::default());
        let target = stream::Target {
            view: &tview,
            view_bind: &view_bind,
        };
        let mut times = FrameTimes::default();
        if let Some((_, cap)) = &st.chunk {
            let t = Instant::now();
            let chunks = stream::draw_streamed(&gpu, st, &target, mesh, step)?;
            times.sort_ms = cpu_sort_ms;
            times.draw_ms = ms_since(t);
            counters.push(("chunks", chunks as f64));
            counters.push(("chunk_tets", *cap as f64));
        } else {
            stream::draw_resident(&gpu, st, &target, camera, n, cpu_sort_ms, &mut times)?;
        }
        let t_read = Instant::now();
        let image = gpu.read_target(tex)?;
        times.readback_ms = ms_since(t_read);
        times.total_ms = ms_since(t_start);
        let disc = st.discarded[step.min(st.discarded.len() - 1)];
        counters.push(("tets_drawn", (st.tets - disc) as f64));
        counters.push(("tets_discarded_empty", disc as f64));
        counters.push(("timestamps", gpu.has_timestamps() as u32 as f64));
        counters.push(("gpu_fixed_bytes", st.fixed_bytes as f64));
        Ok(Frame {
            image,
            times,
            counters,
        })
    }

    fn memory(&self) -> Memory {
        Memory {
            gpu_bytes: self.state.as_ref().map_or(0, |s| s.acct.bytes),
            external_bytes: None,
        }
    }
}
