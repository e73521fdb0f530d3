//! WGSL composition for the GPU renderers and the pieces of their pipelines they share. Each
//! shader stage is one file beside the code that runs it (`*.comp.wgsl`, `*.vert.wgsl`,
//! `*.frag.wgsl`); the functions several stages share live in library files that [`compose`]
//! prepends: the ones here (`view.wgsl`, `classify.wgsl`, `volume.wgsl`), `optics.wgsl` beside
//! the integrators' tables (`optics::gpu`) and each renderer's own. A stage is
//! composed after a generated prelude: for the projected-tetrahedra stages the classification
//! table of `render::pt::table_wgsl`, so no WGSL function is written twice and the
//! table is never retyped.
//!
//! Bind groups shared by the stages: `@group(0)` the integrator's tables
//! (`optics::gpu::OpticsTables`), `@group(1)` the view ([`ViewUniform`]), `@group(2)` the
//! renderer's own buffers.

use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};

use super::Gpu;

/// Library: the camera uniform, projection and snapping (CONVENTIONS §2, `camera::snap`).
pub const VIEW: &str = include_str!("view.wgsl");
/// Library: exact classification (`render::pt::classify`) on 64-bit integers emulated in u32
/// pairs.
pub const CLASSIFY: &str = include_str!("classify.wgsl");
/// Library: `VolumeVarying`, what a vertex stage hands `volume.frag.wgsl`, and its builders.
pub const VOLUME: &str = include_str!("volume.wgsl");

/// Fragment stage of the volume (premultiplied, "over" with `One, OneMinusSrcAlpha`).
pub const VOLUME_FRAG: &str = include_str!("volume.frag.wgsl");

/// The source of one stage: the prelude, then the libraries in order, then the stage.
pub fn compose(prelude: &str, stage: &str, libs: &[&str]) -> String {
    let mut s = prelude.to_string();
    for l in libs {
        s.push('\n');
        s.push_str(l);
    }
    s.push('\n');
    s.push_str(stage);
    s
}

/// Compiles a composed stage; a WGSL error (a bug, never bad input) comes back as
/// `Error::Internal` naming the stage.
pub fn module(
    gpu: &Gpu,
    name: &str,
    prelude: &str,
    stage: &str,
    libs: &[&str],
) -> Result<wgpu::ShaderModule> {
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let m = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(compose(prelude, stage, libs).into()),
        });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Internal(format!("shader {name}: {e}")));
    }
    Ok(m)
}

/// The `View` uniform of `view.wgsl` (96 bytes, std140-compatible layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ViewUniform {
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub to_eye: [f32; 4],
    pub eye: [f32; 4],
    pub size: [f32; 2],
    pub pixel: f32,
    pub radius: f32,
    pub inv_l: f32,
    pub persp: u32,
    pub _pad: [u32; 2],
}

impl ViewUniform {
    /// The uniform of `camera`, positions in the frame centred on the bounding-box centre.
    pub fn new(camera: &Camera, inv_l: f64) -> ViewUniform {
        let v4 = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        ViewUniform {
            right: v4(camera.right),
            up: v4(camera.up),
            to_eye: v4(camera.to_eye),
            eye: v4(camera.eye()),
            size: [camera.width as f32, camera.height as f32],
            pixel: camera.pixel as f32,
            radius: camera.radius as f32,
            inv_l: inv_l as f32,
            persp: (camera.projection == Projection::Persp) as u32,
            _pad: [0; 2],
        }
    }
}

/// Layout of `@group(1)`: the view uniform, seen by every stage.
pub fn view_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        })
}

/// A storage-buffer layout entry at `binding` for `visibility`.
pub fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A bind group of whole buffers at bindings 0, 1, …
pub fn bind_buffers(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// The render pipeline of the volume: a vertex stage feeding `volume.frag.wgsl`, triangles
/// without culling, premultiplied "over" (`One, OneMinusSrcAlpha`, CONVENTIONS §4) into the
/// context's float target ([`Gpu::target_format`]). Used by `ptint`'s pass 2 and `hapt`'s single
/// pass; `fs_entry` is `fs_volume`, or hapt's iso-surface fragment stage.
pub fn volume_pipeline(
    gpu: &Gpu,
    layout: &wgpu::PipelineLayout,
    vs: &wgpu::ShaderModule,
    vs_entry: &str,
    fs: &wgpu::ShaderModule,
    fs_entry: &str,
) -> wgpu::RenderPipeline {
    let over = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    };
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("volume"),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module: vs,
                entry_point: Some(vs_entry),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: fs,
                entry_point: Some(fs_entry),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: gpu.target_format,
                    blend: Some(wgpu::BlendState {
                        color: over,
                        alpha: over,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
}
