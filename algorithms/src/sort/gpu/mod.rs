//! GPU visibility sorts of `hapt` (HAPT §3, "sorting on the GPU"): `gpu-radix` and
//! `gpu-bitonic`, over the centroid keys of [`crate::sort`] computed on the GPU.
//!
//! **Keys** (`sort_keys.comp.wgsl`): one thread per tet reads its centred f32 centroid (the
//! same values the CPU centroid sorts hold, computed once in f64 on the CPU at `prepare` and
//! uploaded, 12 bytes a tet) and computes the key in f32 as the CPU does: ortho `c · forward`,
//! persp `|c − eye|²`. The key becomes u32 bits whose ascending order is the key's *descending*
//! IEEE total order (`sort::desc_bits`: `+0.0` before `−0.0`, farther first); the value is the
//! tet index. The GPU may contract `a·b + c` into a fused multiply-add, so a key can differ from
//! the CPU's by an ulp and two nearly equal keys swap: the order then differs from
//! `centroid-radix` only between tets of (nearly) equal depth. On the *same* keys (mode "raw",
//! [`sort_f32_keys`]) the orders are identical, which `tests/tests/gpu/sort.rs` checks.
//!
//! **`gpu-radix`**: LSD radix sort, 4 passes of 8 bits; per pass a histogram of each block of
//! 1024 keys (`radix_hist`), one exclusive scan of the digit-major histograms (`radix_scan`), and
//! a *stable* scatter (`radix_scatter`: per 256-element chunk, the rank among equal digits is a
//! popcount of per-digit bit masks, chunks in element order). Stable passes over keys that start
//! in index order leave ties in index order: exactly `centroid-radix`'s order. The even number of
//! passes leaves the result in the first buffer pair.
//!
//! **`gpu-bitonic`**: Batcher's bitonic network over (key, index) pairs padded to a power of
//! two, one dispatch per compare-exchange step; pairs compare by key then index, so the order is
//! the same.

use crate::error::{Error, Result};
use crate::gpu::{Account, Gpu};

/// Which GPU sort.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuSortKind {
    Radix,
    Bitonic,
}

impl GpuSortKind {
    pub fn parse(name: &str) -> Option<GpuSortKind> {
        match name {
            "gpu-radix" => Some(GpuSortKind::Radix),
            "gpu-bitonic" => Some(GpuSortKind::Bitonic),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            GpuSortKind::Radix => "gpu-radix",
            GpuSortKind::Bitonic => "gpu-bitonic",
        }
    }
}

const WG: u32 = 256;
const BLOCK: u32 = 1024;
const MAX_X: u32 = 65535;

const COMMON: &str = include_str!("sort_common.wgsl");

fn module(gpu: &Gpu, label: &str, stage: &str) -> wgpu::ShaderModule {
    let src = format!("{COMMON}\n{stage}");
    gpu.device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        })
}

fn pipeline(gpu: &Gpu, label: &str, stage: &str) -> wgpu::ComputePipeline {
    let m = module(gpu, label, stage);
    gpu.device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: None,
            module: &m,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        })
}

/// Workgroup grid for `groups` workgroups (2-D beyond 65535), or one line when even the
/// square grid cannot hold them.
fn grid(groups: u64) -> Result<(u32, u32)> {
    crate::util::size::dispatch_grid(groups, 1, MAX_X).ok_or_else(|| {
        Error::Input(format!(
            "GPU sort: {groups} workgroups exceed the dispatch limit"
        ))
    })
}

fn entries<'a>(bufs: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    bufs.iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
}

fn bind(gpu: &Gpu, p: &wgpu::ComputePipeline, bufs: &[&wgpu::Buffer]) -> wgpu::BindGroup {
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &p.get_bind_group_layout(0),
        entries: &entries(bufs),
    })
}

/// Key mode of the key stage.
#[derive(Clone, Copy, Debug)]
pub enum KeyMode {
    /// `c · forward`.
    Axis([f32; 3]),
    /// `|c − eye|²`.
    EyeDist2([f32; 3]),
    /// The input buffer holds the f32 keys themselves.
    Raw,
}

/// Keys and a GPU sort for `n` elements: the sorted tet indices end in [`GpuSorter::order`].
pub struct GpuSorter {
    pub kind: GpuSortKind,
    n: u32,
    keys: wgpu::Buffer,
    vals: wgpu::Buffer,
    key_params: wgpu::Buffer,
    key_pipe: wgpu::ComputePipeline,
    key_bind: wgpu::BindGroup,
    key_groups: (u32, u32),
    steps: Vec<Step>,
}

struct Step {
    pipe: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    groups: (u32, u32),
}

impl GpuSorter {
    /// A sorter over `n` elements whose key inputs (centroids, 3 f32 a tet, or raw f32 keys) are
    /// in `input`. Buffers are counted in `acct`.
    pub fn new(
        gpu: &Gpu,
        acct: &mut Account,
        kind: GpuSortKind,
        n: usize,
        input: &wgpu::Buffer,
    ) -> Result<GpuSorter> {
        let n32 = u32::try_from(n)
            .ok()
            .filter(|&x| x < u32::MAX / 2)
            .ok_or_else(|| Error::Input(format!("{}: {n} keys are too many", kind.name())))?;
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let len = match kind {
            GpuSortKind::Radix => n32.max(1),
            GpuSortKind::Bitonic => n32.max(1).next_power_of_two(),
        } as u64;
        let keys = acct.buffer(gpu, "sort keys", 4 * len, storage)?;
        let vals = acct.buffer(gpu, "sort values", 4 * len, storage)?;
        let key_params = acct.buffer(gpu, "key params", 32, uniform)?;
        let key_pipe = pipeline(gpu, "sort_keys", include_str!("sort_keys.comp.wgsl"));
        let key_bind = bind(gpu, &key_pipe, &[&key_params, input, &keys, &vals]);
        let mut steps = Vec::new();
        match kind {
            GpuSortKind::Radix => {
                let nblocks = n32.div_ceil(BLOCK).max(1);
                let keys2 = acct.buffer(gpu, "sort keys 2", 4 * len, storage)?;
                let vals2 = acct.buffer(gpu, "sort values 2", 4 * len, storage)?;
                let hist =
                    acct.buffer(gpu, "radix histograms", 4 * 256 * nblocks as u64, storage)?;
                let hist_p = pipeline(gpu, "radix_hist", include_str!("radix_hist.comp.wgsl"));
                let scan_p = pipeline(gpu, "radix_scan", include_str!("radix_scan.comp.wgsl"));
                let scat_p = pipeline(
                    gpu,
                    "radix_scatter",
                    include_str!("radix_scatter.comp.wgsl"),
                );
                for pass in 0..4u32 {
                    let params = acct.buffer(gpu, "radix params", 16, uniform)?;
                    gpu.queue.write_buffer(
                        &params,
                        0,
                        bytemuck::cast_slice(&[n32, nblocks, 8 * pass, 0]),
                    );
                    let (src_k, src_v, dst_k, dst_v) = if pass % 2 == 0 {
                        (&keys, &vals, &keys2, &vals2)
                    } else {
                        (&keys2, &vals2, &keys, &vals)
                    };
                    steps.push(Step {
                        bind: bind(gpu, &hist_p, &[&params, src_k, &hist]),
                        pipe: hist_p.clone(),
                        groups: grid(nblocks.into())?,
                    });
                    steps.push(Step {
                        bind: bind(gpu, &scan_p, &[&params, &hist]),
                        pipe: scan_p.clone(),
                        groups: (1, 1),
                    });
                    steps.push(Step {
                        bind: bind(gpu, &scat_p, &[&params, src_k, src_v, dst_k, dst_v, &hist]),
                        pipe: scat_p.clone(),
                        groups: grid(nblocks.into())?,
                    });
                }
            }
            GpuSortKind::Bitonic => {
                // Padding sorts last and stays at the end, so it is written once.
                let pad = vec![u32::MAX; (len - n32 as u64) as usize];
                if !pad.is_empty() {
                    let at = 4 * n32 as u64;
                    gpu.queue
                        .write_buffer(&keys, at, bytemuck::cast_slice(&pad));
                    gpu.queue
                        .write_buffer(&vals, at, bytemuck::cast_slice(&pad));
                }
                let p = pipeline(gpu, "bitonic", include_str!("bitonic.comp.wgsl"));
                let groups = grid(len.div_ceil(WG.into()))?;
                let mut k = 2u32;
                while k as u64 <= len {
                    let mut j = k / 2;
                    while j > 0 {
                        let params = acct.buffer(gpu, "bitonic params", 16, uniform)?;
                        gpu.queue
                            .write_buffer(&params, 0, bytemuck::cast_slice(&[k, j, 0, 0]));
                        steps.push(Step {
                            bind: bind(gpu, &p, &[&params, &keys, &vals]),
                            pipe: p.clone(),
                            groups,
                        });
                        j /= 2;
                    }
                    k *= 2;
                }
            }
        }
        Ok(GpuSorter {
            kind,
            n: n32,
            keys,
            vals,
            key_params,
            key_pipe,
            key_bind,
            key_groups: grid(u64::from(n32).div_ceil(WG.into()))?,
            steps,
        })
    }

    /// Sets the key function for the next [`GpuSorter::encode`].
    pub fn set_keys(&self, gpu: &Gpu, mode: KeyMode) {
        let (v, m) = match mode {
            KeyMode::Axis(f) => (f, 0u32),
            KeyMode::EyeDist2(e) => (e, 1),
            KeyMode::Raw => ([0.0; 3], 2),
        };
        let mut b = [0u32; 8];
        for i in 0..3 {
            b[i] = v[i].to_bits();
        }
        b[4] = self.n;
        b[5] = m;
        gpu.queue
            .write_buffer(&self.key_params, 0, bytemuck::cast_slice(&b));
    }

    /// Records the key stage and the sort into one compute pass (timed as pass `timer_pass`).
    pub fn encode(
        &self,
        enc: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gpu sort"),
            timestamp_writes: ts,
        });
        if self.n == 0 {
            return;
        }
        pass.set_pipeline(&self.key_pipe);
        pass.set_bind_group(0, &self.key_bind, &[]);
        pass.dispatch_workgroups(self.key_groups.0, self.key_groups.1, 1);
        for s in &self.steps {
            pass.set_pipeline(&s.pipe);
            pass.set_bind_group(0, &s.bind, &[]);
            pass.dispatch_workgroups(s.groups.0, s.groups.1, 1);
        }
    }

    /// The sorted tet indices (the first `n` entries), farthest first.
    pub fn order(&self) -> &wgpu::Buffer {
        &self.vals
    }

    /// The sorted key bits (the first `n` entries).
    pub fn keys(&self) -> &wgpu::Buffer {
        &self.keys
    }
}

/// Sorts f32 keys on the GPU (farthest = largest first, ties by index) and reads the order back:
/// the test entry point that compares the GPU sorts with `centroid-radix` on the same keys.
pub fn sort_f32_keys(gpu: &Gpu, kind: GpuSortKind, keys: &[f32]) -> Result<Vec<u32>> {
    let mut acct = Account::default();
    let input = acct.buffer_init(
        gpu,
        "raw keys",
        bytemuck::cast_slice(keys),
        wgpu::BufferUsages::STORAGE,
    )?;
    let s = GpuSorter::new(gpu, &mut acct, kind, keys.len(), &input)?;
    s.set_keys(gpu, KeyMode::Raw);
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    s.encode(&mut enc, None);
    gpu.queue.submit([enc.finish()]);
    let raw = gpu.read_buffer(s.order(), 0, 4 * keys.len() as u64)?;
    Ok(bytemuck::cast_slice(&raw).to_vec())
}
