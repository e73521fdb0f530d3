//! The renderer plug-in interface and the one registry of renderers by name.
//!
//! A renderer is one module behind the [`Renderer`] trait; it is made known by one line in
//! [`REGISTRY`]. Everything else — the CLI, experiments, the JBU wrapper — looks renderers up
//! here by name (after pbrt-v4's and Mitsuba's plugin registries).

use std::time::Instant;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::tf::TransferFunction;

/// Options a renderer is made with.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Visibility sort by name (renderers that sort); `None` picks the renderer's default.
    pub sort: Option<String>,
    /// Integrator by name; `None` picks the renderer's default.
    pub integrator: Option<String>,
    /// Renderer-specific parameters, `KEY=VALUE` (`--param` on the command line, `params` in an
    /// experiment file); a renderer refuses keys it does not know.
    pub params: Vec<(String, String)>,
}

/// Time of one frame split by stage (CONVENTIONS §7), in milliseconds. Stages an algorithm does
/// not have stay 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTimes {
    pub project_ms: f64,
    pub sort_ms: f64,
    pub draw_ms: f64,
    pub readback_ms: f64,
    pub total_ms: f64,
}

/// One rendered frame with its timing and the renderer's own counters (e.g. `cell_steps`).
#[derive(Clone, Debug)]
pub struct Frame {
    pub image: Image,
    pub times: FrameTimes,
    pub counters: Vec<(&'static str, f64)>,
}

/// A volume renderer for tetrahedral meshes.
pub trait Renderer: Send {
    /// The full variant name, e.g. `cpu-pt` or `reference`.
    fn name(&self) -> String;
    /// The sort and integrator actually used (for CSV rows); empty when not applicable.
    fn sort_name(&self) -> String {
        String::new()
    }
    fn integrator_name(&self) -> String;
    /// Builds everything the renderer holds for this mesh and transfer function. The harness
    /// times this as setup and measures the heap bytes it leaves allocated.
    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()>;
    /// Renders one frame. `prepare` must have been called with the same mesh.
    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame>;
    /// Bytes of GPU buffers and textures held for this mesh (0 for CPU renderers).
    fn gpu_bytes(&self) -> u64 {
        0
    }
    /// What ran it: `cpu` or the GPU adapter's name.
    fn device(&self) -> String {
        "cpu".to_string()
    }
    /// For a renderer that runs in a helper process (family "external"): the bytes that
    /// process holds, its peak resident set. The harness reports these as the renderer's CPU
    /// bytes instead of the heap bytes it counted in this process.
    fn external_bytes(&self) -> Option<u64> {
        None
    }
}

/// A registry entry.
pub struct RendererInfo {
    pub name: &'static str,
    pub description: &'static str,
    /// Sorts it accepts (empty: it needs none).
    pub sorts: &'static [&'static str],
    /// Integrators it accepts.
    pub integrators: &'static [&'static str],
    pub make: fn(&RenderOptions) -> Result<Box<dyn Renderer>>,
}

/// Declares each renderer module and lists its registry entries, so that the registry is the
/// one place renderers are known by.
macro_rules! registry {
    ($($module:ident => [$($entry:ident),+],)+) => {
        $(pub mod $module;)+
        /// Every renderer, by name, in `tetbench list` order.
        pub static REGISTRY: &[&RendererInfo] = &[$($(&$module::$entry,)+)+];
    };
}

// The registry: adding a renderer is one new file in this directory and one line here
// (docs/adding-a-renderer.md walks through it).
registry! {
    raycast => [RAYCAST, REFERENCE],
    cpu_pt => [CPU_PT],
    cpu_pt_slab16 => [CPU_PT_SLAB16],
    ptint => [PTINT],
    hapt => [HAPT],
    vtk => [VTK_PT, VTK_RAYCAST, VTK_ZSWEEP],
    // The last entry, `jbu:<renderer>@<size>`, describes the wrapper pattern (see `is_wrapper`).
    jbu => [JBU],
}

/// Whether `name` is a wrapper (`jbu:...`), not a renderer of its own.
pub fn is_wrapper(name: &str) -> bool {
    name.starts_with(jbu::PREFIX)
}

/// Whether `name` runs in a helper process outside tetbench (family "external": the VTK peers,
/// which need `TETBENCH_VTK_PYTHON`). Sweeps over "every renderer" leave these out unless named.
pub fn is_external(name: &str) -> bool {
    vtk::NAMES.contains(&name)
}

/// Looks a renderer up by name. A `jbu:<renderer>@<size>` name is checked and answers with the
/// inner renderer's entry (the wrapper takes exactly its sorts and integrators).
pub fn info(name: &str) -> Result<&'static RendererInfo> {
    if is_wrapper(name) {
        let spec = jbu::Spec::parse(name)?;
        return info(&spec.inner);
    }
    REGISTRY
        .iter()
        .copied()
        .find(|r| r.name == name)
        .ok_or_else(|| {
            Error::Input(format!(
                "unknown renderer '{name}' (known: {})",
                names().join(", ")
            ))
        })
}

/// Names of all registered renderers.
pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|r| r.name).collect()
}

/// Makes a renderer by name, checking the sort and integrator names against what it accepts.
pub fn make(name: &str, opts: &RenderOptions) -> Result<Box<dyn Renderer>> {
    if is_wrapper(name) {
        return jbu::make(name, opts);
    }
    let info = info(name)?;
    if let Some(s) = &opts.sort {
        // `bucket:16` is the `bucket` sort with a parameter.
        let base = s.split(':').next().unwrap_or(s);
        if !info.sorts.contains(&base) {
            return Err(Error::Input(format!(
                "renderer '{name}' does not take sort '{s}' (it takes: {})",
                if info.sorts.is_empty() {
                    "none".to_string()
                } else {
                    info.sorts.join(", ")
                }
            )));
        }
    }
    if let Some(i) = &opts.integrator {
        if !info.integrators.contains(&i.as_str()) {
            return Err(Error::Input(format!(
                "renderer '{name}' does not take integrator '{i}' (it takes: {})",
                info.integrators.join(", ")
            )));
        }
    }
    (info.make)(opts)
}

/// Milliseconds since `t`.
pub fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
