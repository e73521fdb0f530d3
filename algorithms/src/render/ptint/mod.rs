//! `ptint`: two-pass GPU projected tetrahedra (Marroquim et al. 2006, PTINT §3), on wgpu.
//!
//! The mesh is resident on the GPU: vertices (centred f32 position + TF coordinate, 16 B) and
//! tets (four u32, 16 B) — the paper's 20 B/tet, reported as the `mesh_bytes_per_tet` counter.
//! Per frame:
//! 1. **project** (pass 1, compute): `ptint_project.comp.wgsl` projects every vertex once to
//!    snapped pixel coordinates and depth; `ptint_classify.comp.wgsl` classifies every tet with
//!    the generated ternary truth table (exact tests, `classify.wgsl`) and writes its record —
//!    thick vertex, s_f, s_b, l (or the 1/z-weighted attributes in perspective), table index
//!    (fan order and count) — and its key (centroid depth, table index);
//! 2. **readback** of the keys (8 B/tet) to the CPU;
//! 3. **sort** on the CPU with the named sort ([`crate::sort`], the same code and order as
//!    `cpu-pt`), then the list of drawn tets in that order is built and uploaded (4 B/tet);
//! 4. **draw** (pass 2): one instanced draw, 12 vertices per drawn tet, the fan pulled by
//!    `ptint_fan.vert.wgsl` (triangles past the fan's count degenerate), shaded by
//!    `volume.frag.wgsl` with the chosen integrator and blended `One, OneMinusSrcAlpha` back to
//!    front into an `Rgba32Float` target ([`Renderer::device`] names it with the adapter);
//! 5. **readback** of the image.
//!
//! Default sort `centroid`: PTINT sorts centroids on the CPU (bucket sort while the camera
//! moves, merge sort when still); for a still frame the full centroid sort is the paper's
//! choice, and it is `cpu-pt`'s default, so the two render the same image by default.
//! Integrators `average`, `partial` (default, as the paper) and `preint`.
//!
//! Times: `project_ms` and `draw_ms` are GPU timestamps around the passes where the adapter
//! has them (counter `timestamps` = 1), else the wall clock around submit and wait;
//! `readback_ms` = keys + image; `sort_ms` = the CPU sort + building and uploading the list.
//! `gpu_bytes` counts the per-mesh buffers; the fixed ones (tables, view, target) are the
//! `gpu_fixed_bytes` counter.

use std::sync::Arc;
use std::time::Instant;

use super::{
    ms_since, Description, Family, Frame, FrameTimes, Memory, Renderer, RendererInfo,
};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::optics::gpu::{OpticsTables, GPU_INTEGRATORS};
use crate::gpu::shader::{self, ViewUniform};
use crate::gpu::{Account, Gpu, Timer};
use crate::mesh::Mesh;
use crate::render::pt::{self, TABLE};
use crate::sort::{Sort, SortStats};
use crate::tf::TransferFunction;

/// Library: element types of `ptint`'s buffers.
pub const PTINT_LIB: &str = include_str!("ptint.wgsl");
/// Pass 1a: project every vertex.
pub const PTINT_PROJECT_COMP: &str = include_str!("ptint_project.comp.wgsl");
/// Pass 1b: classify every tet, write its record and its sort key.
pub const PTINT_CLASSIFY_COMP: &str = include_str!("ptint_classify.comp.wgsl");
/// Pass 2: vertex stage pulling the fan of each sorted tet.
pub const PTINT_FAN_VERT: &str = include_str!("ptint_fan.vert.wgsl");
/// The libraries of the project stage.
const PROJECT_LIBS: &[&str] = &[shader::VIEW, PTINT_LIB];
/// The libraries of the classify and fan stages.
const PTINT_LIBS: &[&str] = &[shader::VIEW, shader::CLASSIFY, shader::VOLUME, PTINT_LIB];
/// Every stage of its own with the libraries it is composed with (for the compile test).
pub const STAGES: &[(&str, &str, &[&str])] = &[
    ("ptint_project.comp.wgsl", PTINT_PROJECT_COMP, PROJECT_LIBS),
    ("ptint_classify.comp.wgsl", PTINT_CLASSIFY_COMP, PTINT_LIBS),
    ("ptint_fan.vert.wgsl", PTINT_FAN_VERT, PTINT_LIBS),
];

/// Registry entry for `ptint` (`partial` and `centroid` by default).
pub static PTINT: RendererInfo = RendererInfo {
    name: "ptint",
    description: "GPU projected tetrahedra, two passes (PTINT): compute-shader classification, \
                  CPU sort, fans drawn with per-fragment integration (wgpu)",
    sorts: crate::sort::SORTS,
    integrators: &GPU_INTEGRATORS,
    family: Family::Pt,
    needs_gpu: true,
    default_sort: "centroid",
    // Its CPU sort variants are cpu-pt's rows; on a software GPU each extra row costs seconds.
    table_sorts: &["centroid"],
    default_integrator: "partial",
    params: &[],
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 4.0e-3), ("partial", 4.6e-3), ("preint", 2.8e-3)],
    make: |_, o| {
        Ok(Box::new(Ptint::new(
            o.sort.as_deref().unwrap_or("centroid"),
            o.integrator.as_deref().unwrap_or("partial"),
        )?))
    },
};

/// Workgroup width of the compute stages (`@workgroup_size(64)`).
const WG: u32 = 64;

pub struct Ptint {
    sort_name: String,
    integrator_name: String,
    sort: Box<dyn Sort>,
    sort_stats: SortStats,
    state: Option<State>,
}

struct Target {
    size: (u32, u32),
    tex: wgpu::Texture,
    view: wgpu::TextureView,
    bytes: u64,
}

struct State {
    gpu: Arc<Gpu>,
    /// Per-mesh buffers.
    mesh_bytes: u64,
    /// Vertex + tet buffers only (the paper's measure).
    resident_bytes: u64,
    /// Tables and the view uniform.
    fixed_bytes: u64,
    optics: OpticsTables,
    view_buf: wgpu::Buffer,
    view_bg: wgpu::BindGroup,
    project: wgpu::ComputePipeline,
    classify: wgpu::ComputePipeline,
    draw: wgpu::RenderPipeline,
    project_bg: wgpu::BindGroup,
    classify_bg: wgpu::BindGroup,
    draw_bg: wgpu::BindGroup,
    keys: wgpu::Buffer,
    keys_staging: wgpu::Buffer,
    order: wgpu::Buffer,
    target: Option<Target>,
    timer: Timer,
    inv_l: f64,
    tets: usize,
    verts: usize,
    /// Scratch: the sort's order and the drawn list.
    sorted: Vec<u32>,
    drawn: Vec<u32>,
}

impl Ptint {
    /// `sort`: any name [`crate::sort::make`] knows; `integrator`: `average`, `partial`,
    /// `preint`.
    pub fn new(sort: &str, integrator: &str) -> Result<Ptint> {
        let sorter = crate::sort::make(sort)?;
        Ok(Ptint {
            sort_name: sort.to_string(),
            integrator_name: integrator.to_string(),
            sort: sorter,
            sort_stats: SortStats::default(),
            state: None,
        })
    }
}

/// Workgroup counts (x, y) covering `n` invocations of a 1-D index flattened by
/// `ptint_index` (x at most the adapter's per-dimension limit).
fn groups(gpu: &Gpu, n: usize, what: &str) -> Result<(u32, u32)> {
    let max = gpu.limits.max_compute_workgroups_per_dimension;
    crate::util::size::dispatch_grid(n as u64, WG, max).ok_or_else(|| {
        Error::Input(format!(
            "ptint: {n} {what} exceed the GPU's dispatch limit"
        ))
    })
}

fn compute_pipeline(
    gpu: &Gpu,
    name: &str,
    src: &str,
    libs: &[&str],
    entry: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
) -> Result<wgpu::ComputePipeline> {
    let m = pt::wgsl::module(gpu, name, src, libs)?;
    let layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: layouts,
            immediate_size: 0,
        });
    Ok(gpu
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&layout),
            module: &m,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        }))
}

fn storage_layout(gpu: &Gpu, label: &str, vis: wgpu::ShaderStages, ro: &[bool]) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = ro
        .iter()
        .enumerate()
        .map(|(i, &r)| shader::storage_entry(i as u32, vis, r))
        .collect();
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &entries,
        })
}

impl State {
    fn new(mesh: &Mesh, tf: &TransferFunction, integrator: &str) -> Result<State> {
        let gpu = Gpu::shared()?;
        let (nv, nt) = (mesh.num_vertices(), mesh.num_tets());
        let mut fixed = Account::default();
        let optics = OpticsTables::new(&gpu, &mut fixed, integrator, tf)?;
        let view_buf = fixed.buffer(
            &gpu,
            "view",
            std::mem::size_of::<ViewUniform>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        )?;
        let view_layout = shader::view_layout(&gpu);
        let view_bg = shader::bind_buffers(&gpu, "view", &view_layout, &[&view_buf]);

        // The mesh, centred before the conversion to f32 (CONVENTIONS §1).
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let map = tf.scalar_map(mesh.scalar_range());
        let verts: Vec<[f32; 4]> = mesh
            .positions()
            .iter()
            .zip(mesh.scalars())
            .map(|(p, &v)| {
                let q = (*p - c).as_vec3();
                [q.x, q.y, q.z, map.s(v) as f32]
            })
            .collect();
        let st = wgpu::BufferUsages::STORAGE;
        let mut acct = Account::default();
        let vbuf = acct.buffer_init(&gpu, "ptint vertices", bytemuck::cast_slice(&verts), st)?;
        let tbuf = acct.buffer_init(
            &gpu,
            "ptint tets",
            bytemuck::cast_slice(mesh.tets()),
            st,
        )?;
        let resident_bytes = acct.bytes;
        let pverts = acct.buffer(&gpu, "ptint projected vertices", 16 * nv.max(1) as u64, st)?;
        let records = acct.buffer(&gpu, "ptint records", 32 * nt.max(1) as u64, st)?;
        let keys = acct.buffer(
            &gpu,
            "ptint keys",
            8 * nt.max(1) as u64,
            st | wgpu::BufferUsages::COPY_SRC,
        )?;
        let keys_staging = acct.buffer(
            &gpu,
            "ptint keys readback",
            8 * nt.max(1) as u64,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )?;
        let order = acct.buffer(
            &gpu,
            "ptint order",
            4 * nt.max(1) as u64,
            st | wgpu::BufferUsages::COPY_DST,
        )?;
        groups(&gpu, nt, "tets")?;

        let comp = wgpu::ShaderStages::COMPUTE;
        let project_layout = storage_layout(&gpu, "ptint project", comp, &[true, false]);
        let classify_layout =
            storage_layout(&gpu, "ptint classify", comp, &[true, true, true, false, false]);
        let draw_layout = storage_layout(
            &gpu,
            "ptint draw",
            wgpu::ShaderStages::VERTEX,
            &[true, true, true, true],
        );
        let project = compute_pipeline(
            &gpu,
            "ptint_project.comp.wgsl",
            PTINT_PROJECT_COMP,
            PROJECT_LIBS,
            "cs_project",
            &[None, Some(&view_layout), Some(&project_layout)],
        )?;
        let classify = compute_pipeline(
            &gpu,
            "ptint_classify.comp.wgsl",
            PTINT_CLASSIFY_COMP,
            PTINT_LIBS,
            "cs_classify",
            &[None, Some(&view_layout), Some(&classify_layout)],
        )?;
        let vs = pt::wgsl::module(
            &gpu,
            "ptint_fan.vert.wgsl",
            PTINT_FAN_VERT,
            PTINT_LIBS,
        )?;
        let fs = pt::wgsl::module(
            &gpu,
            "volume.frag.wgsl",
            shader::VOLUME_FRAG,
            pt::wgsl::VOLUME_FRAG_LIBS,
        )?;
        let draw_pl = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("ptint draw"),
                bind_group_layouts: &[
                    Some(&optics.layout),
                    Some(&view_layout),
                    Some(&draw_layout),
                ],
                immediate_size: 0,
            });
        let draw = shader::volume_pipeline(&gpu, &draw_pl, &vs, "vs_fan", &fs, "fs_volume");
        let project_bg = shader::bind_buffers(&gpu, "ptint project", &project_layout, &[&vbuf, &pverts]);
        let classify_bg = shader::bind_buffers(
            &gpu,
            "ptint classify",
            &classify_layout,
            &[&vbuf, &pverts, &tbuf, &records, &keys],
        );
        let draw_bg = shader::bind_buffers(
            &gpu,
            "ptint draw",
            &draw_layout,
            &[&pverts, &tbuf, &records, &order],
        );
        let timer = Timer::new(&gpu, 2);
        Ok(State {
            mesh_bytes: acct.bytes,
            resident_bytes,
            fixed_bytes: fixed.bytes,
            optics,
            view_buf,
            view_bg,
            project,
            classify,
            draw,
            project_bg,
            classify_bg,
            draw_bg,
            keys,
            keys_staging,
            order,
            target: None,
            timer,
            inv_l: if l > 0.0 { 1.0 / l } else { 0.0 },
            tets: nt,
            verts: nv,
            sorted: Vec::new(),
            drawn: Vec::new(),
            gpu,
        })
    }

    fn target(&mut self, w: u32, h: u32) -> Result<&Target> {
        if self.target.as_ref().is_none_or(|t| t.size != (w, h)) {
            self.target = None;
            let mut acct = Account::default();
            let tex = acct.target(&self.gpu, w, h)?;
            let view = tex.create_view(&wgpu::TextureViewDescriptor::default());
            self.target = Some(Target {
                size: (w, h),
                tex,
                view,
                bytes: acct.bytes,
            });
        }
        Ok(self.target.as_ref().expect("made above"))
    }
}

impl Renderer for Ptint {
    fn describe(&self) -> Description {
        Description {
            name: "ptint".into(),
            sort: self.sort_name.clone(),
            integrator: self.integrator_name.clone(),
            device: Gpu::label(self.state.as_ref().map(|s| &*s.gpu)),
        }
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        self.state = Some(State::new(mesh, tf, &self.integrator_name)?);
        self.sort.prepare(mesh)?;
        self.sort.set_transfer_function(mesh, tf)?;
        Ok(())
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let t_start = Instant::now();
        let st = self
            .state
            .as_mut()
            .ok_or_else(|| Error::Internal("ptint: render before prepare".into()))?;
        if st.tets != mesh.num_tets() || st.verts != mesh.num_vertices() {
            return Err(Error::Internal(
                "ptint: render with a mesh other than the prepared one".into(),
            ));
        }
        let (w, h) = (camera.width, camera.height);
        st.target(w, h)?;
        let gpu = st.gpu.clone();
        let nt = st.tets;

        // 1. Pass 1: project and classify; copy the keys for readback.
        let t0 = Instant::now();
        let vu = ViewUniform::new(camera, st.inv_l);
        gpu.queue
            .write_buffer(&st.view_buf, 0, bytemuck::bytes_of(&vu));
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("ptint pass 1"),
                timestamp_writes: st.timer.compute(0),
            });
            pass.set_bind_group(1, &st.view_bg, &[]);
            pass.set_pipeline(&st.project);
            pass.set_bind_group(2, &st.project_bg, &[]);
            let (gx, gy) = groups(&gpu, st.verts, "vertices")?;
            pass.dispatch_workgroups(gx, gy, 1);
            pass.set_pipeline(&st.classify);
            pass.set_bind_group(2, &st.classify_bg, &[]);
            let (gx, gy) = groups(&gpu, nt, "tets")?;
            pass.dispatch_workgroups(gx, gy, 1);
        }
        enc.copy_buffer_to_buffer(&st.keys, 0, &st.keys_staging, 0, 8 * nt.max(1) as u64);
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let project_wall = ms_since(t0);
        let t1 = Instant::now();
        let raw = gpu.map_read(&st.keys_staging)?;
        let keys: &[[u32; 2]] = bytemuck::cast_slice(&raw);
        let mut readback_ms = ms_since(t1);

        // 2. Sort on the CPU; the drawn tets in that order.
        let t2 = Instant::now();
        let mut sorted = std::mem::take(&mut st.sorted);
        let mut drawn = std::mem::take(&mut st.drawn);
        let stats = self.sort.sort(mesh, camera, &mut sorted);
        let st = self.state.as_mut().expect("prepared");
        self.sort_stats = stats?;
        drawn.clear();
        drawn.extend(
            sorted
                .iter()
                .copied()
                .filter(|&t| TABLE[keys[t as usize][1].min(80) as usize].drawn()),
        );
        if !drawn.is_empty() {
            gpu.queue
                .write_buffer(&st.order, 0, bytemuck::cast_slice(&drawn));
        }
        let sort_ms = ms_since(t2);

        // 3. Pass 2: the fans, back to front, "over" into the cleared target.
        let t3 = Instant::now();
        let target = st.target.as_ref().expect("made above");
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ptint pass 2"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: st.timer.render(1),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if !drawn.is_empty() {
                pass.set_pipeline(&st.draw);
                pass.set_bind_group(0, &st.optics.bind_group, &[]);
                pass.set_bind_group(1, &st.view_bg, &[]);
                pass.set_bind_group(2, &st.draw_bg, &[]);
                pass.draw(0..12, 0..drawn.len() as u32);
            }
        }
        st.timer.resolve(&mut enc);
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let draw_wall = ms_since(t3);

        // 4. The image.
        let t4 = Instant::now();
        let image = gpu.read_target(&target.tex)?;
        readback_ms += ms_since(t4);
        let gpu_ms = st.timer.read_ms(&gpu)?;
        let (project_ms, draw_ms) = match &gpu_ms {
            Some(ms) => (ms[0], ms[1]),
            None => (project_wall, draw_wall),
        };
        let ndrawn = drawn.len();
        let target_bytes = target.bytes;
        st.sorted = sorted;
        st.drawn = drawn;
        Ok(Frame {
            image,
            times: FrameTimes {
                project_ms,
                sort_ms,
                draw_ms,
                readback_ms,
                total_ms: ms_since(t_start),
            },
            counters: vec![
                ("tets_drawn", ndrawn as f64),
                ("tets_discarded", (nt - ndrawn) as f64),
                ("timestamps", gpu_ms.is_some() as u8 as f64),
                ("project_wall_ms", project_wall),
                ("draw_wall_ms", draw_wall),
                ("gpu_fixed_bytes", (st.fixed_bytes + target_bytes) as f64),
                (
                    "mesh_bytes_per_tet",
                    st.resident_bytes as f64 / nt.max(1) as f64,
                ),
                ("sort_cycles", self.sort_stats.cycles as f64),
                ("sort_cells_in_cycles", self.sort_stats.cells_in_cycles as f64),
                ("sort_forced", self.sort_stats.forced as f64),
            ],
        })
    }

    fn memory(&self) -> Memory {
        Memory {
            gpu_bytes: self.state.as_ref().map_or(0, |s| s.mesh_bytes),
            external_bytes: None,
        }
    }
}
