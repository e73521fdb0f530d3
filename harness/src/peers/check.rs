//! `tetbench peer check`: the conformance suite for a peer (after ANARI's CTS: test scenes,
//! each image compared against a reference device by a threshold, and a report).
//!
//! 1. **Protocol.** `hello` is answered with protocol 1.x and the peer's integrators; a request
//!    of an unknown type and a `hello` of another major version are refused with an error
//!    reply (the process stays up); `bye` ends the process within the grace period.
//! 2. **Scenes.** The contract's scenes for the peer's family ([`scenes`]): a convex and two
//!    non-convex meshes and the hard cases the family should survive, each in ortho and persp
//!    projection and with every integrator the peer offers, plus one non-square image. Each
//!    image is compared with `reference` (the exact ray caster) by RMSE against the bound of its
//!    integrator's class ([`conformance_bound`](algorithms::render::peer::conformance_bound), `docs/peers.md`); a failed request, a wrong-size image or a
//!    non-finite pixel fails the scene with the reason.
//! 3. **Report.** A Markdown table with the error, the request's wall time, the peer's own
//!    time (the sum of its stages) and its peak resident set per tet for each scene.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use algorithms::camera::{Camera, Projection, View};
use algorithms::image::Image;
use algorithms::metrics;
use algorithms::render::peer::process::PeerProcess;
use algorithms::render::peer::{
    conformance_bound as bound, protocol, PeerFamily, PeerRenderer, PeerSpec,
};
use algorithms::render::{self, RenderOptions, Renderer};
use algorithms::{Error, Mesh, Result, TransferFunction};
use serde_json::json;

use crate::meshes::{load_mesh, MeshSpec};

/// One scene: a mesh, a view and what it tests.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    pub mesh: &'static str,
    pub view: (f64, f64),
    pub what: &'static str,
}

const fn scene(mesh: &'static str, view: (f64, f64), what: &'static str) -> Scene {
    Scene { mesh, view, what }
}

/// Every family's scenes: convexity, and the inputs every renderer must take (CONVENTIONS §1,
/// §3: centring, scale, scalar range, constant fields, orientation).
const COMMON: &[Scene] = &[
    scene("cc6:6000", (30.0, 20.0), "convex lattice"),
    scene("spx:6000", (30.0, 20.0), "non-convex: a cavity"),
    scene("torus:6000", (30.0, 20.0), "non-convex: a hole through it"),
    scene(
        "hard-translated:6000",
        (30.0, 20.0),
        "translated by 1e6 (centring)",
    ),
    scene("hard-tiny:6000", (30.0, 20.0), "scaled to 1e-6"),
    scene(
        "hard-scalar-range:6000",
        (30.0, 20.0),
        "scalars from 1 to 1e30",
    ),
    scene("hard-constant:6000", (30.0, 20.0), "a constant field"),
    scene(
        "hard-negative:6000",
        (30.0, 20.0),
        "negatively oriented tets",
    ),
];

/// What projected tetrahedra should survive besides: thin cells.
const PT: &[Scene] = &[
    scene("hard-slivers:6000", (30.0, 20.0), "a layer of slivers"),
    scene("hard-caps:6000", (30.0, 20.0), "a thin sheared layer"),
];

/// What a ray caster should survive besides: rays along faces and edges (watertightness),
/// degenerate and thin cells, faces that are not shared.
const RAYCASTING: &[Scene] = &[
    scene(
        "hard-axis-aligned:6000",
        (0.0, 0.0),
        "rays along faces and edges",
    ),
    scene("hard-needles:6000", (30.0, 20.0), "needle cells"),
    scene("hard-slivers:6000", (30.0, 20.0), "a layer of slivers"),
    scene("hard-zero-volume:6000", (30.0, 20.0), "zero-volume cells"),
    scene(
        "hard-duplicates:6000",
        (30.0, 20.0),
        "duplicate vertices (faces not shared)",
    ),
];

/// The scenes of a family.
pub fn scenes(family: PeerFamily) -> Vec<Scene> {
    let extra: &[Scene] = match family {
        PeerFamily::Pt => PT,
        PeerFamily::RayCasting => RAYCASTING,
        PeerFamily::Other => &[],
    };
    COMMON.iter().chain(extra).copied().collect()
}

/// One line of the report.
struct Outcome {
    scene: String,
    integrator: String,
    projection: &'static str,
    size: (u32, u32),
    rmse: Option<f64>,
    bound: f64,
    wall_ms: Option<f64>,
    peer_ms: Option<f64>,
    rss_per_tet: Option<f64>,
    problem: Option<String>,
}

/// Runs the suite and writes the report; returns it and the number of failed checks. A peer
/// given as a command (its spec has no integrators) is named and described by its `hello`;
/// `family` (`--family`) overrides the family it says.
pub fn run(
    spec: PeerSpec,
    family: Option<PeerFamily>,
    size: (u32, u32),
) -> Result<(String, usize)> {
    let (hello, protocol_lines) = protocol_checks(&spec);
    let mut spec = spec;
    if let Some(h) = hello.as_ref().filter(|_| spec.integrators.is_empty()) {
        spec.name = h.name.clone();
        spec.integrators = h.integrators.clone();
        spec.family = family
            .or_else(|| h.family.as_deref().and_then(PeerFamily::parse))
            .unwrap_or(PeerFamily::Other);
    }
    let mut report = String::new();
    let _ = writeln!(report, "# Conformance of peer `{}`\n", spec.name);
    let _ = writeln!(
        report,
        "Command: `{}`; family {}; timeout {} s a request; tetbench {} (protocol {}).\n",
        spec.launch.command_line(),
        spec.family.name(),
        spec.timeout.as_secs_f64(),
        env!("CARGO_PKG_VERSION"),
        protocol::PROTOCOL
    );
    let mut failed = protocol_lines.iter().filter(|l| !l.0).count();
    let _ = writeln!(report, "## Protocol\n");
    for (ok, line) in &protocol_lines {
        let _ = writeln!(report, "- {} {line}", if *ok { "pass" } else { "**FAIL**" });
    }
    let Some(hello) = hello else {
        let _ = writeln!(
            report,
            "\nNo scene was rendered: the peer did not answer `hello`."
        );
        return Ok((report, failed.max(1)));
    };
    let projections: Vec<Projection> = [Projection::Ortho, Projection::Persp]
        .into_iter()
        .filter(|p| hello.projections.iter().any(|h| h == p.name()))
        .collect();

    let tf = TransferFunction::preset("default")
        .ok_or_else(|| Error::Internal("no default transfer function".into()))?;
    let mut outcomes = Vec::new();
    let scene_list = scenes(spec.family);
    for integrator in spec.integrators.clone() {
        let opts = RenderOptions {
            integrator: Some(integrator.clone()),
            ..Default::default()
        };
        let mut peer = PeerRenderer::new(spec.clone(), &opts)?;
        for s in &scene_list {
            let mesh = load_mesh(&MeshSpec::named(s.mesh))?;
            let prepared = crate::bench::isolated(|| peer.prepare(&mesh, &tf));
            for &p in &projections {
                outcomes.push(check_scene(
                    &mut peer,
                    prepared.as_ref().err(),
                    &mesh,
                    &tf,
                    s,
                    &integrator,
                    p,
                    size,
                ));
            }
        }
        // One non-square image: rows and columns must not be swapped.
        let s = &scene_list[1];
        let mesh = load_mesh(&MeshSpec::named(s.mesh))?;
        let prepared = crate::bench::isolated(|| peer.prepare(&mesh, &tf));
        let wide = (size.0, (size.1 * 2 / 3).max(1));
        outcomes.push(check_scene(
            &mut peer,
            prepared.as_ref().err(),
            &mesh,
            &tf,
            s,
            &integrator,
            projections.first().copied().unwrap_or(Projection::Ortho),
            wide,
        ));
    }
    failed += outcomes.iter().filter(|o| o.problem.is_some()).count();

    let _ = writeln!(
        report,
        "\n## Scenes\n\nEach against `reference` at the size shown, default transfer function; \
         bounds by integrator class (docs/peers.md): average {}, partial and preint {}, exact {}.\n",
        bound("average"),
        bound("partial"),
        bound("exact")
    );
    let _ = writeln!(
        report,
        "| scene | integrator | projection | size | RMSE | bound | wall ms | peer ms | RSS B/tet | result |"
    );
    let _ = writeln!(
        report,
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    let f = |v: Option<f64>, p: usize| v.map_or("–".to_string(), |x| format!("{x:.p$}"));
    for o in &outcomes {
        let _ = writeln!(
            report,
            "| {} | {} | {} | {}×{} | {} | {} | {} | {} | {} | {} |",
            o.scene,
            o.integrator,
            o.projection,
            o.size.0,
            o.size.1,
            o.rmse.map_or("–".into(), |x| format!("{x:.2e}")),
            o.bound,
            f(o.wall_ms, 1),
            f(o.peer_ms, 1),
            f(o.rss_per_tet, 0),
            match &o.problem {
                None => "pass".to_string(),
                Some(p) => format!("**FAIL**: {}", p.replace('|', "/")),
            }
        );
    }
    let scenes_failed = outcomes.iter().filter(|o| o.problem.is_some()).count();
    let _ = writeln!(
        report,
        "\n**{}**: {} of {} scenes passed{}.",
        if failed == 0 { "PASS" } else { "FAIL" },
        outcomes.len() - scenes_failed,
        outcomes.len(),
        if failed > scenes_failed {
            format!(", {} protocol checks failed", failed - scenes_failed)
        } else {
            String::new()
        }
    );
    Ok((report, failed))
}

/// Renders one scene with the peer and with `reference`, and judges it.
#[allow(clippy::too_many_arguments)]
fn check_scene(
    peer: &mut PeerRenderer,
    prepare_error: Option<&Error>,
    mesh: &Mesh,
    tf: &TransferFunction,
    s: &Scene,
    integrator: &str,
    projection: Projection,
    size: (u32, u32),
) -> Outcome {
    let mut o = Outcome {
        scene: format!("{} ({})", s.mesh, s.what),
        integrator: integrator.to_string(),
        projection: projection.name(),
        size,
        rmse: None,
        bound: bound(integrator),
        wall_ms: None,
        peer_ms: None,
        rss_per_tet: None,
        problem: None,
    };
    if let Some(e) = prepare_error {
        o.problem = Some(format!("prepare: {e}"));
        return o;
    }
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(s.view.0, s.view.1),
        projection,
        size.0,
        size.1,
    );
    let t0 = Instant::now();
    let frame = crate::bench::isolated(|| peer.render(mesh, &cam));
    o.wall_ms = Some(t0.elapsed().as_secs_f64() * 1e3);
    o.rss_per_tet = peer
        .memory()
        .external_bytes
        .map(|b| b as f64 / mesh.num_tets() as f64);
    let frame = match frame {
        Ok(f) => f,
        Err(e) => {
            o.problem = Some(e.to_string());
            return o;
        }
    };
    o.peer_ms = Some(frame.times.total_ms);
    match reference(mesh, tf, &cam).and_then(|r| metrics::compare(&frame.image, &r)) {
        Ok(e) => {
            o.rmse = Some(e.rmse);
            if e.rmse.is_nan() || e.rmse > o.bound {
                o.problem = Some(format!("RMSE {:.3e} above the bound {}", e.rmse, o.bound));
            }
        }
        Err(e) => o.problem = Some(format!("compare: {e}")),
    }
    o
}

fn reference(mesh: &Mesh, tf: &TransferFunction, cam: &Camera) -> Result<Image> {
    let mut r = render::make("reference", &RenderOptions::default())?;
    r.prepare(mesh, tf)?;
    Ok(r.render(mesh, cam)?.image)
}

/// The protocol checks on one process: its `hello` (if it answered) and a line per check.
fn protocol_checks(spec: &PeerSpec) -> (Option<protocol::Hello>, Vec<(bool, String)>) {
    let mut lines = Vec::new();
    let mut p = match PeerProcess::start(&spec.name, &spec.launch, None) {
        Ok(p) => p,
        Err(e) => {
            lines.push((false, format!("start: {e}")));
            return (None, lines);
        }
    };
    let t = spec.timeout;
    let t0 = Instant::now();
    let hello = p.call(&protocol::hello_request(p.dir()), t).and_then(|r| {
        if r["ok"] == json!(true) {
            protocol::read_hello(&spec.name, &r)
        } else {
            Err(Error::Input(format!("hello refused: {}", r["error"])))
        }
    });
    let hello = match hello {
        Ok(h) => {
            lines.push((
                !h.integrators.is_empty(),
                format!(
                    "`hello` answered in {:.0} ms: {} {}, integrators [{}], projections [{}]{}",
                    t0.elapsed().as_secs_f64() * 1e3,
                    h.name,
                    h.version,
                    h.integrators.join(", "),
                    h.projections.join(", "),
                    if h.integrators.is_empty() {
                        " (no integrators)"
                    } else {
                        ""
                    }
                ),
            ));
            h
        }
        Err(e) => {
            lines.push((false, format!("`hello`: {e}")));
            return (None, lines);
        }
    };
    let dir = p.dir().to_string_lossy().into_owned();
    let mut refused = |what: &str, request: serde_json::Value| {
        let r = p.call(&request, t);
        let ok = matches!(&r, Ok(v) if v["ok"] == json!(false) && v["error"].is_string());
        lines.push((
            ok,
            match r {
                Ok(v) if ok => format!(
                    "{what}: refused with {:?}",
                    v["error"].as_str().unwrap_or("")
                ),
                Ok(v) => format!("{what}: expected an error reply, got {v}"),
                Err(e) => format!("{what}: {e}"),
            },
        ));
    };
    refused(
        "a request of an unknown type",
        json!({"type": "tetbench-check-unknown"}),
    );
    refused(
        "`hello` of protocol 99.0",
        json!({"type": "hello", "protocol": "99.0", "dir": dir}),
    );
    let t1 = Instant::now();
    drop(p);
    let bye_ms = t1.elapsed().as_secs_f64() * 1e3;
    lines.push((
        bye_ms < 1900.0,
        format!("`bye`: the process group ended after {bye_ms:.0} ms (grace 2 s)"),
    ));
    (Some(hello), lines)
}

/// `tetbench peer check`'s entry: the report printed (and written to `out`), failures counted.
pub fn check(
    spec: PeerSpec,
    family: Option<PeerFamily>,
    size: (u32, u32),
    out: Option<&Path>,
) -> Result<usize> {
    eprintln!(
        "tetbench: peer '{}' runs `{}`",
        spec.name,
        spec.launch.command_line()
    );
    let (report, failed) = run(spec, family, size)?;
    print!("{report}");
    if let Some(path) = out {
        algorithms::io::atomic_write(path, |w| {
            use std::io::Write;
            w.write_all(report.as_bytes())
        })?;
    }
    Ok(failed)
}
