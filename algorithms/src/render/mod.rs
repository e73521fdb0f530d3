//! The renderer plug-in interface and the one registry of renderers by name.
//!
//! A renderer is one module behind the [`Renderer`] trait; it is made known by one line in
//! [`REGISTRY`]. Peers — renderers that are other programs (`docs/peers.md`) — join it at run
//! time from their `[[peer]]` declarations, once, through [`peer::register`]. Everything else —
//! the CLI, experiments, the JBU wrapper — looks renderers up here by name (after pbrt-v4's and
//! Mitsuba's plugin registries): [`all`], [`info`], [`make`].

use std::path::PathBuf;
use std::time::Instant;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::plugin::{check_params, did_you_mean, ParamInfo};
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
    /// Where a renderer that runs another program (a peer) saves that program's log (its
    /// stderr), as `DIR/<renderer>.log`; `None`: kept only for error messages.
    pub log_dir: Option<PathBuf>,
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

impl Frame {
    /// The value of counter `name`, if the renderer reports it.
    pub fn counter(&self, name: &str) -> Option<f64> {
        self.counters.iter().find(|c| c.0 == name).map(|c| c.1)
    }
}

/// What a renderer is, for the CSV rows and `tetbench render`'s output.
#[derive(Clone, Debug, PartialEq)]
pub struct Description {
    /// The full variant name, e.g. `cpu-pt` or `reference`.
    pub name: String,
    /// The sort actually used; empty when it takes none.
    pub sort: String,
    /// The integrator actually used.
    pub integrator: String,
    /// What ran it: `cpu` or the GPU adapter's name.
    pub device: String,
}

impl Description {
    /// A renderer that runs on the CPU.
    pub fn cpu(name: &str, sort: &str, integrator: &str) -> Description {
        Description {
            name: name.to_string(),
            sort: sort.to_string(),
            integrator: integrator.to_string(),
            device: "cpu".to_string(),
        }
    }
}

/// What a renderer holds for its mesh beyond the heap bytes the harness counts in this process.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Memory {
    /// Bytes of GPU buffers and textures held for this mesh (0 for CPU renderers).
    pub gpu_bytes: u64,
    /// For a renderer that runs in another process (family "external", a peer): the bytes
    /// that process holds, its peak resident set. The harness reports these as the renderer's CPU
    /// bytes instead of the heap bytes it counted in this process.
    pub external_bytes: Option<u64>,
}

/// A volume renderer for tetrahedral meshes.
pub trait Renderer: Send {
    /// Its name, sort, integrator and device.
    fn describe(&self) -> Description;
    /// Builds everything the renderer holds for this mesh and transfer function. The harness
    /// times this as setup and measures the heap bytes it leaves allocated.
    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()>;
    /// Renders one frame. `prepare` must have been called with the same mesh.
    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame>;
    /// The GPU and other-process bytes it holds (none for a CPU renderer).
    fn memory(&self) -> Memory {
        Memory::default()
    }
}

/// What kind of algorithm a renderer is; the papers' tables pick their renderers by family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Projected tetrahedra (Shirley–Tuchman; PTINT, HAPT and their variants).
    Pt,
    /// Ray casting through the mesh (HARC's family; the exact reference).
    RayCasting,
    /// Wraps another renderer (`jbu:<renderer>@<size>`).
    Wrapper,
    /// Runs another program over the peer protocol (VTK's mappers, declared peers); the papers'
    /// tables take such peers by the family they declare ([`peer::PeerFamily`]).
    External,
    /// Ray casts the regular volume a lattice mesh samples (the BCC paper's reconstruction
    /// schemes); lattice meshes only.
    Volume,
}

impl Family {
    pub fn name(self) -> &'static str {
        match self {
            Family::Pt => "projected tetrahedra",
            Family::RayCasting => "ray casting",
            Family::Wrapper => "wrapper",
            Family::External => "external",
            Family::Volume => "regular volume",
        }
    }
}

/// A renderer's registry entry, declared in the renderer's own file.
pub struct RendererInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub family: Family,
    /// Whether it runs on a GPU (wgpu): it needs an adapter, and on a software one it is slow.
    pub needs_gpu: bool,
    /// Sorts it accepts (empty: it needs none).
    pub sorts: &'static [&'static str],
    /// The sort it uses when none is given ("" when it takes none).
    pub default_sort: &'static str,
    /// The sorts the papers' algorithm tables (PTINT Table 2, HAPT Tables 3 and 4) measure it
    /// with: `["*"]` every sort but the lattice-only ones, `[]` only its default.
    pub table_sorts: &'static [&'static str],
    /// Integrators it accepts.
    pub integrators: &'static [&'static str],
    /// The integrator it uses when none is given.
    pub default_integrator: &'static str,
    /// The `--param KEY=VALUE` keys it takes, with their defaults and docs; any other key is
    /// refused before the renderer is made.
    pub params: &'static [ParamInfo],
    /// The largest RMSE against `reference` (CONVENTIONS §6) that the registry-wide test
    /// (`tests/tests/renderers/registry.rs`) accepts, per integrator it takes: on a 3000-tet
    /// `cc6` lattice with the default transfer function, 48×48, ortho, at views (0, 0) and
    /// (37, 21). Each entry says where its values come from (measured, with a margin).
    pub max_rmse: &'static [(&'static str, f64)],
    /// Makes it (given its own entry); the options have been checked against this entry.
    pub make: fn(&RendererInfo, &RenderOptions) -> Result<Box<dyn Renderer>>,
}

pub mod pt;

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
    volume_raycast => [VOLUME_RAYCAST],
    // The last entry, `jbu:<renderer>@<size>`, describes the wrapper pattern (see `is_wrapper`).
    jbu => [JBU],
}

pub mod peer;

/// Whether `name` is a wrapper (`jbu:...`), not a renderer of its own.
pub fn is_wrapper(name: &str) -> bool {
    name.starts_with(jbu::PREFIX)
}

/// Whether `name` runs in another program (family "external": the VTK peers, which need
/// `TETBENCH_VTK_PYTHON`, and declared peers). Sweeps over "every renderer" leave these out
/// unless named.
pub fn is_external(name: &str) -> bool {
    info(name).is_ok_and(|i| i.family == Family::External)
}

/// Every renderer: the built-in ones ([`REGISTRY`]), then the declared peers
/// ([`peer::register`]), in `tetbench list` order.
pub fn all() -> Vec<&'static RendererInfo> {
    REGISTRY
        .iter()
        .copied()
        .chain(peer::registered().iter().map(|r| r.info))
        .collect()
}

/// The algorithm family a peer declares (`None` for renderers that are not peers).
pub fn peer_family(info: &RendererInfo) -> Option<peer::PeerFamily> {
    if info.family != Family::External {
        return None;
    }
    peer::find(info.name)
        .map(|r| r.spec.family)
        .or_else(|| vtk::family(info.name))
}

/// Looks a renderer up by name. A `jbu:<renderer>@<size>` name is checked and answers with the
/// inner renderer's entry (the wrapper takes exactly its sorts and integrators).
pub fn info(name: &str) -> Result<&'static RendererInfo> {
    if is_wrapper(name) {
        let spec = jbu::Spec::parse(name)?;
        return info(&spec.inner);
    }
    all().into_iter().find(|r| r.name == name).ok_or_else(|| {
        let names = names();
        Error::Input(format!(
            "unknown renderer '{name}' (known: {}){}",
            names.join(", "),
            did_you_mean(name, &names)
        ))
    })
}

/// Names of all registered renderers.
pub fn names() -> Vec<&'static str> {
    all().iter().map(|r| r.name).collect()
}

/// The registered renderers of one family, in registry order (wrappers' pattern entry left out).
pub fn family(f: Family) -> Vec<&'static RendererInfo> {
    all()
        .into_iter()
        .filter(|r| r.family == f && !is_wrapper(r.name))
        .collect()
}

/// Makes a renderer by name. Everything is checked here, once, against its registry entry:
/// the sort (and that it exists), the integrator, and every `--param` key (unknown or repeated
/// keys are refused). Absent sort and integrator are filled in with the entry's defaults.
pub fn make(name: &str, opts: &RenderOptions) -> Result<Box<dyn Renderer>> {
    if is_wrapper(name) {
        return jbu::make(name, opts);
    }
    let info = info(name)?;
    check_params(&format!("renderer '{name}'"), info.params, &opts.params)?;
    let mut opts = opts.clone();
    if let Some(s) = &opts.sort {
        // `bucket:16` is the `bucket` sort with a parameter.
        let base = s.split(':').next().unwrap_or(s);
        if !info.sorts.contains(&base) {
            return Err(Error::Input(format!(
                "renderer '{name}' does not take sort '{s}' (it takes: {}){}",
                if info.sorts.is_empty() {
                    "none".to_string()
                } else {
                    info.sorts.join(", ")
                },
                did_you_mean(base, info.sorts)
            )));
        }
    } else if !info.default_sort.is_empty() {
        opts.sort = Some(info.default_sort.to_string());
    }
    let integ = opts
        .integrator
        .get_or_insert_with(|| info.default_integrator.to_string());
    if !info.integrators.contains(&integ.as_str()) {
        // An unknown name gets the list of all integrators; a known one the renderer's.
        crate::optics::info(integ)?;
        return Err(Error::Input(format!(
            "renderer '{name}' does not take integrator '{integ}' (it takes: {})",
            info.integrators.join(", ")
        )));
    }
    (info.make)(info, &opts)
}

/// Milliseconds since `t`.
pub fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_entry_is_complete_and_refuses_unknown_params() {
        for r in REGISTRY.iter().filter(|r| !is_wrapper(r.name)) {
            assert!(r.integrators.contains(&r.default_integrator), "{}", r.name);
            assert!(
                r.default_sort.is_empty() == r.sorts.is_empty()
                    && (r.default_sort.is_empty() || r.sorts.contains(&r.default_sort)),
                "{}",
                r.name
            );
            for s in r.table_sorts {
                assert!(*s == "*" || r.sorts.contains(s), "{}: {s}", r.name);
            }
            let o = RenderOptions {
                params: vec![("bogus".into(), "1".into())],
                ..Default::default()
            };
            let e = make(r.name, &o).err().expect("refused").to_string();
            assert!(e.contains("unknown parameter 'bogus'"), "{e}");
        }
        for i in crate::optics::REGISTRY {
            assert_eq!(
                crate::optics::gpu::GPU_INTEGRATORS.contains(&i.name),
                i.on_gpu,
                "{}",
                i.name
            );
        }
    }
}
