//! The frame's draw: the render pass every mode draws in, the resident draw (GPU sort, then
//! one instanced draw), and the streamed one (the sorted tets gathered and uploaded chunk by
//! chunk, each chunk its own pass and submit).

use std::time::Instant;

use super::pipeline::State;
use crate::camera::{Camera, Projection};
use crate::error::Result;
use crate::gpu::{wgpu, Gpu, Timer};
use crate::mesh::Mesh;
use crate::render::{ms_since, FrameTimes};
use crate::sort::{self, gpu::KeyMode};

/// Chunks submitted before the frame waits for the GPU, so that staging memory stays bounded.
const MAX_IN_FLIGHT: usize = 4;

/// What one frame draws with: the target's view and the view's bind group.
pub(super) struct Target<'a> {
    pub view: &'a wgpu::TextureView,
    pub view_bind: &'a wgpu::BindGroup,
}

/// A render pass into the target (cleared first, or loaded), with `hapt`'s pipeline and bind
/// groups set.
fn begin_pass(
    enc: &mut wgpu::CommandEncoder,
    st: &State,
    target: &Target,
    clear: bool,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'static> {
    let mut rp = enc
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hapt draw"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target.view,
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
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        })
        .forget_lifetime();
    rp.set_pipeline(&st.pipeline);
    rp.set_bind_group(0, &st.optics.bind_group, &[]);
    rp.set_bind_group(1, target.view_bind, &[]);
    rp.set_bind_group(2, &st.group2, &[]);
    rp
}

/// Resident mode: the GPU sort (if the order comes from the GPU), then one instanced draw of
/// `n` tets, 12 vertices each. Times by timestamp queries where the adapter has them, else by
/// the wall clock around each submit.
pub(super) fn draw_resident(
    gpu: &Gpu,
    st: &State,
    target: &Target,
    camera: &Camera,
    n: u32,
    cpu_sort_ms: f64,
    times: &mut FrameTimes,
) -> Result<()> {
    let timer = Timer::new(gpu, 2);
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    let t_sort = Instant::now();
    if let Some(sorter) = &st.sorter {
        let kf = match camera.projection {
            Projection::Ortho => KeyMode::Axis(sort::f32x3(camera.forward)),
            Projection::Persp => KeyMode::EyeDist2(sort::f32x3(camera.eye())),
        };
        sorter.set_keys(gpu, kf);
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
        let mut rp = begin_pass(&mut enc, st, target, true, timer.render(1));
        rp.draw(0..12, 0..n);
    }
    timer.resolve(&mut enc);
    gpu.queue.submit([enc.finish()]);
    gpu.wait()?;
    let wall_draw = ms_since(t_draw);
    match timer.read_ms(gpu)? {
        Some(ms) => {
            times.sort_ms = cpu_sort_ms + if st.sorter.is_some() { ms[0] } else { 0.0 };
            times.draw_ms = ms[1];
        }
        None => {
            times.sort_ms = cpu_sort_ms + wall_sort;
            times.draw_ms = wall_draw;
        }
    }
    Ok(())
}

/// Streaming mode: the CPU sort's order in chunks of the chunk buffer's capacity, each chunk's
/// tets gathered with their four vertices' (x, y, z, s) of time step `step`, uploaded and
/// drawn; at most [`MAX_IN_FLIGHT`] chunks in flight. Returns the number of chunks.
pub(super) fn draw_streamed(
    gpu: &Gpu,
    st: &State,
    target: &Target,
    mesh: &Mesh,
    step: usize,
) -> Result<usize> {
    let Some((chunk_buf, cap)) = &st.chunk else {
        return Ok(0);
    };
    let s = &st.steps[step];
    let mut data: Vec<[f32; 4]> = Vec::with_capacity(4 * cap);
    let mut first = true;
    let mut chunks = 0;
    // An empty order still clears the target: one empty chunk.
    let empty: Option<&[u32]> = st.order.is_empty().then_some(&[]);
    for part in st.order.chunks(*cap).chain(empty) {
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
            let mut rp = begin_pass(&mut enc, st, target, first, None);
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
    Ok(chunks)
}
