//! Peers: renderers that are other programs, spoken to over the peer protocol
//! (`docs/peers.md`). A peer is declared by a [`PeerSpec`] — from a `[[peer]]` table
//! ([`decl`]) or in code (VTK's mappers, `render/vtk.rs`) — and runs as a [`PeerRenderer`],
//! which is a [`Renderer`] like any other: the harness times it, counts its memory and
//! compares its image, without knowing it is another process.
//!
//! **Registration.** Declared peers join the registry once, explicitly, through [`register`],
//! which the command-line layer calls before it looks any renderer up. There is no other
//! mutable global state here (the live process groups of [`process`] excepted, which exist so
//! that a signal handler can end them).
//!
//! **Faults cost one request.** A peer that exits, hangs past its `timeout_s`, writes garbage,
//! an endless line, a wrong-size image or non-finite pixels fails that request with a one-line
//! reason; its process group is ended, and the next request starts a fresh process (prepared
//! again with the same scene, counted in `peer_restarts`). A peer's own error reply
//! (`"ok": false`) fails the request and keeps the process.

pub mod decl;
mod private_dir;
pub mod process;
pub mod protocol;

use std::cell::Cell;
use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use super::{
    Description, Family, Frame, FrameTimes, Memory, RenderOptions, Renderer, RendererInfo,
};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::plugin::ParamInfo;
use crate::tf::TransferFunction;
use process::PeerProcess;
pub use process::{end_all, group_members, Launch};
use protocol::Hello;

/// The timeout of each request when a declaration gives none.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(120);

/// The kind of algorithm a peer declares; the papers' tables take peers by it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeerFamily {
    /// Projected tetrahedra (cell projection): the PT tables.
    Pt,
    /// Ray casting or any per-pixel integration along rays.
    RayCasting,
    /// Anything else: measured when named, left out of the papers' tables.
    Other,
}

impl PeerFamily {
    pub fn parse(s: &str) -> Option<PeerFamily> {
        match s {
            "pt" => Some(PeerFamily::Pt),
            "raycasting" => Some(PeerFamily::RayCasting),
            "other" => Some(PeerFamily::Other),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            PeerFamily::Pt => "pt",
            PeerFamily::RayCasting => "raycasting",
            PeerFamily::Other => "other",
        }
    }
}

/// One parameter a peer takes (`--param KEY=VALUE`), passed to it in `prepare`.
#[derive(Clone, Debug)]
pub struct PeerParam {
    pub name: String,
    pub default: String,
    pub doc: String,
}

/// A peer as declared: what `tetbench list` shows and how to start it.
#[derive(Clone, Debug)]
pub struct PeerSpec {
    pub name: String,
    pub description: String,
    pub family: PeerFamily,
    /// The integrators it takes, its default first. Empty: those its `hello` names
    /// (`tetbench peer check -- CMD`).
    pub integrators: Vec<String>,
    pub params: Vec<PeerParam>,
    /// The deadline of every request (hello, prepare, render).
    pub timeout: Duration,
    pub launch: Launch,
    /// Where it was declared (a file), for messages and `tetbench list`.
    pub origin: String,
}

/// A declared peer in the registry: its entry and its spec.
pub struct Registered {
    pub info: &'static RendererInfo,
    pub spec: PeerSpec,
}

static REGISTERED: OnceLock<Vec<Registered>> = OnceLock::new();

/// Adds declared peers to the registry, once, before any renderer is looked up (the
/// command-line layer does this). Refuses a name that a built-in renderer or another
/// declaration already has, naming both.
pub fn register(specs: Vec<PeerSpec>) -> Result<()> {
    let mut seen: Vec<&PeerSpec> = Vec::new();
    for s in &specs {
        if super::REGISTRY.iter().any(|r| r.name == s.name) || super::is_wrapper(&s.name) {
            return Err(Error::Input(format!(
                "peer '{}' ({}): the name of a built-in renderer",
                s.name, s.origin
            )));
        }
        if let Some(o) = seen.iter().find(|o| o.name == s.name) {
            return Err(Error::Input(format!(
                "peer '{}' is declared twice ({} and {})",
                s.name, o.origin, s.origin
            )));
        }
        seen.push(s);
    }
    let entries = specs
        .into_iter()
        .map(|spec| Registered {
            info: Box::leak(Box::new(info_of(&spec))),
            spec,
        })
        .collect();
    REGISTERED
        .set(entries)
        .map_err(|_| Error::Internal("peers registered twice".into()))
}

/// The declared peers (empty until [`register`]).
pub fn registered() -> &'static [Registered] {
    REGISTERED.get().map(Vec::as_slice).unwrap_or(&[])
}

/// The declared peer named `name`.
pub fn find(name: &str) -> Option<&'static Registered> {
    registered().iter().find(|r| r.spec.name == name)
}

/// The spec of the peer named `name`: a declared one, or one of VTK's (`None` when `name` is
/// not a peer; an error when it is one that cannot run here).
pub fn spec_of(name: &str) -> Option<Result<PeerSpec>> {
    match find(name) {
        Some(r) => Some(Ok(r.spec.clone())),
        None => super::vtk::spec_by_name(name),
    }
}

/// The RMSE bound against `reference` that a declared peer is held to, by its integrator's
/// class (docs/peers.md, "Conformance"). A declaration states no bound of its own, so
/// `tetbench peer check` and the registry's correctness test both apply these.
pub fn conformance_bound(integrator: &str) -> f64 {
    match integrator {
        "exact" => 2e-3,
        "partial" | "preint" => 1e-2,
        _ => 2e-2,
    }
}

fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

/// The registry entry of a declared peer (its strings live as long as the process: a
/// registration happens once).
fn info_of(spec: &PeerSpec) -> RendererInfo {
    let integrators: Vec<&'static str> = spec.integrators.iter().map(|s| leak(s)).collect();
    let params: Vec<ParamInfo> = spec
        .params
        .iter()
        .map(|p| ParamInfo {
            name: leak(&p.name),
            default: leak(&p.default),
            doc: leak(&p.doc),
        })
        .collect();
    let max_rmse: Vec<(&'static str, f64)> = integrators
        .iter()
        .map(|i| (*i, conformance_bound(i)))
        .collect();
    RendererInfo {
        name: leak(&spec.name),
        description: leak(&spec.description),
        family: Family::External,
        needs_gpu: false,
        sorts: &[],
        default_sort: "",
        table_sorts: &[],
        default_integrator: integrators.first().copied().unwrap_or(""),
        integrators: Box::leak(integrators.into_boxed_slice()),
        params: Box::leak(params.into_boxed_slice()),
        max_rmse: Box::leak(max_rmse.into_boxed_slice()),
        make: |info, o| {
            let r = find(info.name).ok_or_else(|| {
                Error::Internal(format!("peer '{}' is not registered", info.name))
            })?;
            Ok(Box::new(PeerRenderer::new(r.spec.clone(), o)?))
        },
    }
}

/// A counter name that lives as long as the process (frames carry `&'static str` names). Peers
/// name their own counters; each distinct name is kept once, at most 1024 of them.
fn intern(name: &str) -> Option<&'static str> {
    static NAMES: Mutex<Option<HashSet<&'static str>>> = Mutex::new(None);
    let mut g = NAMES.lock().unwrap_or_else(|p| p.into_inner());
    let set = g.get_or_insert_with(HashSet::new);
    if let Some(s) = set.get(name) {
        return Some(s);
    }
    if set.len() >= 1024 {
        return None;
    }
    let s = leak(name);
    set.insert(s);
    Some(s)
}

/// A peer as a renderer: one process at a time, started at the first `prepare` and again
/// after a fault.
pub struct PeerRenderer {
    spec: PeerSpec,
    integrator: String,
    /// Every declared parameter, given or default.
    params: Vec<(String, String)>,
    log: Option<PathBuf>,
    process: Option<PeerProcess>,
    hello: Option<Hello>,
    /// The scene of the last `prepare`, for a fresh process after a fault.
    tf: Option<TransferFunction>,
    /// Whether the running process holds that scene.
    prepared: bool,
    prepare_counters: Vec<(&'static str, f64)>,
    restarts: usize,
    peak_rss: Cell<u64>,
    gpu_bytes: u64,
}

impl PeerRenderer {
    /// The renderer for `spec`; `o`'s integrator and parameters have been checked against its
    /// registry entry (or come from `peer check`).
    pub fn new(spec: PeerSpec, o: &RenderOptions) -> Result<PeerRenderer> {
        let integrator = o
            .integrator
            .clone()
            .or_else(|| spec.integrators.first().cloned())
            .unwrap_or_default();
        let params = spec
            .params
            .iter()
            .map(|p| {
                let v = o
                    .params
                    .iter()
                    .find(|(k, _)| *k == p.name)
                    .map_or(p.default.clone(), |(_, v)| v.clone());
                (p.name.clone(), v)
            })
            .collect();
        let log = o
            .log_dir
            .as_ref()
            .map(|d| d.join(format!("{}.log", spec.name)));
        Ok(PeerRenderer {
            spec,
            integrator,
            params,
            log,
            process: None,
            hello: None,
            tf: None,
            prepared: false,
            prepare_counters: Vec::new(),
            restarts: 0,
            peak_rss: Cell::new(0),
            gpu_bytes: 0,
        })
    }

    /// What the peer said in its `hello` (after the first `prepare`).
    pub fn hello(&self) -> Option<&Hello> {
        self.hello.as_ref()
    }

    pub fn spec(&self) -> &PeerSpec {
        &self.spec
    }

    /// Sends a request to the running process and returns its reply; a peer's `ok: false`
    /// becomes an error naming the peer, its process kept.
    fn call(&mut self, request: &serde_json::Value) -> Result<serde_json::Value> {
        let name = self.spec.name.clone();
        let p = self
            .process
            .as_mut()
            .ok_or_else(|| Error::Internal(format!("peer '{name}': no process")))?;
        let reply = p.call(request, self.spec.timeout)?;
        if reply["ok"] == serde_json::Value::Bool(true) {
            return Ok(reply);
        }
        let what = request["type"].as_str().unwrap_or("request");
        let msg = reply["error"].as_str().unwrap_or("no reason given");
        let msg: String = msg.split_whitespace().collect::<Vec<_>>().join(" ");
        Err(Error::Input(format!(
            "peer '{name}' failed {what}: {}",
            msg.chars().take(500).collect::<String>()
        )))
    }

    /// Ends the process at once after a fault in what it sent (the next request starts a
    /// fresh one).
    fn fault(&mut self, msg: String) -> Error {
        self.end_process();
        Error::Input(format!("peer '{}': {msg}", self.spec.name))
    }

    fn end_process(&mut self) {
        if let Some(mut p) = self.process.take() {
            p.kill();
        }
        self.prepared = false;
    }

    /// Starts a process and checks its `hello`; a process whose hello is refused is ended.
    fn start(&mut self) -> Result<()> {
        self.end_process();
        let p = PeerProcess::start(&self.spec.name, &self.spec.launch, self.log.as_deref())?;
        let dir = p.dir().to_path_buf();
        self.process = Some(p);
        let hello = self
            .call(&protocol::hello_request(&dir))
            .and_then(|reply| protocol::read_hello(&self.spec.name, &reply))
            .and_then(|hello| {
                let declared = if self.spec.integrators.is_empty() {
                    &hello.integrators
                } else {
                    &self.spec.integrators
                };
                match declared.iter().find(|i| !hello.integrators.contains(i)) {
                    None => Ok(hello),
                    Some(missing) => Err(Error::Input(format!(
                        "peer '{}' is declared with integrator '{missing}' ({}), but its hello offers: {}",
                        self.spec.name,
                        self.spec.origin,
                        hello.integrators.join(", ")
                    ))),
                }
            })
            .inspect_err(|_| self.end_process())?;
        if self.integrator.is_empty() {
            self.integrator = hello.integrators.first().cloned().unwrap_or_default();
        }
        self.hello = Some(hello);
        Ok(())
    }

    /// Hands the scene to the running process.
    fn send_scene(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        let dir = match &self.process {
            Some(p) => p.dir().to_path_buf(),
            None => return Err(Error::Internal("no process".into())),
        };
        let request = protocol::prepare_request(&dir, mesh, tf, &self.integrator, &self.params)?;
        let reply = self.call(&request)?;
        // Read from /proc after prepare and after the frames (`external_bytes`), not at every
        // request: high-water marks only grow.
        if let Some(p) = &self.process {
            self.peak_rss.set(self.peak_rss.get().max(p.peak_rss()));
        }
        for f in [protocol::POSITIONS, protocol::CELLS, protocol::SCALARS] {
            let _ = std::fs::remove_file(dir.join(f));
        }
        self.read_extras(&reply)?;
        self.prepare_counters = self.counters(&reply)?;
        self.prepared = true;
        Ok(())
    }

    /// `gpu_bytes` of a reply (the largest seen is kept).
    fn read_extras(&mut self, reply: &serde_json::Value) -> Result<()> {
        let gpu = protocol::number(reply, "gpu_bytes").map_err(|e| self.fault(e.to_string()))?;
        self.gpu_bytes = self.gpu_bytes.max(gpu.unwrap_or(0.0) as u64);
        Ok(())
    }

    fn counters(&mut self, reply: &serde_json::Value) -> Result<Vec<(&'static str, f64)>> {
        let c = protocol::counters(reply).map_err(|e| self.fault(e.to_string()))?;
        Ok(c.into_iter()
            .filter_map(|(k, v)| Some((intern(&k)?, v)))
            .collect())
    }

    fn running(&self) -> bool {
        self.process.as_ref().is_some_and(|p| !p.ended())
    }

    /// A process that holds the last scene: a fresh one when the last was ended.
    fn ensure_running(&mut self, mesh: &Mesh) -> Result<()> {
        if self.running() && self.prepared {
            return Ok(());
        }
        let tf = self.tf.clone().ok_or_else(|| {
            Error::Internal(format!("peer '{}': render before prepare", self.spec.name))
        })?;
        if !self.running() {
            self.restarts += 1;
            self.start()?;
        }
        self.send_scene(mesh, &tf)
    }
}

impl Renderer for PeerRenderer {
    fn describe(&self) -> Description {
        let device = match &self.hello {
            Some(Hello {
                device: Some(d), ..
            }) => d.clone(),
            Some(h) => format!("peer {} {}", h.name, h.version).trim().to_string(),
            None => format!("peer {}", self.spec.name),
        };
        Description {
            name: self.spec.name.clone(),
            sort: String::new(),
            integrator: self.integrator.clone(),
            device,
        }
    }
    fn memory(&self) -> Memory {
        if let Some(p) = &self.process {
            // High-water marks only grow: reading them now gives the peak so far.
            self.peak_rss.set(self.peak_rss.get().max(p.peak_rss()));
        }
        Memory {
            gpu_bytes: self.gpu_bytes,
            external_bytes: Some(self.peak_rss.get()),
        }
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.tf = Some(tf.clone());
        self.prepared = false;
        if !self.running() {
            self.start()?;
        }
        self.send_scene(mesh, tf)
    }

    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        self.ensure_running(mesh)?;
        let projection = camera.projection.name();
        if let Some(h) = &self.hello {
            if !h.projections.iter().any(|p| p == projection) {
                return Err(Error::Input(format!(
                    "peer '{}' does not render {projection} projections (it offers: {})",
                    self.spec.name,
                    h.projections.join(", ")
                )));
            }
        }
        let image_path = match &self.process {
            Some(p) => p.dir().join(protocol::IMAGE),
            None => return Err(Error::Internal("no process".into())),
        };
        // A stale image must not pass for this frame's.
        let _ = std::fs::remove_file(&image_path);
        let reply = self.call(&protocol::render_request(camera, &image_path))?;
        let stage = |r: &serde_json::Value, k: &str| protocol::number(r, k);
        let times = (|| -> Result<[f64; 4]> {
            let draw = stage(&reply, "draw_ms")?
                .ok_or_else(|| Error::Input("the reply has no `draw_ms`".into()))?;
            Ok([
                stage(&reply, "project_ms")?.unwrap_or(0.0),
                stage(&reply, "sort_ms")?.unwrap_or(0.0),
                draw,
                stage(&reply, "readback_ms")?.unwrap_or(0.0),
            ])
        })()
        .map_err(|e| self.fault(format!("render reply: {e}")))?;
        self.read_extras(&reply)?;
        let mut counters = self.counters(&reply)?;
        let image = protocol::read_image(&image_path, camera.width, camera.height)
            .map_err(|e| self.fault(e.to_string()))?;
        let _ = std::fs::remove_file(&image_path);
        let bad = image.non_finite_pixels();
        if bad > 0 {
            return Err(self.fault(format!("image has {bad} pixels that are NaN or infinite")));
        }
        let [project_ms, sort_ms, draw_ms, readback_ms] = times;
        counters.extend(self.prepare_counters.iter().copied());
        counters.push(("peer_restarts", self.restarts as f64));
        Ok(Frame {
            image,
            times: FrameTimes {
                project_ms,
                sort_ms,
                draw_ms,
                readback_ms,
                total_ms: project_ms + sort_ms + draw_ms + readback_ms,
            },
            counters,
        })
    }
}
