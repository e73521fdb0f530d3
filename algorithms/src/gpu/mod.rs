//! The shared GPU context of the wgpu renderers (`ptint`, `hapt`): adapter choice, device with
//! checked limits, buffer accounting, timestamp queries and readback. Headless: no window, no
//! surface. One device per process, made on first use and shared (creating one costs ~60 ms on
//! lavapipe and much more on some drivers).
//!
//! **Adapter choice.** Every adapter of every backend is listed; `TETBENCH_ADAPTER` picks one by
//! index (as `tetbench list` numbers them) or by a case-insensitive part of its name. Without
//! it: an adapter that blends `Rgba32Float` first, then a discrete GPU, integrated, virtual, CPU
//! (lavapipe) and other; within a type, Vulkan/Metal/DX12 before GL. `WGPU_BACKEND=vulkan|gl|…`
//! restricts the backends listed.
//!
//! **Render target.** `Rgba32Float`, blended in f32. An adapter that cannot blend it (no
//! `FLOAT32_BLENDABLE`: wgpu's GL backend, e.g. llvmpipe where no Vulkan driver is installed)
//! is refused with one line naming the format: its only blendable float target, `Rgba16Float`,
//! put `ptint` and `hapt` ~25× further from `cpu-pt` (RMSE 1.3e-3 against 5.1e-5 on Vulkan,
//! cube lattice, `partial`, 128²), too far for the image error they are measured by.
//!
//! **Tests.** [`test_gpu`] returns the context, or — when no adapter exists — panics if
//! `TETBENCH_REQUIRE_GPU=1` (CI sets it: a missing driver is a failure) and otherwise prints
//! that the test was skipped and returns `None`.
//!
//! Past 600 lines only with its tests (about 560 lines of code): the context is one job.

pub mod shader;

use std::sync::{Arc, OnceLock};
use std::time::Instant;

use crate::error::{Error, Result};
use crate::image::Image;

pub use wgpu;

/// The device, its queue and what the adapter can do.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub features: wgpu::Features,
    pub limits: wgpu::Limits,
    /// The render target's format, `Rgba32Float` (see the module docs); the renderers report it.
    pub target_format: wgpu::TextureFormat,
    /// The first uncaptured device error not yet reported ([`Gpu::take_error`]).
    last_error: Arc<std::sync::Mutex<Option<String>>>,
}

/// A wgpu error as one line (its Display can span several).
fn one_line_error(e: &wgpu::Error) -> String {
    let s = match e {
        wgpu::Error::OutOfMemory { .. } => "out of memory".to_string(),
        e => e.to_string(),
    };
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

static GPU: OnceLock<std::result::Result<Arc<Gpu>, String>> = OnceLock::new();

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

/// Every adapter the instance lists, in the order `TETBENCH_ADAPTER=<index>` counts them.
pub fn adapters() -> Vec<wgpu::AdapterInfo> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()))
        .iter()
        .map(|a| a.get_info())
        .collect()
}

/// `TETBENCH_ADAPTER`'s choice among `all`: a number is an index only (`2` never matches "256
/// bits" in a name); anything else is a case-insensitive part of the name.
fn pick_adapter<'a, A>(want: &str, all: &'a [A], name: impl Fn(&A) -> String) -> Option<&'a A> {
    if let Ok(i) = want.parse::<usize>() {
        return all.get(i);
    }
    let lower = want.to_lowercase();
    all.iter().find(|a| name(a).to_lowercase().contains(&lower))
}

fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let ty = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (ty, backend)
}

/// One line naming an adapter: `name (backend, type)`.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

impl Gpu {
    /// The device a GPU renderer reports: the adapter and the target format of `held` (the
    /// context it holds), else of the shared context, else `no GPU`.
    pub fn label(held: Option<&Gpu>) -> String {
        let shared;
        let gpu = match held {
            Some(g) => g,
            None => match Gpu::shared() {
                Ok(g) => {
                    shared = g;
                    &*shared
                }
                Err(_) => return "no GPU".into(),
            },
        };
        format!("{} / {:?}", gpu.name(), gpu.target_format)
    }

    /// The process-wide context, made on first use. An error (no adapter, a refused device) is
    /// remembered and returned to every later caller.
    pub fn shared() -> Result<Arc<Gpu>> {
        GPU.get_or_init(|| Gpu::create().map(Arc::new))
            .clone()
            .map_err(Error::Input)
    }

    fn create() -> std::result::Result<Gpu, String> {
        let all = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()));
        if all.is_empty() {
            return Err(
                "no GPU adapter found (on Debian: apt-get install mesa-vulkan-drivers \
                        libvulkan1 for the software Vulkan driver)"
                    .into(),
            );
        }
        let adapter = match std::env::var("TETBENCH_ADAPTER") {
            Ok(want) if !want.trim().is_empty() => {
                let want = want.trim();
                pick_adapter(want, &all, |a| a.get_info().name).ok_or_else(|| {
                    let names: Vec<String> = all
                        .iter()
                        .enumerate()
                        .map(|(i, a)| format!("{i}: {}", describe(&a.get_info())))
                        .collect();
                    format!(
                        "TETBENCH_ADAPTER={want} matches no adapter (have: {})",
                        names.join("; ")
                    )
                })?
            }
            _ => all
                .iter()
                .min_by_key(|a| {
                    let f32_blend = a.features().contains(wgpu::Features::FLOAT32_BLENDABLE);
                    (!f32_blend, rank(&a.get_info()))
                })
                .expect("non-empty"),
        };
        let info = adapter.get_info();
        let have = adapter.features();
        if !have.contains(wgpu::Features::FLOAT32_BLENDABLE) {
            return Err(format!(
                "GPU adapter {} cannot blend Rgba32Float (no FLOAT32_BLENDABLE), and on its \
                 Rgba16Float target the GPU renderers are ~25x further from cpu-pt than on f32: \
                 not used (on Linux without a GPU: apt-get install mesa-vulkan-drivers)",
                describe(&info)
            ));
        }
        let wanted = wgpu::Features::FLOAT32_BLENDABLE | wgpu::Features::TIMESTAMP_QUERY;
        let features = have & wanted;
        let limits = adapter.limits();
        // What both renderers need at the least; the per-mesh buffer sizes are checked by
        // `check_buffer` when the mesh is uploaded.
        if limits.max_storage_buffers_per_shader_stage < 8 {
            return Err(format!(
                "GPU adapter {} allows {} storage buffers per shader stage; tetbench needs 8",
                describe(&info),
                limits.max_storage_buffers_per_shader_stage
            ));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tetbench"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| format!("GPU adapter {}: device refused: {e}", describe(&info)))?;
        // Device errors (out of memory above all) are remembered, not a panic: `wait` and the
        // readbacks turn them into an error naming the adapter.
        let last_error: Arc<std::sync::Mutex<Option<String>>> = Arc::default();
        let sink = last_error.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| one_line_error(&e));
        }));
        let target_format = wgpu::TextureFormat::Rgba32Float;
        Ok(Gpu {
            device,
            queue,
            info,
            features,
            limits,
            target_format,
            last_error,
        })
    }

    /// The first device error since the last call (uncaptured errors are stored, not raised),
    /// as an error naming the adapter.
    pub fn take_error(&self) -> Result<()> {
        let e = self
            .last_error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        match e {
            Some(e) => Err(Error::Input(format!(
                "GPU adapter {}: {e}",
                describe(&self.info)
            ))),
            None => Ok(()),
        }
    }

    /// Makes a resource of `bytes` bytes (`what`, e.g. "render target 12000x12000") with
    /// `make`, refusing with one line when the device is out of memory for it.
    pub fn alloc<T>(&self, what: &str, bytes: u64, make: impl FnOnce() -> T) -> Result<T> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let invalid = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let v = make();
        // Popped in reverse order; a size past the adapter's limits is a validation error.
        let e = pollster::block_on(invalid.pop()).or(pollster::block_on(oom.pop()));
        if let Some(e) = e {
            return Err(Error::Input(format!(
                "{what} needs {:.2} GiB, more than GPU adapter {} can allocate ({})",
                bytes as f64 / (1u64 << 30) as f64,
                describe(&self.info),
                one_line_error(&e)
            )));
        }
        Ok(v)
    }

    /// The adapter's name, as the CSV `device` column shows it.
    pub fn name(&self) -> String {
        self.info.name.clone()
    }

    pub fn has_timestamps(&self) -> bool {
        self.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Blocks until the queue has finished all submitted work.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| Error::Internal(format!("GPU wait failed: {e}")))?;
        self.take_error()
    }

    /// A clear error if one buffer of `bytes` exceeds what the adapter allows for a storage
    /// binding or a buffer (`what` names the buffer).
    pub fn check_buffer(&self, what: &str, bytes: u64) -> Result<()> {
        let max = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size);
        if bytes > max {
            return Err(Error::Input(format!(
                "{what} needs a {:.1} MiB GPU buffer; {} allows {:.1} MiB",
                bytes as f64 / 1048576.0,
                describe(&self.info),
                max as f64 / 1048576.0
            )));
        }
        Ok(())
    }

    /// Copies `size` bytes at `offset` of `src` (which needs `COPY_SRC`) back to the CPU.
    pub fn read_buffer(&self, src: &wgpu::Buffer, offset: u64, size: u64) -> Result<Vec<u8>> {
        if size == 0 {
            return Ok(Vec::new());
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.copy_buffer_to_buffer(src, offset, &staging, 0, size);
        self.queue.submit([enc.finish()]);
        self.map_read(&staging)
    }

    /// Maps a `MAP_READ` buffer after the queue is done and returns its bytes.
    pub fn map_read(&self, buf: &wgpu::Buffer) -> Result<Vec<u8>> {
        let slice = buf.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|_| Error::Internal("GPU map callback dropped".into()))?
            .map_err(|e| Error::Internal(format!("GPU buffer map failed: {e}")))?;
        let range = slice
            .get_mapped_range()
            .map_err(|e| Error::Internal(format!("GPU mapped range: {e}")))?;
        let mut data = crate::util::alloc::try_vec_with_capacity(range.len())?;
        data.extend_from_slice(&range);
        drop(range);
        buf.unmap();
        Ok(data)
    }

    /// Reads an RGBA float render target (`Rgba32Float` or `Rgba16Float`, `COPY_SRC`) back into
    /// an [`Image`]. Rows are flipped: the target's row 0 is the top of the image, as in
    /// [`Image`] (CONVENTIONS §5), so no flip is needed when the renderers draw with y down.
    pub fn read_target(&self, tex: &wgpu::Texture) -> Result<Image> {
        let (w, h) = (tex.width(), tex.height());
        let texel = match tex.format() {
            wgpu::TextureFormat::Rgba32Float => 16u32,
            wgpu::TextureFormat::Rgba16Float => 8,
            f => return Err(Error::Internal(format!("read_target: format {f:?}"))),
        };
        let row = (w * texel).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let size = row as u64 * h as u64;
        let staging = self.alloc(&format!("the readback of the {w}x{h} image"), size, || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("target readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.copy_texture_to_buffer(
            tex.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([enc.finish()]);
        let data = self.map_read(&staging)?;
        let mut img = Image::try_new(w, h)?;
        for y in 0..h as usize {
            let r = &data[y * row as usize..];
            for x in 0..w as usize {
                let p = &mut img.pixels[y * w as usize + x];
                for (c, v) in p.iter_mut().enumerate() {
                    *v = if texel == 16 {
                        let o = x * 16 + c * 4;
                        f32::from_le_bytes([r[o], r[o + 1], r[o + 2], r[o + 3]])
                    } else {
                        let o = x * 8 + c * 2;
                        half::f16::from_le_bytes([r[o], r[o + 1]]).to_f32()
                    };
                }
            }
        }
        Ok(img)
    }
}

/// Buffers and textures a renderer made, with their bytes counted for `gpu_bytes`.
#[derive(Debug, Default)]
pub struct Account {
    /// Bytes of everything made through this account.
    pub bytes: u64,
}

impl Account {
    /// A new buffer of `size` bytes (rounded up to 4), counted.
    pub fn buffer(
        &mut self,
        gpu: &Gpu,
        label: &str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        let size = size.max(4).next_multiple_of(4);
        if usage.contains(wgpu::BufferUsages::STORAGE) {
            gpu.check_buffer(label, size)?;
        }
        self.bytes += size;
        gpu.alloc(&format!("GPU buffer '{label}'"), size, || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        })
    }

    /// A new buffer holding `data`, counted.
    pub fn buffer_init(
        &mut self,
        gpu: &Gpu,
        label: &str,
        data: &[u8],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        let buf = self.buffer(
            gpu,
            label,
            data.len() as u64,
            usage | wgpu::BufferUsages::COPY_DST,
        )?;
        if !data.is_empty() {
            gpu.queue.write_buffer(&buf, 0, data);
        }
        Ok(buf)
    }

    /// A new 2D render target of the context's float format, counted.
    pub fn target(&mut self, gpu: &Gpu, w: u32, h: u32) -> Result<wgpu::Texture> {
        let max = gpu.limits.max_texture_dimension_2d;
        if w > max || h > max {
            return Err(Error::Input(format!(
                "image {w}x{h} exceeds the GPU's largest texture ({max} per side)"
            )));
        }
        let texel = gpu.target_format.block_copy_size(None).unwrap_or(16) as u64;
        let bytes = w as u64 * h as u64 * texel;
        self.bytes += bytes;
        let what = format!("the {w}x{h} render target (largest texture {max} per side)");
        gpu.alloc(&what, bytes, || {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("target"),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: gpu.target_format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        })
    }
}

/// GPU timestamps around passes, in pairs (begin, end), where the adapter has
/// `TIMESTAMP_QUERY`; otherwise [`Timer::read_ms`] returns `None` and the renderers time with
/// the wall clock around submit and wait.
pub struct Timer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    pairs: u32,
    period_ns: f64,
}

impl Timer {
    /// Room for `pairs` timed passes.
    pub fn new(gpu: &Gpu, pairs: u32) -> Timer {
        if !gpu.has_timestamps() || pairs == 0 {
            return Timer {
                set: None,
                resolve: None,
                pairs,
                period_ns: 0.0,
            };
        }
        let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * pairs,
        });
        let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps resolve"),
            size: 16 * pairs as u64,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Timer {
            set: Some(set),
            resolve: Some(resolve),
            pairs,
            period_ns: gpu.queue.get_timestamp_period() as f64,
        }
    }

    /// Timestamp writes for compute pass number `i` (None without timestamps).
    pub fn compute(&self, i: u32) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.set.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
            query_set: q,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// Timestamp writes for render pass number `i` (None without timestamps).
    pub fn render(&self, i: u32) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.set.as_ref().map(|q| wgpu::RenderPassTimestampWrites {
            query_set: q,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// Records the resolve of all queries into `enc` (call once, after the timed passes).
    pub fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        if let (Some(q), Some(b)) = (&self.set, &self.resolve) {
            enc.resolve_query_set(q, 0..2 * self.pairs, b, 0);
        }
    }

    /// Milliseconds of each timed pass, once the work is submitted (`None` without timestamps).
    /// A pass that was not recorded reads as 0.
    pub fn read_ms(&self, gpu: &Gpu) -> Result<Option<Vec<f64>>> {
        let Some(b) = &self.resolve else {
            return Ok(None);
        };
        let raw = gpu.read_buffer(b, 0, 16 * self.pairs as u64)?;
        let t: Vec<u64> = raw
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        Ok(Some(
            (0..self.pairs as usize)
                .map(|i| t[2 * i + 1].saturating_sub(t[2 * i]) as f64 * self.period_ns * 1e-6)
                .collect(),
        ))
    }
}

/// The context for a GPU test: `Some` when an adapter exists; else a panic when
/// `TETBENCH_REQUIRE_GPU=1`, or a "skipped" line on stderr and `None`.
pub fn test_gpu(test: &str) -> Option<Arc<Gpu>> {
    match Gpu::shared() {
        Ok(g) => Some(g),
        Err(e) => {
            if std::env::var("TETBENCH_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("{test}: TETBENCH_REQUIRE_GPU=1 but no usable GPU: {e}");
            }
            eprintln!("{test}: SKIPPED (no usable GPU: {e}; set TETBENCH_REQUIRE_GPU=1 to fail)");
            None
        }
    }
}

/// Milliseconds since `t` (wall clock), for adapters without timestamps.
pub fn wall_ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_reads_back_a_cleared_target() {
        let Some(gpu) = test_gpu("context_reads_back_a_cleared_target") else {
            return;
        };
        let mut acct = Account::default();
        let tex = acct.target(&gpu, 7, 3).unwrap();
        assert!(acct.bytes >= 7 * 3 * 8);
        let view = tex.create_view(&wgpu::TextureViewDescriptor::default());
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        let timer = Timer::new(&gpu, 1);
        {
            let _pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: 0.25,
                            g: 0.5,
                            b: 0.75,
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: timer.render(0),
                occlusion_query_set: None,
                multiview_mask: None,
            });
        }
        timer.resolve(&mut enc);
        gpu.queue.submit([enc.finish()]);
        let img = gpu.read_target(&tex).unwrap();
        assert_eq!((img.width, img.height), (7, 3));
        for p in &img.pixels {
            assert_eq!(*p, [0.25, 0.5, 0.75, 1.0]);
        }
        if let Some(ms) = timer.read_ms(&gpu).unwrap() {
            assert_eq!(ms.len(), 1);
            assert!(ms[0] >= 0.0 && ms[0].is_finite());
        }
        // Buffers round-trip through read_buffer.
        let data: Vec<u8> = (0..=255u8).collect();
        let b = acct
            .buffer_init(&gpu, "t", &data, wgpu::BufferUsages::COPY_SRC)
            .unwrap();
        assert_eq!(gpu.read_buffer(&b, 16, 32).unwrap(), data[16..48].to_vec());
    }

    #[test]
    fn oversized_buffers_are_refused_with_a_message() {
        let Some(gpu) = test_gpu("oversized_buffers_are_refused_with_a_message") else {
            return;
        };
        let e = gpu.check_buffer("tet buffer", u64::MAX / 2).unwrap_err();
        assert!(e.to_string().contains("tet buffer"), "{e}");
    }

    #[test]
    fn allocations_that_cannot_be_made_are_refused_not_a_panic() {
        let Some(gpu) = test_gpu("allocations_that_cannot_be_made_are_refused") else {
            return;
        };
        let mut acct = Account::default();
        // 1 TiB: past every adapter's max_buffer_size (a device error, formerly a panic in
        // wgpu's default handler).
        let e = acct
            .buffer(&gpu, "huge", 1 << 40, wgpu::BufferUsages::COPY_DST)
            .unwrap_err()
            .to_string();
        assert!(e.contains("'huge'") && e.contains("1024.00 GiB"), "{e}");
        assert!(!e.contains('\n'), "{e}");
        // The device still works, and no error is left over.
        gpu.wait().unwrap();
        acct.buffer(&gpu, "small", 64, wgpu::BufferUsages::COPY_DST)
            .unwrap();
    }

    #[test]
    fn adapter_numbers_are_indices_only() {
        // Two adapters; "2" is no index, and must not match "256 bits" in a name.
        let all = ["llvmpipe (LLVM 15.0.6, 256 bits)", "Other GPU"];
        let name = |a: &&str| a.to_string();
        assert_eq!(pick_adapter("2", &all, name), None);
        assert_eq!(pick_adapter("1", &all, name), Some(&"Other GPU"));
        assert_eq!(pick_adapter("LLVMpipe", &all, name), Some(&all[0]));
        assert_eq!(pick_adapter("256 bits", &all, name), Some(&all[0]));
        assert_eq!(pick_adapter("nvidia", &all, name), None);
    }
}
