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
//!   raised to it (counter `chunk_tets`), and at most [`MAX_IN_FLIGHT`] chunks are in flight,
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

use std::sync::Arc;
use std::time::Instant;

use super::{ms_since, Family, Frame, FrameTimes, RenderOptions, Renderer, RendererInfo};
use crate::plugin::ParamInfo;
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::optics::gpu::{OpticsTables, GPU_INTEGRATORS, OPTICS};
use crate::gpu::shader::{self, ViewUniform};
use crate::sort::gpu::{GpuSortKind, GpuSorter, KeyMode};
use crate::gpu::{wgpu, Account, Gpu, Timer};
use crate::mesh::Mesh;
use crate::render::pt;
use crate::optics::fast::{TfTable, TF_SAMPLES};
use crate::sort::{self, Sort};
use crate::tf::{ScalarMap, TransferFunction};

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
    params: &[
        ParamInfo {
            name: "mode",
            default: "dvr",
            doc: "dvr, iso or dvr+iso: volume, iso-surfaces, or both",
        },
        ParamInfo {
            name: "iso",
            default: "",
            doc: "up to 4 iso values, comma-separated, in scalar units or P% of the field's range",
        },
        ParamInfo {
            name: "iso_alpha",
            default: "1",
            doc: "opacity of the iso-surfaces, in [0, 1]",
        },
        ParamInfo {
            name: "stream",
            default: "",
            doc: "N: stream the sorted tets in chunks of N (the mesh is not resident)",
        },
        ParamInfo {
            name: "timevarying",
            default: "0",
            doc: "1: upload time step k mod n of the active field before frame k",
        },
    ],
    make: |_, o| Ok(Box::new(Hapt::new(o)?)),
};

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

/// Default tets per chunk of `stream`.
pub const DEFAULT_CHUNK: usize = 65536;
/// Smallest chunk: a smaller `stream=N` is raised to it. Each chunk is one upload, one pass and
/// one submit with a fixed cost (~1 MB of driver memory on lavapipe while in flight): `stream=1`
/// on 13K tets took 88 s and 15.5 GB.
pub const MIN_CHUNK: usize = 1024;
/// Chunks submitted before the frame waits for the GPU, so that staging memory stays bounded.
const MAX_IN_FLIGHT: usize = 4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Dvr,
    Iso,
    DvrIso,
}

impl Mode {
    fn bits(self) -> u32 {
        match self {
            Mode::Dvr => 1,
            Mode::Iso => 2,
            Mode::DvrIso => 3,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Mode::Dvr => "dvr",
            Mode::Iso => "iso",
            Mode::DvrIso => "dvr+iso",
        }
    }
}

/// An iso value: in scalar units, or a percentage of the active field's range (`50%`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum IsoValue {
    Scalar(f64),
    Percent(f64),
}

impl IsoValue {
    fn parse(x: &str) -> Option<IsoValue> {
        let (num, pct) = match x.strip_suffix('%') {
            Some(n) => (n, true),
            None => (x, false),
        };
        let v = num.trim().parse::<f64>().ok().filter(|v| v.is_finite())?;
        // A percentage is of the field's range: outside [0, 100] no surface can exist.
        if pct && !(0.0..=100.0).contains(&v) {
            return None;
        }
        Some(if pct {
            IsoValue::Percent(v)
        } else {
            IsoValue::Scalar(v)
        })
    }
    fn scalar(self, range: (f64, f64)) -> f64 {
        match self {
            IsoValue::Scalar(v) => v,
            IsoValue::Percent(p) => range.0 + (range.1 - range.0) * p / 100.0,
        }
    }
}

enum SortChoice {
    Gpu(GpuSortKind),
    Cpu(Box<dyn Sort>),
}

pub struct Hapt {
    sort_name: String,
    integrator_name: String,
    sort: SortChoice,
    mode: Mode,
    iso: Vec<IsoValue>,
    iso_alpha: f32,
    stream: Option<usize>,
    timevarying: bool,
    state: Option<State>,
    frame: u64,
}

/// `HaptParams` of `hapt.wgsl` (112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct HaptParams {
    tf_lo: f32,
    tf_scale: f32,
    tf_cells: u32,
    mode: u32,
    iso_s: [f32; 4],
    iso_rgba: [[f32; 4]; 4],
    iso_n: u32,
    _p: [u32; 3],
}

struct State {
    gpu: Arc<Gpu>,
    acct: Account,
    fixed_bytes: u64,
    tets: usize,
    verts: usize,
    inv_l: f64,
    tf: TransferFunction,
    table: TfTable,
    /// Prefix counts of non-empty TF cells (the GPU's `nz`).
    nz: Vec<u32>,
    /// The field's time steps in TF coordinate, or just the active one.
    steps: Vec<Vec<f32>>,
    /// Per step: tets skipped by the early discard in this mode.
    discarded: Vec<usize>,
    pos: Vec<[f32; 4]>,
    params: HaptParams,
    params_buf: wgpu::Buffer,
    view_buf: wgpu::Buffer,
    optics: OpticsTables,
    group2: wgpu::BindGroup,
    pipeline: wgpu::RenderPipeline,
    /// Resident mode: scalars, order upload (CPU sorts), GPU sorter.
    scal: Option<wgpu::Buffer>,
    order_buf: Option<wgpu::Buffer>,
    sorter: Option<GpuSorter>,
    /// Streaming mode: the chunk buffer and its capacity in tets.
    chunk: Option<(wgpu::Buffer, usize)>,
    target: Option<(u32, u32, wgpu::Texture, u64)>,
    order: Vec<u32>,
}

/// (mode, iso values, iso alpha, stream chunk, time-varying).
type Params = (Mode, Vec<IsoValue>, f32, Option<usize>, bool);

fn parse_params(o: &RenderOptions) -> Result<Params> {
    let (mut mode, mut iso, mut alpha, mut stream, mut tv) = (None, Vec::new(), 1.0f32, None, false);
    for (k, v) in &o.params {
        let bad = |what: &str| Error::Input(format!("hapt: parameter {k}={v}: {what}"));
        match k.as_str() {
            "mode" => {
                mode = Some(match v.as_str() {
                    "dvr" => Mode::Dvr,
                    "iso" => Mode::Iso,
                    "dvr+iso" | "dvriso" => Mode::DvrIso,
                    _ => return Err(bad("expected dvr, iso or dvr+iso")),
                })
            }
            "iso" => {
                // A value ending in % is that percentage of the active field's range.
                iso = v
                    .split(',')
                    .map(|x| IsoValue::parse(x.trim()))
                    .collect::<Option<Vec<IsoValue>>>()
                    .ok_or_else(|| {
                        bad("expected a comma-separated list of numbers or P% with P in 0..=100")
                    })?;
                if iso.is_empty() || iso.len() > 4 {
                    return Err(bad("1 to 4 iso values"));
                }
            }
            "iso_alpha" => {
                alpha = v
                    .parse::<f32>()
                    .ok()
                    .filter(|a| (0.0..=1.0).contains(a))
                    .ok_or_else(|| bad("expected a number in [0, 1]"))?
            }
            "stream" => {
                stream = Some(
                    v.parse::<usize>()
                        .ok()
                        .filter(|n| (1..=1 << 22).contains(n))
                        .ok_or_else(|| bad("expected a chunk size in 1..=4194304 tets"))?
                        .max(MIN_CHUNK),
                )
            }
            "timevarying" => {
                tv = match v.as_str() {
                    "1" | "true" => true,
                    "0" | "false" => false,
                    _ => return Err(bad("expected 0 or 1")),
                }
            }
            _ => {
                return Err(Error::Input(format!(
                    "hapt: unknown parameter '{k}' (known: mode, iso, iso_alpha, stream, timevarying)"
                )))
            }
        }
    }
    let mode = mode.unwrap_or(Mode::Dvr);
    if mode == Mode::Dvr && !iso.is_empty() {
        return Err(Error::Input(
            "hapt: iso=... draws iso-surfaces only with mode=iso or mode=dvr+iso (mode is dvr)"
                .into(),
        ));
    }
    if mode != Mode::Dvr && iso.is_empty() {
        return Err(Error::Input(format!(
            "hapt: mode={} needs iso=v1,... (scalar units)",
            mode.name()
        )));
    }
    Ok((mode, iso, alpha, stream, tv))
}

impl Hapt {
    pub fn new(o: &RenderOptions) -> Result<Hapt> {
        let (mode, iso, iso_alpha, stream, timevarying) = parse_params(o)?;
        let integrator_name = o.integrator.clone().unwrap_or_else(|| "partial".into());
        let mut sort_name = o.sort.clone().unwrap_or_else(|| "gpu-radix".into());
        let sort = match GpuSortKind::parse(&sort_name) {
            Some(_) if stream.is_some() => {
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
            mode,
            iso,
            iso_alpha,
            stream,
            timevarying,
            state: None,
            frame: 0,
        })
    }
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

impl Hapt {
    fn build(&self, mesh: &Mesh, tf: &TransferFunction) -> Result<State> {
        let gpu = Gpu::shared()?;
        let mut acct = Account::default();
        let n = mesh.num_tets();
        let nv = mesh.num_vertices();
        let stream = self.stream.is_some();
        // Fixed costs first.
        let optics = OpticsTables::new(&gpu, &mut acct, &self.integrator_name, tf)?;
        let table = TfTable::new(tf, TF_SAMPLES);
        let nz = empty_cells(tf, &table);
        let (lo, scale) = table.domain();
        let (name, step) = mesh.active_field();
        let field = mesh
            .fields()
            .iter()
            .find(|f| f.name == name)
            .ok_or_else(|| Error::Internal("hapt: active field not found".into()))?;
        let raw_steps: Vec<&Vec<f64>> = if self.timevarying {
            field.steps.iter().collect()
        } else {
            vec![&field.steps[step]]
        };
        let active_map = scalar_map(tf, mesh.scalars());
        let mut params = HaptParams {
            tf_lo: lo,
            tf_scale: scale,
            tf_cells: (table.data().len() - 1) as u32,
            mode: self.mode.bits(),
            iso_n: self.iso.len() as u32,
            ..Default::default()
        };
        for (i, &v) in self.iso.iter().enumerate() {
            let s = active_map.s(v.scalar(mesh.scalar_range()));
            params.iso_s[i] = s as f32;
            let (c, _) = tf.eval(s);
            params.iso_rgba[i] = [c[0] as f32, c[1] as f32, c[2] as f32, self.iso_alpha];
        }
        let steps: Vec<Vec<f32>> = raw_steps
            .iter()
            .map(|vals| {
                let m = scalar_map(tf, vals);
                vals.iter().map(|&v| m.s(v) as f32).collect()
            })
            .collect();
        let discarded = steps
            .iter()
            .map(|s| count_discarded(mesh, s, &params, &nz))
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
        let stub = |acct: &mut Account, what: &str| acct.buffer(&gpu, what, 16, storage);
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
        let (mut scal, mut order_buf, mut sorter, mut chunk) = (None, None, None, None);
        let (verts_b, scal_b, tets_b, order_b, chunk_b);
        if let Some(cap) = self.stream {
            // Fixed size: the same for every mesh.
            let b = acct.buffer(
                &gpu,
                "hapt chunk",
                64 * cap as u64,
                storage | wgpu::BufferUsages::COPY_DST,
            )?;
            chunk_b = b.clone();
            chunk = Some((b, cap));
            verts_b = stub(&mut acct, "stub")?;
            scal_b = stub(&mut acct, "stub")?;
            tets_b = stub(&mut acct, "stub")?;
            order_b = stub(&mut acct, "stub")?;
        } else {
            verts_b = acct.buffer_init(&gpu, "hapt vertices", bytemuck::cast_slice(&pos), storage)?;
            let sb = acct.buffer_init(
                &gpu,
                "hapt scalars",
                bytemuck::cast_slice(&steps[0]),
                storage,
            )?;
            scal_b = sb.clone();
            scal = Some(sb);
            let tets: Vec<[u32; 4]> = mesh.tets().to_vec();
            tets_b = acct.buffer_init(&gpu, "hapt tets", bytemuck::cast_slice(&tets), storage)?;
            match &self.sort {
                SortChoice::Gpu(kind) => {
                    let cent: Vec<[f32; 3]> = sort::centroids(mesh);
                    let cb = acct.buffer_init(
                        &gpu,
                        "centroids",
                        bytemuck::cast_slice(&cent),
                        storage,
                    )?;
                    let s = GpuSorter::new(&gpu, &mut acct, *kind, n, &cb)?;
                    order_b = s.order().clone();
                    sorter = Some(s);
                }
                SortChoice::Cpu(_) => {
                    let b = acct.buffer(
                        &gpu,
                        "hapt order",
                        4 * n as u64,
                        storage | wgpu::BufferUsages::COPY_DST,
                    )?;
                    order_b = b.clone();
                    order_buf = Some(b);
                }
            }
            chunk_b = stub(&mut acct, "stub")?;
        }
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
        for b in 1..=6 {
            entries.push(shader::storage_entry(b, wgpu::ShaderStages::VERTEX, true));
        }
        let layout2 = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("hapt"),
                entries: &entries,
            });
        let group2 = shader::bind_buffers(
            &gpu,
            "hapt",
            &layout2,
            &[
                &params_buf,
                &verts_b,
                &scal_b,
                &tets_b,
                &order_b,
                &nz_buf,
                &chunk_b,
            ],
        );
        let view_layout = shader::view_layout(&gpu);
        let pipeline = pipeline(
            &gpu,
            &[Some(&optics.layout), Some(&view_layout), Some(&layout2)],
            self.mode,
            stream,
        )?;
        let _ = fixed_before_mesh;
        // Fixed: tables, uniforms, TF cells (and the streaming chunk, by design mesh-independent).
        let fixed_bytes = if stream {
            acct.bytes
        } else {
            fixed_before_mesh + 16
        };
        Ok(State {
            gpu,
            acct,
            fixed_bytes,
            tets: n,
            verts: nv,
            inv_l: {
                let l = mesh.diagonal();
                if l > 0.0 {
                    1.0 / l
                } else {
                    0.0
                }
            },
            tf: tf.clone(),
            table,
            nz,
            steps,
            discarded,
            pos,
            params,
            params_buf,
            view_buf,
            optics,
            group2,
            pipeline,
            scal,
            order_buf,
            sorter,
            chunk,
            target: None,
            order: Vec::new(),
        })
    }
}

impl Renderer for Hapt {
    fn name(&self) -> String {
        "hapt".into()
    }
    fn sort_name(&self) -> String {
        self.sort_name.clone()
    }
    fn integrator_name(&self) -> String {
        self.integrator_name.clone()
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.state = None;
        self.frame = 0;
        if let SortChoice::Cpu(s) = &mut self.sort {
            s.prepare(mesh)?;
            s.set_transfer_function(mesh, tf)?;
        }
        self.state = Some(self.build(mesh, tf)?);
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
        let (w, h) = (camera.width, camera.height);
        if st.target.as_ref().map(|t| (t.0, t.1)) != Some((w, h)) {
            if let Some(t) = st.target.take() {
                st.acct.bytes -= t.3;
                st.fixed_bytes -= t.3;
            }
            let before = st.acct.bytes;
            let tex = st.acct.target(&gpu, w, h)?;
            let bytes = st.acct.bytes - before;
            st.fixed_bytes += bytes;
            st.target = Some((w, h, tex, bytes));
        }
        let view = ViewUniform::new(camera, st.inv_l);
        gpu.queue.write_buffer(&st.view_buf, 0, bytemuck::bytes_of(&view));
        let view_layout = shader::view_layout(&gpu);
        let view_bind = shader::bind_buffers(&gpu, "view", &view_layout, &[&st.view_buf]);
        let mut counters: Vec<(&'static str, f64)> = Vec::new();
        // Time-varying: this frame's step.
        let step = if self.timevarying {
            (frame_no % st.steps.len() as u64) as usize
        } else {
            0
        };
        if self.timevarying {
            let t = Instant::now();
            if let Some(b) = &st.scal {
                gpu.queue
                    .write_buffer(b, 0, bytemuck::cast_slice(&st.steps[step]));
            }
            gpu.wait()?;
            counters.push(("upload_ms", ms_since(t)));
            counters.push(("time_step", step as f64));
        }
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
        let timer = Timer::new(&gpu, 2);
        let mut times = FrameTimes::default();
        let tex = &st.target.as_ref().expect("target").2;
        let tview = tex.create_view(&wgpu::TextureViewDescriptor::default());
        let pass = |enc: &mut wgpu::CommandEncoder, clear: bool, ts: bool| {
            let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("hapt draw"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &tview,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: if clear {
                            wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
                        } else {
                            wgpu::LoadOp::Load
                        },
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: if ts { timer.render(1) } else { None },
                occlusion_query_set: None,
                multiview_mask: None,
            })
            .forget_lifetime();
            rp.set_pipeline(&st.pipeline);
            rp.set_bind_group(0, &st.optics.bind_group, &[]);
            rp.set_bind_group(1, &view_bind, &[]);
            rp.set_bind_group(2, &st.group2, &[]);
            rp
        };
        if let Some((chunk_buf, cap)) = &st.chunk {
            // Streaming: chunk by chunk, each its own upload and submit.
            let t = Instant::now();
            let s = &st.steps[step];
            let mut data: Vec<[f32; 4]> = Vec::with_capacity(4 * cap);
            let mut first = true;
            let mut chunks = 0;
            for part in st.order.chunks(*cap).chain(if st.order.is_empty() {
                Some(&[][..])
            } else {
                None
            }) {
                data.clear();
                for &t in part {
                    for &v in &mesh.tets()[t as usize] {
                        let p = st.pos[v as usize];
                        data.push([p[0], p[1], p[2], s[v as usize]]);
                    }
                }
                if !data.is_empty() {
                    gpu.queue
                        .write_buffer(chunk_buf, 0, bytemuck::cast_slice(&data));
                }
                let mut enc = gpu
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                {
                    let mut rp = pass(&mut enc, first, false);
                    rp.draw(0..12, 0..part.len() as u32);
                }
                gpu.queue.submit([enc.finish()]);
                first = false;
                chunks += 1;
                // Bounded in flight: every queued write holds its staging copy until done.
                if chunks % MAX_IN_FLIGHT == 0 {
                    gpu.wait()?;
                }
            }
            gpu.wait()?;
            times.sort_ms = cpu_sort_ms;
            times.draw_ms = ms_since(t);
            counters.push(("chunks", chunks as f64));
            counters.push(("chunk_tets", *cap as f64));
        } else {
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            let t_sort = Instant::now();
            if let Some(sorter) = &st.sorter {
                let kf = match camera.projection {
                    Projection::Ortho => KeyMode::Axis(sort::f32x3(camera.forward)),
                    Projection::Persp => KeyMode::EyeDist2(sort::f32x3(camera.eye())),
                };
                sorter.set_keys(&gpu, kf);
                sorter.encode(&mut enc, timer.compute(0));
                if !gpu.has_timestamps() {
                    gpu.queue.submit([enc.finish()]);
                    gpu.wait()?;
                    enc = gpu
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                }
            }
            let wall_sort = ms_since(t_sort);
            let t_draw = Instant::now();
            {
                let mut rp = pass(&mut enc, true, true);
                rp.draw(0..12, 0..n);
            }
            timer.resolve(&mut enc);
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            let wall_draw = ms_since(t_draw);
            match timer.read_ms(&gpu)? {
                Some(ms) => {
                    times.sort_ms = cpu_sort_ms + if st.sorter.is_some() { ms[0] } else { 0.0 };
                    times.draw_ms = ms[1];
                }
                None => {
                    times.sort_ms = cpu_sort_ms + wall_sort;
                    times.draw_ms = wall_draw;
                }
            }
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
        let _ = (&st.tf, &st.table, &st.nz, &st.params, &st.params_buf);
        Ok(Frame {
            image,
            times,
            counters,
        })
    }

    fn gpu_bytes(&self) -> u64 {
        self.state.as_ref().map_or(0, |s| s.acct.bytes)
    }

    fn device(&self) -> String {
        match &self.state {
            Some(s) => format!("{} / {:?}", s.gpu.name(), s.gpu.target_format),
            None => match Gpu::shared() {
                Ok(g) => format!("{} / {:?}", g.name(), g.target_format),
                Err(_) => "no GPU".into(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(kv: &[(&str, &str)]) -> Result<Params> {
        parse_params(&RenderOptions {
            params: kv.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            ..Default::default()
        })
    }

    #[test]
    fn iso_values_out_of_range_or_without_an_iso_mode_are_refused() {
        for (kv, what) in [
            (&[("mode", "iso"), ("iso", "200%")][..], "0..=100"),
            (&[("mode", "iso"), ("iso", "30%,-1%")][..], "0..=100"),
            (&[("iso", "0.5")][..], "mode=iso"),
            (&[("mode", "dvr"), ("iso", "0.5")][..], "mode=iso"),
            (&[("mode", "iso")][..], "needs iso"),
        ] {
            let e = params(kv).err().unwrap_or_else(|| panic!("{kv:?} accepted")).to_string();
            assert!(e.starts_with("hapt: ") && e.contains(what), "{kv:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        assert!(params(&[("mode", "iso"), ("iso", "0%,100%,0.5")]).is_ok());
        assert!(params(&[("mode", "dvr+iso"), ("iso", "30%,60%")]).is_ok());
    }

    #[test]
    fn tiny_stream_chunks_are_raised_to_the_floor() {
        assert_eq!(params(&[("stream", "1")]).unwrap().3, Some(MIN_CHUNK));
        assert_eq!(params(&[("stream", "5000")]).unwrap().3, Some(5000));
        assert!(params(&[("stream", "0")]).is_err());
    }
}
