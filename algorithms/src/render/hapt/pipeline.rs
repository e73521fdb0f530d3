//! What `hapt` builds for a mesh and a transfer function: the shaders and the render pipeline,
//! the uniform block (the TF's cells for the early discard, the iso values), the scalars of
//! every time step, and the buffers of the resident or the streaming mode.

use std::sync::Arc;

use super::params::{Mode, Settings};
use super::SortChoice;
use crate::error::{Error, Result};
use crate::gpu::shader::{self, ViewUniform};
use crate::gpu::{wgpu, Account, Gpu};
use crate::mesh::Mesh;
use crate::optics::fast::{TfTable, TF_SAMPLES};
use crate::optics::gpu::{OpticsTables, OPTICS};
use crate::render::pt;
use crate::sort::gpu::GpuSorter;
use crate::sort;
use crate::tf::{ScalarMap, TransferFunction};

/// Library and stage sources of hapt.
pub const HAPT_LIB: &str = include_str!("hapt.wgsl");
pub const HAPT_VERT: &str = include_str!("hapt.vert.wgsl");
pub const HAPT_ISO_FRAG: &str = include_str!("hapt_iso.frag.wgsl");
const VERT_LIBS: &[&str] = &[shader::VIEW, shader::CLASSIFY, shader::VOLUME, HAPT_LIB];
const ISO_LIBS: &[&str] = &[
    shader::VIEW,
    shader::VOLUME,
    OPTICS,
    shader::CLASSIFY,
    HAPT_LIB,
];

/// `HaptParams` of `hapt.wgsl` (112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct HaptParams {
    tf_lo: f32,
    tf_scale: f32,
    tf_cells: u32,
    mode: u32,
    iso_s: [f32; 4],
    iso_rgba: [[f32; 4]; 4],
    iso_n: u32,
    _p: [u32; 3],
}

/// Everything `hapt` holds for one mesh and transfer function.
pub(super) struct State {
    pub gpu: Arc<Gpu>,
    pub acct: Account,
    /// The mesh-independent part of `acct.bytes` (`gpu_fixed_bytes`).
    pub fixed_bytes: u64,
    pub tets: usize,
    pub verts: usize,
    pub inv_l: f64,
    /// The field's time steps in TF coordinate, or just the active one.
    pub steps: Vec<Vec<f32>>,
    /// Per step: tets skipped by the early discard in this mode.
    pub discarded: Vec<usize>,
    /// Vertex positions in the centred frame (streaming gathers them per chunk).
    pub pos: Vec<[f32; 4]>,
    /// What the uniform block was made of, held as long as the state (part of the bytes hapt
    /// holds for a mesh).
    pub _held: (TransferFunction, TfTable, Vec<u32>, HaptParams, wgpu::Buffer),
    pub view_buf: wgpu::Buffer,
    pub optics: OpticsTables,
    pub group2: wgpu::BindGroup,
    pub pipeline: wgpu::RenderPipeline,
    /// Resident mode: scalars, order upload (CPU sorts), GPU sorter.
    pub scal: Option<wgpu::Buffer>,
    pub order_buf: Option<wgpu::Buffer>,
    pub sorter: Option<GpuSorter>,
    /// Streaming mode: the chunk buffer and its capacity in tets.
    pub chunk: Option<(wgpu::Buffer, usize)>,
    /// The render target: width, height, texture, its bytes.
    pub target: Option<(u32, u32, wgpu::Texture, u64)>,
    /// The CPU sort's order (CPU sorts and streaming).
    pub order: Vec<u32>,
}

/// Builds the state for `mesh` and `tf` (see the module docs).
pub(super) fn build(
    s: &Settings,
    sort_choice: &SortChoice,
    integrator: &str,
    mesh: &Mesh,
    tf: &TransferFunction,
) -> Result<State> {
    let gpu = Gpu::shared()?;
    let mut acct = Account::default();
    // Fixed costs first.
    let optics = OpticsTables::new(&gpu, &mut acct, integrator, tf)?;
    let table = TfTable::new(tf, TF_SAMPLES);
    let nz = empty_cells(tf, &table);
    let (params, steps) = uniforms(s, mesh, tf, &table)?;
    let discarded = steps
        .iter()
        .map(|st| count_discarded(mesh, st, &params, &nz))
        .collect();
    let uniform = wgpu::BufferUsages::UNIFORM;
    let storage = wgpu::BufferUsages::STORAGE;
    let params_buf = acct.buffer_init(&gpu, "hapt params", bytemuck::bytes_of(&params), uniform)?;
    let view_buf = acct.buffer(
        &gpu,
        "view",
        std::mem::size_of::<ViewUniform>() as u64,
        uniform | wgpu::BufferUsages::COPY_DST,
    )?;
    let nz_buf = acct.buffer_init(&gpu, "tf cells", bytemuck::cast_slice(&nz), storage)?;
    let fixed_before_mesh = acct.bytes;
    let c = mesh.bbox().center();
    let pos: Vec<[f32; 4]> = mesh
        .positions()
        .iter()
        .map(|p| {
            let v = (*p - c).as_vec3();
            [v.x, v.y, v.z, 0.0]
        })
        .collect();
    let mb = match s.stream {
        Some(cap) => MeshBuffers::streaming(&gpu, &mut acct, cap)?,
        None => MeshBuffers::resident(&gpu, &mut acct, sort_choice, mesh, &pos, &steps[0])?,
    };
    let (layout2, group2) = bind_group(
        &gpu,
        &[
            &params_buf,
            &mb.verts,
            &mb.scal,
            &mb.tets,
            &mb.order,
            &nz_buf,
            &mb.chunk,
        ],
    );
    let view_layout = shader::view_layout(&gpu);
    let pipeline = pipeline(
        &gpu,
        &[Some(&optics.layout), Some(&view_layout), Some(&layout2)],
        s.mode,
        s.stream.is_some(),
    )?;
    // Fixed: tables, uniforms, TF cells (and the streaming chunk, by design mesh-independent).
    let fixed_bytes = if s.stream.is_some() {
        acct.bytes
    } else {
        fixed_before_mesh + 16
    };
    let l = mesh.diagonal();
    Ok(State {
        gpu,
        acct,
        fixed_bytes,
        tets: mesh.num_tets(),
        verts: mesh.num_vertices(),
        inv_l: if l > 0.0 { 1.0 / l } else { 0.0 },
        steps,
        discarded,
        pos,
        _held: (tf.clone(), table, nz, params, params_buf),
        view_buf,
        optics,
        group2,
        pipeline,
        scal: mb.resident_scal,
        order_buf: mb.order_upload,
        sorter: mb.sorter,
        chunk: mb.chunk_cap.map(|cap| (mb.chunk.clone(), cap)),
        target: None,
        order: Vec::new(),
    })
}

/// The uniform block (TF table domain, mode, iso values in TF coordinate with their colours)
/// and the scalars of every step drawn, in TF coordinate.
fn uniforms(
    s: &Settings,
    mesh: &Mesh,
    tf: &TransferFunction,
    table: &TfTable,
) -> Result<(HaptParams, Vec<Vec<f32>>)> {
    let (lo, scale) = table.domain();
    let (name, step) = mesh.active_field();
    let field = mesh
        .fields()
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| Error::Internal("hapt: active field not found".into()))?;
    let raw_steps: Vec<&Vec<f64>> = if s.timevarying {
        field.steps.iter().collect()
    } else {
        vec![&field.steps[step]]
    };
    let active_map = scalar_map(tf, mesh.scalars());
    let mut params = HaptParams {
        tf_lo: lo,
        tf_scale: scale,
        tf_cells: (table.data().len() - 1) as u32,
        mode: s.mode.bits(),
        iso_n: s.iso.len() as u32,
        ..Default::default()
    };
    for (i, &v) in s.iso.iter().enumerate() {
        let x = active_map.s(v.scalar(mesh.scalar_range()));
        params.iso_s[i] = x as f32;
        let (c, _) = tf.eval(x);
        params.iso_rgba[i] = [c[0] as f32, c[1] as f32, c[2] as f32, s.iso_alpha];
    }
    let steps = raw_steps
        .iter()
        .map(|vals| {
            let m = scalar_map(tf, vals);
            vals.iter().map(|&v| m.s(v) as f32).collect()
        })
        .collect();
    Ok((params, steps))
}

/// The buffers bound at `@group(2)` bindings 1..=4 and 6 (a 16-byte stub where the mode has
/// none), and those the frame writes.
struct MeshBuffers {
    verts: wgpu::Buffer,
    scal: wgpu::Buffer,
    tets: wgpu::Buffer,
    order: wgpu::Buffer,
    chunk: wgpu::Buffer,
    resident_scal: Option<wgpu::Buffer>,
    order_upload: Option<wgpu::Buffer>,
    sorter: Option<GpuSorter>,
    chunk_cap: Option<usize>,
}

impl MeshBuffers {
    /// Streaming: one chunk buffer of `cap` tets (64 bytes each), the same for every mesh.
    fn streaming(gpu: &Gpu, acct: &mut Account, cap: usize) -> Result<MeshBuffers> {
        let storage = wgpu::BufferUsages::STORAGE;
        let chunk = acct.buffer(
            gpu,
            "hapt chunk",
            64 * cap as u64,
            storage | wgpu::BufferUsages::COPY_DST,
        )?;
        let mut stub = || acct.buffer(gpu, "stub", 16, storage);
        Ok(MeshBuffers {
            verts: stub()?,
            scal: stub()?,
            tets: stub()?,
            order: stub()?,
            chunk,
            resident_scal: None,
            order_upload: None,
            sorter: None,
            chunk_cap: Some(cap),
        })
    }

    /// Resident: vertices, scalars and tets uploaded once, and the order's buffer: the GPU
    /// sorter's, or one the CPU sort's order is written to.
    fn resident(
        gpu: &Gpu,
        acct: &mut Account,
        sort_choice: &SortChoice,
        mesh: &Mesh,
        pos: &[[f32; 4]],
        scalars: &[f32],
    ) -> Result<MeshBuffers> {
        let storage = wgpu::BufferUsages::STORAGE;
        let verts = acct.buffer_init(gpu, "hapt vertices", bytemuck::cast_slice(pos), storage)?;
        let scal = acct.buffer_init(gpu, "hapt scalars", bytemuck::cast_slice(scalars), storage)?;
        let tets: Vec<[u32; 4]> = mesh.tets().to_vec();
        let tets = acct.buffer_init(gpu, "hapt tets", bytemuck::cast_slice(&tets), storage)?;
        let (order, order_upload, sorter) = match sort_choice {
            SortChoice::Gpu(kind) => {
                let cent: Vec<[f32; 3]> = sort::centroids(mesh);
                let cb = acct.buffer_init(gpu, "centroids", bytemuck::cast_slice(&cent), storage)?;
                let s = GpuSorter::new(gpu, acct, *kind, mesh.num_tets(), &cb)?;
                (s.order().clone(), None, Some(s))
            }
            SortChoice::Cpu(_) => {
                let b = acct.buffer(
                    gpu,
                    "hapt order",
                    4 * mesh.num_tets() as u64,
                    storage | wgpu::BufferUsages::COPY_DST,
                )?;
                (b.clone(), Some(b), None)
            }
        };
        let chunk = acct.buffer(gpu, "stub", 16, storage)?;
        Ok(MeshBuffers {
            verts,
            resident_scal: Some(scal.clone()),
            scal,
            tets,
            order,
            chunk,
            order_upload,
            sorter,
            chunk_cap: None,
        })
    }
}

/// `@group(2)`: the uniform block at binding 0, then the storage buffers, read by the vertex
/// stage.
fn bind_group(gpu: &Gpu, buffers: &[&wgpu::Buffer]) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let vis = wgpu::ShaderStages::VERTEX_FRAGMENT;
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: vis,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }];
    for b in 1..buffers.len() as u32 {
        entries.push(shader::storage_entry(b, wgpu::ShaderStages::VERTEX, true));
    }
    let layout = gpu
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hapt"),
            entries: &entries,
        });
    let group = shader::bind_buffers(gpu, "hapt", &layout, buffers);
    (layout, group)
}

/// The render pipeline: the vertex stage (resident or streaming entry) and the volume's or
/// the iso-surfaces' fragment stage.
fn pipeline(
    gpu: &Gpu,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    mode: Mode,
    stream: bool,
) -> Result<wgpu::RenderPipeline> {
    let layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hapt"),
            bind_group_layouts: layouts,
            immediate_size: 0,
        });
    let vs = pt::wgsl::module(gpu, "hapt.vert.wgsl", HAPT_VERT, VERT_LIBS)?;
    let (fs, fs_entry) = if mode == Mode::Dvr {
        (
            pt::wgsl::module(
                gpu,
                "volume.frag.wgsl",
                shader::VOLUME_FRAG,
                pt::wgsl::VOLUME_FRAG_LIBS,
            )?,
            "fs_volume",
        )
    } else {
        (
            pt::wgsl::module(gpu, "hapt_iso.frag.wgsl", HAPT_ISO_FRAG, ISO_LIBS)?,
            "fs_hapt_iso",
        )
    };
    let vs_entry = if stream { "vs_hapt_stream" } else { "vs_hapt" };
    Ok(shader::volume_pipeline(
        gpu, &layout, &vs, vs_entry, &fs, fs_entry,
    ))
}
/// Prefix counts over the TF table's cells of those where τ is not identically 0: cell k,
/// [s_k, s_k+1], is empty when τ is 0 at both ends and at every TF point inside (τ is piecewise
/// linear and ≥ 0).
fn empty_cells(tf: &TransferFunction, table: &TfTable) -> Vec<u32> {
    let (lo, scale) = table.domain();
    let n = table.data().len() - 1;
    let at = |k: usize| lo as f64 + k as f64 / scale as f64;
    let mut nz = Vec::with_capacity(n + 1);
    let mut c = 0u32;
    nz.push(0);
    for k in 0..n {
        let (a, b) = (at(k), at(k + 1));
        let empty = table.data()[k][3] == 0.0
            && table.data()[k + 1][3] == 0.0
            && tf.eval(a).1 == 0.0
            && tf.eval(b).1 == 0.0
            && !tf.points_between(a, b).iter().any(|p| p.tau > 0.0);
        c += (!empty) as u32;
        nz.push(c);
    }
    nz
}

/// The GPU's `hapt_visible` on the CPU, for the discard count.
fn visible(p: &HaptParams, nz: &[u32], s0: f32, s1: f32) -> bool {
    if p.mode & 1 != 0 {
        let hi = p.tf_cells as f32;
        let x0 = ((s0 - p.tf_lo) * p.tf_scale).clamp(0.0, hi);
        let x1 = ((s1 - p.tf_lo) * p.tf_scale).clamp(0.0, hi);
        let k0 = (x0 as u32).min(p.tf_cells - 1) as usize;
        let k1 = (x1 as u32).min(p.tf_cells - 1) as usize;
        if nz[k1 + 1] != nz[k0] {
            return true;
        }
    }
    p.mode & 2 != 0 && p.iso_s[..p.iso_n as usize].iter().any(|&v| v >= s0 && v <= s1)
}

fn count_discarded(mesh: &Mesh, s: &[f32], p: &HaptParams, nz: &[u32]) -> usize {
    mesh.tets()
        .iter()
        .filter(|t| {
            let v = t.map(|i| s[i as usize]);
            let s0 = v[0].min(v[1]).min(v[2].min(v[3]));
            let s1 = v[0].max(v[1]).max(v[2].max(v[3]));
            !visible(p, nz, s0, s1)
        })
        .count()
}

fn scalar_map(tf: &TransferFunction, values: &[f64]) -> ScalarMap {
    let range = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    tf.scalar_map(range)
}

