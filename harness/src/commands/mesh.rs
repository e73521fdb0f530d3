//! The commands on one mesh: `info`, `convert` and `render`.

use std::time::Instant;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io;
use algorithms::render::{self, RenderOptions};
use algorithms::{util::alloc, Error, Result, TransferFunction};
use serde_json::json;

use super::output::{num, print_pairs};
use crate::cli::{MeshArgs, RenderArgs};
use crate::measure::{measure, Frames};
use crate::meshes::{load_mesh, parse_size};

/// `tetbench convert`: the mesh as tetbench loads it, written by extension.
pub(super) fn convert(args: &MeshArgs, out: &std::path::Path) -> Result<()> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !io::writers::FORMATS.contains(&ext.as_str()) {
        return Err(Error::Input(format!(
            "{}: output must end in .{}",
            out.display(),
            io::writers::FORMATS.join(", .")
        )));
    }
    let mesh = load_mesh(&args.to_spec())?;
    io::write(&mesh, out)?;
    let (field, step) = mesh.active_field();
    let arrays: usize = mesh.fields().iter().map(|f| f.steps.len()).sum();
    if ext == "off" && arrays > 1 {
        eprintln!(
            "tetbench: note: .off holds one field: {field}[{step}] written, the other {} arrays are not (write .vtu or .vtk for every field)",
            arrays - 1
        );
    }
    print_pairs(
        [
            ("vertices", json!(mesh.num_vertices())),
            ("tets", json!(mesh.num_tets())),
            ("scalar_field", json!(format!("{field}[{step}]"))),
            ("arrays", json!(if ext == "off" { 1 } else { arrays })),
            ("out", json!(out.display().to_string())),
        ],
        false,
    );
    Ok(())
}

pub(super) fn info(args: &MeshArgs, as_json: bool) -> Result<()> {
    let t0 = Instant::now();
    let mesh = load_mesh(&args.to_spec())?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let bb = mesh.bbox();
    let (lo, hi) = mesh.scalar_range();
    let (field, step) = mesh.active_field();
    let fields: Vec<String> = mesh
        .fields()
        .iter()
        .map(|f| {
            if f.steps.len() > 1 {
                format!("{}[{} steps]", f.name, f.steps.len())
            } else {
                f.name.clone()
            }
        })
        .collect();
    let adj = mesh.adjacency();
    let pairs = vec![
        ("vertices", json!(mesh.num_vertices())),
        ("tets", json!(mesh.num_tets())),
        (
            "scalar_range",
            if as_json {
                json!([lo, hi])
            } else {
                json!(format!("[{lo}, {hi}]"))
            },
        ),
        (
            "bbox",
            if as_json {
                json!([bb.min.to_array(), bb.max.to_array()])
            } else {
                json!(format!(
                    "[{}, {}, {}] [{}, {}, {}]",
                    bb.min.x, bb.min.y, bb.min.z, bb.max.x, bb.max.y, bb.max.z
                ))
            },
        ),
        ("degenerate_tets", json!(mesh.degenerate_tets())),
        ("boundary_faces", json!(mesh.boundary_faces().len())),
        ("convex", json!(mesh.is_convex())),
        ("diagonal", json!(mesh.diagonal())),
        ("negative_tets", json!(mesh.negative_tets())),
        ("nonmanifold_faces", json!(adj.nonmanifold_faces)),
        ("scalar_field", json!(format!("{field}[{step}]"))),
        ("fields", json!(fields.join(", "))),
        ("load_ms", json!((load_ms * 1000.0).round() / 1000.0)),
    ];
    if as_json {
        print_pairs(pairs, true);
    } else {
        print_pairs(pairs, false);
    }
    Ok(())
}

pub(super) fn render_cmd(args: &RenderArgs) -> Result<()> {
    // Check every name and flag before the (possibly long) load and render.
    let ext = args
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "png")) {
        return Err(Error::Input(format!(
            "{}: output must end in .exr or .png",
            args.out.display()
        )));
    }
    let params = args
        .params
        .iter()
        .map(|kv| {
            kv.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .ok_or_else(|| {
                    algorithms::Error::Input(format!("--param {kv}: expected KEY=VALUE"))
                })
        })
        .collect::<Result<Vec<_>>>()?;
    let opts = RenderOptions {
        sort: args.sort.clone(),
        integrator: args.integrator.clone(),
        params,
        log_dir: None,
    };
    let mut renderer = render::make(&args.renderer, &opts)?;
    crate::bench::announce_peers([args.renderer.as_str()]);
    let tf = TransferFunction::load(&args.tf)?;
    let view = View::parse(&args.view)?;
    let projection = Projection::parse(&args.projection)?;
    let (w, h) = parse_size(&args.size).map_err(|e| match e {
        Error::Input(m) => Error::Input(format!("--{m}")),
        o => o,
    })?;
    let mesh = load_mesh(&args.mesh.to_spec())?;

    let t0 = Instant::now();
    let (res, bytes, _peak) =
        crate::measure::prepare_counted(&args.renderer, || renderer.prepare(&mesh, &tf));
    res?;
    let setup_ms = t0.elapsed().as_secs_f64() * 1e3;
    let camera = Camera::new(&mesh.bbox(), view, projection, w, h);
    let once = Frames {
        warmup: 0,
        repeats: 1,
    };
    let frame = measure(renderer.as_mut(), &mesh, &camera, once)?;
    frame.image.write(&args.out)?;

    let t = frame.times;
    let tets = mesh.num_tets() as f64;
    let (d, memory) = (renderer.describe(), renderer.memory());
    let mut pairs = vec![
        ("renderer", json!(d.name)),
        ("sort", json!(d.sort)),
        ("integrator", json!(d.integrator)),
        ("device", json!(d.device)),
        ("tets", json!(mesh.num_tets())),
        ("width", json!(w)),
        ("height", json!(h)),
        ("setup_ms", num(setup_ms)),
        ("project_ms", num(t.project_ms)),
        ("sort_ms", num(t.sort_ms)),
        ("draw_ms", num(t.draw_ms)),
        ("readback_ms", num(t.readback_ms)),
        ("total_ms", num(t.total_ms)),
        ("tets_per_s", num(tets / (t.total_ms.max(1e-9) * 1e-3))),
        (
            "cpu_bytes_per_tet",
            // An external renderer (VTK): its helper process's peak RSS.
            if let Some(b) = memory.external_bytes {
                num(b as f64 / tets)
            } else if alloc::is_counting() {
                num(bytes as f64 / tets)
            } else {
                json!("not measured")
            },
        ),
        ("gpu_bytes_per_tet", num(memory.gpu_bytes as f64 / tets)),
        // The fixed cost kept apart from cpu_bytes_per_tet (CONVENTIONS §7).
        (
            "shared_fixed_bytes",
            json!(crate::measure::shared_fixed_bytes()),
        ),
        ("non_finite_pixels", json!(frame.image.non_finite_pixels())),
    ];
    for (k, v) in &frame.counters {
        pairs.push((k, num(*v)));
    }
    pairs.push(("out", json!(args.out.display().to_string())));
    print_pairs(pairs, args.json);
    Ok(())
}
