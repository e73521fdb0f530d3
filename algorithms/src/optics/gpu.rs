//! The integrator's tables on the GPU (`@group(0)` of `optics.wgsl`): the same f32 tables
//! `cpu-pt`'s fast path reads ([`FastIntegrator`]: the TF samples, Ψ, the pre-integration
//! table), uploaded as storage buffers with an [`OpticsParams`] uniform. The WGSL `segment`
//! ports [`FastIntegrator::segment`] line by line; the test below compares them.

use crate::error::{Error, Result};
use crate::optics::fast::FastIntegrator;
use crate::optics::PreintTable;
use crate::tf::TransferFunction;

use crate::gpu::{shader, Account, Gpu};

/// Library: `segment(s_f, s_b, l)` for `average`, `partial`, `preint` (port of
/// [`FastIntegrator::segment`]).
pub const OPTICS: &str = include_str!("optics.wgsl");
/// Test-only compute stage evaluating `segment` on a list of triples.
#[cfg(test)]
const OPTICS_TEST_COMP: &str = include_str!("optics_test.comp.wgsl");

/// The integrators the GPU renderers take (`exact` stays on the CPU: it is the ground truth).
pub const GPU_INTEGRATORS: [&str; 3] = [
    crate::optics::AVERAGE.name,
    crate::optics::PARTIAL.name,
    crate::optics::PREINT.name,
];

/// `OpticsParams` of `optics.wgsl` (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OpticsParams {
    pub kind: u32,
    pub tf_n: u32,
    pub psi_n: u32,
    pub pre_ns: u32,
    pub tf_lo: f32,
    pub tf_scale: f32,
    pub pre_nl: u32,
    pub pre_lo: f32,
    pub pre_scale: f32,
    pub pre_l_max: f32,
    pub pre_l0: f32,
    pub pre_l_norm: f32,
}

/// The tables of one integrator and transfer function, with their bind group.
pub struct OpticsTables {
    pub params: OpticsParams,
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    /// Bytes of the buffers (mesh-independent: reported as fixed costs).
    pub bytes: u64,
    _buffers: [wgpu::Buffer; 4],
}

impl OpticsTables {
    /// The layout entries of `@group(0)` for `visibility` (the fragment stage; compute too
    /// for the tests).
    pub fn layout_entries(visibility: wgpu::ShaderStages) -> [wgpu::BindGroupLayoutEntry; 4] {
        [
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            shader::storage_entry(1, visibility, true),
            shader::storage_entry(2, visibility, true),
            shader::storage_entry(3, visibility, true),
        ]
    }

    /// Uploads the tables of `integrator` (`average`, `partial`, `preint`) for `tf`; the
    /// bytes are counted in `acct`. Tables an integrator does not read are 16-byte stubs.
    pub fn new(
        gpu: &Gpu,
        acct: &mut Account,
        integrator: &str,
        tf: &TransferFunction,
    ) -> Result<OpticsTables> {
        let fast = FastIntegrator::new(integrator, tf).ok_or_else(|| {
            Error::Input(format!(
                "the GPU renderers take the integrators {}, not '{integrator}'",
                GPU_INTEGRATORS.join(", ")
            ))
        })?;
        let before = acct.bytes;
        let mut p = OpticsParams {
            tf_n: 2,
            psi_n: 2,
            pre_ns: 2,
            pre_nl: 2,
            pre_l_max: PreintTable::L_MAX as f32,
            pre_l0: PreintTable::L0 as f32,
            pre_l_norm: (1.0 / (PreintTable::L_MAX / PreintTable::L0).ln_1p()) as f32,
            ..Default::default()
        };
        let stub = [0u8; 16];
        let (mut tf_bytes, mut psi_bytes, mut pre_bytes): (&[u8], &[u8], &[u8]) =
            (&stub, &stub, &stub);
        match &fast {
            FastIntegrator::Average(t) | FastIntegrator::Partial(t, _) => {
                let (lo, scale) = t.domain();
                p.tf_lo = lo;
                p.tf_scale = scale;
                p.tf_n = t.data().len() as u32;
                tf_bytes = bytemuck::cast_slice(t.data());
            }
            FastIntegrator::Preint(_) => {}
        }
        match &fast {
            FastIntegrator::Average(_) => p.kind = 0,
            FastIntegrator::Partial(_, psi) => {
                p.kind = 1;
                p.psi_n = psi.size() as u32;
                psi_bytes = bytemuck::cast_slice(psi.data());
            }
            FastIntegrator::Preint(t) => {
                p.kind = 2;
                let [n_s, _, n_l] = t.dims();
                let [s_lo, s_hi] = t.s_range();
                p.pre_ns = n_s as u32;
                p.pre_nl = n_l as u32;
                p.pre_lo = s_lo as f32;
                p.pre_scale = ((n_s - 1) as f64 / (s_hi - s_lo)) as f32;
                pre_bytes = bytemuck::cast_slice(t.data());
            }
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let params = acct.buffer_init(
            gpu,
            "optics params",
            bytemuck::bytes_of(&p),
            wgpu::BufferUsages::UNIFORM,
        )?;
        let tfb = acct.buffer_init(gpu, "tf table", tf_bytes, storage)?;
        let psib = acct.buffer_init(gpu, "psi table", psi_bytes, storage)?;
        let preb = acct.buffer_init(gpu, "preint table", pre_bytes, storage)?;
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("optics"),
                entries: &Self::layout_entries(
                    wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ),
            });
        let bind_group =
            shader::bind_buffers(gpu, "optics", &layout, &[&params, &tfb, &psib, &preb]);
        Ok(OpticsTables {
            params: p,
            layout,
            bind_group,
            bytes: acct.bytes - before,
            _buffers: [params, tfb, psib, preb],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::test_gpu;

    /// `segment` on the GPU against `FastIntegrator::segment` on a grid of (s_f, s_b, l),
    /// including l = 0, negative, NaN and ∞ ends, s outside [0, 1], and a TF with a very
    /// large extinction.
    #[test]
    fn gpu_segment_matches_fast_integrator() {
        let Some(gpu) = test_gpu("gpu_segment_matches_fast_integrator") else {
            return;
        };
        let mut input: Vec<[f32; 4]> = Vec::new();
        let ss = [-0.3f32, 0.0, 0.1, 0.25, 0.4, 0.5, 0.66, 0.7, 0.9, 1.0, 1.2];
        let ls = [
            -1.0f32, 0.0, 1e-7, 1e-5, 1e-3, 0.004, 0.02, 0.1, 0.3, 0.8, 1.0, 2.5, 1e3,
        ];
        for &sf in &ss {
            for &sb in &ss {
                for &l in &ls {
                    input.push([sf, sb, l, 0.0]);
                }
            }
        }
        input.push([f32::NAN, 0.5, 0.1, 0.0]);
        input.push([0.5, f32::INFINITY, 0.1, 0.0]);
        input.push([0.5, 0.5, f32::NAN, 0.0]);
        input.push([0.5, 0.5, f32::INFINITY, 0.0]);
        let tfs = [
            TransferFunction::preset("default").unwrap(),
            TransferFunction {
                name: "steep".into(),
                range: Some([0.0, 1.0]),
                points: vec![
                    crate::tf::TfPoint {
                        s: 0.0,
                        rgb: [0.1, 0.2, 0.9],
                        tau: 0.0,
                    },
                    crate::tf::TfPoint {
                        s: 0.5,
                        rgb: [1.0, 0.5, 0.0],
                        tau: 40.0,
                    },
                    crate::tf::TfPoint {
                        s: 1.0,
                        rgb: [1.0, 1.0, 1.0],
                        tau: 1e6,
                    },
                ],
            },
        ];
        let inl = wgpu::ShaderStages::COMPUTE;
        for tf in &tfs {
            for integ in GPU_INTEGRATORS {
                let mut acct = Account::default();
                let tables = OpticsTables::new(&gpu, &mut acct, integ, tf).unwrap();
                let got = run_segments(&gpu, &mut acct, &tables, &input, inl);
                let fast = FastIntegrator::new(integ, tf).unwrap();
                let mut worst = 0.0f32;
                for (x, g) in input.iter().zip(&got) {
                    let want = fast.segment(x[0], x[1], x[2]);
                    for c in 0..4 {
                        assert!(g[c].is_finite(), "{integ} {x:?}: {g:?}");
                        let d = (g[c] - want[c]).abs();
                        if d > worst {
                            worst = d;
                        }
                        assert!(
                            d <= 1e-5,
                            "{} {integ} {x:?}: gpu {g:?} cpu {want:?}",
                            tf.name
                        );
                    }
                }
                eprintln!("{} {integ}: max |gpu - cpu| = {worst:e}", tf.name);
            }
        }
    }

    fn run_segments(
        gpu: &Gpu,
        acct: &mut Account,
        tables: &OpticsTables,
        input: &[[f32; 4]],
        vis: wgpu::ShaderStages,
    ) -> Vec<[f32; 4]> {
        let st = wgpu::BufferUsages::STORAGE;
        let inb = acct
            .buffer_init(gpu, "in", bytemuck::cast_slice(input), st)
            .unwrap();
        let outb = acct
            .buffer(
                gpu,
                "out",
                (input.len() * 16) as u64,
                st | wgpu::BufferUsages::COPY_SRC,
            )
            .unwrap();
        let own = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: None,
                entries: &[
                    shader::storage_entry(0, vis, true),
                    shader::storage_entry(1, vis, false),
                ],
            });
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: None,
                bind_group_layouts: &[Some(&tables.layout), None, Some(&own)],
                immediate_size: 0,
            });
        let m = shader::module(
            gpu,
            "optics_test.comp.wgsl",
            "",
            OPTICS_TEST_COMP,
            &[OPTICS],
        )
        .unwrap();
        let pipe = gpu
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: None,
                layout: Some(&layout),
                module: &m,
                entry_point: Some("cs_optics_test"),
                compilation_options: Default::default(),
                cache: None,
            });
        let bg = shader::bind_buffers(gpu, "test", &own, &[&inb, &outb]);
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            pass.set_pipeline(&pipe);
            pass.set_bind_group(0, &tables.bind_group, &[]);
            pass.set_bind_group(2, &bg, &[]);
            pass.dispatch_workgroups((input.len() as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([enc.finish()]);
        let raw = gpu
            .read_buffer(&outb, 0, (input.len() * 16) as u64)
            .unwrap();
        bytemuck::cast_slice::<u8, [f32; 4]>(&raw).to_vec()
    }
}
