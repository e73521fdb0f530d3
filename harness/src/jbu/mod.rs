//! `tetbench jbu [--quick] [--out DIR]`: the joint bilateral upsampling experiment (issues 8,
//! 14) on Callahan & Silva's protocol: each dataset rendered from the paper's 14 cube views (the
//! 8 corners and 6 faces, [`cube_views`]) at 1024² and at 512², 256², 128² upsampled to 1024²;
//! Fig. 3/4 (time per resolution) and Fig. 5 (RMSE rate–distortion, bilateral against linear).
//!
//! For every dataset, renderer and view: one full-size frame (the reference image and the time
//! to beat), then per low resolution one low-res frame, upsampled by every [`METHODS`] entry
//! (default parameters) from that same low-res image. A row's `time_ms` = `low_ms` +
//! `depth_ms` + `filter_ms`, the frame time of the `jbu:<renderer>@<low_res>` wrapper;
//! `speedup` = the view's full-size time / `time_ms`; `rmse` (CONVENTIONS §6) is against the
//! full-size image of the same renderer from the same view. One row per (view, method) with the
//! view's `azimuth`/`elevation`; a cell (dataset, renderer, resolution) is summarised by the
//! mean and worst view ([`report`]).
//!
//! Renderers: the ray caster and cpu-pt, and the GPU renderers of the papers' families only
//! when the adapter is a real GPU (on a software rasteriser such as lavapipe they are left out
//! and the report says so; `--renderers` overrides). `--quick`: 512² from 64², 128², 256², two
//! generated datasets, two views (a corner and a face).
//!
//! Writes `DIR/jbu.csv`, `DIR/jbu.md` and the plots `DIR/jbu_time_<renderer>.png|svg` (median
//! time per resolution, bilateral) and `DIR/jbu_rmse_<renderer>.png|svg` (mean RMSE per
//! resolution, one colour per dataset and method), drawn by plotters.

use std::path::Path;

use algorithms::camera::{Camera, Projection, View};
use algorithms::image::Image;
use algorithms::jbu::{cube_views, low_camera, Method, Params, Upsampler};
use algorithms::render::{self, Family, RenderOptions, Renderer};
use algorithms::{metrics, Error, Mesh, Result, TransferFunction};

use crate::measure::{measure, Frames};
use crate::meshes::{load_mesh, MeshSpec};

pub mod report;

/// The upsampling methods every view is filtered with, each with its default parameters.
pub const METHODS: [Method; 4] = [
    Method::Nearest,
    Method::Linear,
    Method::Bilateral,
    Method::Gauss,
];

/// The experiment's settings.
#[derive(Clone, Debug)]
pub struct Plan {
    pub datasets: Vec<String>,
    pub renderers: Vec<String>,
    pub full: u32,
    pub lows: Vec<u32>,
    pub views: Vec<View>,
    pub tf: String,
    pub repeats: usize,
    /// Renderers left out, with why (for the report).
    pub notes: Vec<String>,
}

impl Plan {
    pub fn new(quick: bool) -> Plan {
        let mut notes = Vec::new();
        let renderers = if quick {
            // Every renderer of the papers' families (the exact reference is the yardstick, not
            // a contender; wrappers and external programs are not upsampled).
            render::REGISTRY
                .iter()
                .filter(|r| matches!(r.family, Family::Pt | Family::RayCasting))
                .map(|r| r.name)
                .filter(|n| *n != "reference")
                .map(String::from)
                .collect()
        } else {
            let mut v = vec!["raycast".to_string(), "cpu-pt".to_string()];
            let gpu: Vec<&str> = render::REGISTRY
                .iter()
                .filter(|r| r.needs_gpu && matches!(r.family, Family::Pt | Family::RayCasting))
                .map(|r| r.name)
                .collect();
            match algorithms::gpu::Gpu::shared() {
                Ok(g) if g.info.device_type != algorithms::gpu::wgpu::DeviceType::Cpu => {
                    v.extend(gpu.iter().map(|s| s.to_string()))
                }
                Ok(g) => notes.push(format!(
                    "GPU renderers ({}) left out: the adapter is a software rasteriser ({})",
                    gpu.join(", "),
                    g.info.name
                )),
                Err(e) => notes.push(format!(
                    "GPU renderers ({}) left out: no GPU adapter ({e})",
                    gpu.join(", ")
                )),
            }
            v
        };
        let (datasets, full, lows): (&[&str], u32, Vec<u32>) = if quick {
            (&["spx", "blunt-like"], 512, vec![64, 128, 256])
        } else {
            (
                &["spx", "blunt", "spx2", "fighter:240000", "post", "comb"],
                1024,
                vec![128, 256, 512],
            )
        };
        let all = cube_views();
        let views = if quick { vec![all[0], all[8]] } else { all };
        Plan {
            datasets: datasets
                .iter()
                .map(|s| present_or_analogue(s, &mut notes))
                .collect(),
            renderers,
            full,
            lows,
            views,
            tf: "default".into(),
            repeats: 1,
            notes,
        }
    }
}

/// A NASA grid's name when its file is found, else its `datasets-gen` analogue (`blunt-like`),
/// saying so on stderr and in the report: the experiment runs without downloaded data.
fn present_or_analogue(name: &str, notes: &mut Vec<String>) -> String {
    match algorithms::io::resolve_short_name(name) {
        Some(Err(_)) => {
            let n = format!("{name}: NASA grid not found, its analogue {name}-like is used");
            eprintln!("jbu: {n}");
            notes.push(n);
            format!("{name}-like")
        }
        _ => name.to_string(),
    }
}

/// One CSV row.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Row {
    pub dataset: String,
    pub tets: usize,
    pub renderer: String,
    pub low_res: u32,
    pub full_res: u32,
    pub factor: f64,
    pub method: String,
    pub k: usize,
    pub sigma: f64,
    pub rmse: f64,
    pub psnr: f64,
    pub max_abs: f64,
    pub time_ms: f64,
    pub low_ms: f64,
    pub depth_ms: f64,
    pub filter_ms: f64,
    pub project_ms: f64,
    pub sort_ms: f64,
    pub draw_ms: f64,
    pub full_ms: f64,
    pub speedup: f64,
    pub repeats: usize,
    pub threads: usize,
    /// Index into the plan's views (cube views: 0–7 corners, 8–13 faces).
    pub view: usize,
    pub azimuth: f64,
    pub elevation: f64,
}

/// Checks the plan's names, runs it and writes `DIR/jbu.csv` and the plots.
pub fn run(plan: &Plan, out: &Path) -> Result<()> {
    for n in &plan.renderers {
        render::info(n)?;
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let rows = experiment(plan)?;
    write_outputs(&rows, plan, out)?;
    report::print_summary(&rows);
    Ok(())
}

/// Redraws the plots and `jbu.md` of `DIR/jbu.csv` (the notes on left-out renderers are those
/// of this machine).
pub fn replot(dir: &Path) -> Result<()> {
    let (rows, mut plan) = read_rows(&dir.join("jbu.csv"))?;
    plan.notes = Plan::new(false)
        .notes
        .into_iter()
        .filter(|n| n.starts_with("GPU"))
        .collect();
    report::write_plots(&rows, &plan, dir)?;
    report::write_md(&rows, &plan, dir)?;
    report::print_summary(&rows);
    Ok(())
}

/// `reps` measured frames: the last image, the median wall time and the median stage times.
fn timed(
    r: &mut dyn Renderer,
    mesh: &Mesh,
    cam: &Camera,
    reps: usize,
) -> Result<(Image, f64, [f64; 3])> {
    let frames = Frames {
        warmup: 0,
        repeats: reps,
    };
    let m = measure(r, mesh, cam, frames)?;
    Ok((
        m.image,
        m.wall_ms,
        [m.times.project_ms, m.times.sort_ms, m.times.draw_ms],
    ))
}

/// Runs the plan; per (dataset, renderer, view) one `full` row and one row per (low size,
/// method).
pub fn experiment(plan: &Plan) -> Result<Vec<Row>> {
    let tf = TransferFunction::load(&plan.tf)?;
    let threads = rayon::current_num_threads();
    let mut rows = Vec::new();
    for ds in &plan.datasets {
        let mesh = load_mesh(&MeshSpec::named(ds))?;
        eprintln!("jbu: {ds} ({} tets)", mesh.num_tets());
        let mut ups: Vec<Upsampler> = METHODS
            .iter()
            .map(|&method| {
                Upsampler::new(Params {
                    method,
                    ..Params::default()
                })
            })
            .collect::<Result<_>>()?;
        for u in &mut ups {
            u.prepare(&mesh);
        }
        for rname in &plan.renderers {
            let mut r = render::make(rname, &RenderOptions::default())?;
            r.prepare(&mesh, &tf)?;
            for (vi, &view) in plan.views.iter().enumerate() {
                let full_cam =
                    Camera::new(&mesh.bbox(), view, Projection::Ortho, plan.full, plan.full);
                if vi == 0 {
                    // A first frame warms caches and the thread pool; it is not timed.
                    r.render(&mesh, &low_camera(&mesh, &full_cam, 64, 64))?;
                }
                view_rows(
                    plan,
                    &mesh,
                    ds,
                    rname,
                    r.as_mut(),
                    &ups,
                    vi,
                    threads,
                    &mut rows,
                )?;
            }
            report::print_cells(&rows, ds, rname);
        }
    }
    Ok(rows)
}

/// The rows of one view: the full-size frame, then every low size and method.
#[allow(clippy::too_many_arguments)]
fn view_rows(
    plan: &Plan,
    mesh: &Mesh,
    ds: &str,
    rname: &str,
    r: &mut dyn Renderer,
    ups: &[Upsampler],
    vi: usize,
    threads: usize,
    rows: &mut Vec<Row>,
) -> Result<()> {
    let view = plan.views[vi];
    let full_cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, plan.full, plan.full);
    let (full_img, full_ms, st) = timed(r, mesh, &full_cam, plan.repeats)?;
    let base = |low: u32, method: &str, k: usize, sigma: f64| Row {
        dataset: ds.to_string(),
        tets: mesh.num_tets(),
        renderer: rname.to_string(),
        low_res: low,
        full_res: plan.full,
        factor: plan.full as f64 / low as f64,
        method: method.into(),
        k,
        sigma,
        rmse: 0.0,
        psnr: f64::INFINITY,
        max_abs: 0.0,
        time_ms: 0.0,
        low_ms: 0.0,
        depth_ms: 0.0,
        filter_ms: 0.0,
        project_ms: 0.0,
        sort_ms: 0.0,
        draw_ms: 0.0,
        full_ms,
        speedup: 1.0,
        repeats: plan.repeats,
        threads,
        view: vi,
        azimuth: view.azimuth,
        elevation: view.elevation,
    };
    rows.push(Row {
        time_ms: full_ms,
        low_ms: full_ms,
        project_ms: st[0],
        sort_ms: st[1],
        draw_ms: st[2],
        ..base(plan.full, "full", 0, 0.0)
    });
    for &low in &plan.lows {
        let low_cam = low_camera(mesh, &full_cam, low, low);
        let (low_img, low_ms, st) = timed(r, mesh, &low_cam, plan.repeats)?;
        for u in ups {
            let o = u.run(&low_img, &low_cam, &full_cam)?;
            let e = metrics::compare(&o.image, &full_img)?;
            let time_ms = low_ms + o.depth_ms + o.filter_ms;
            let p = u.params;
            let guided = p.method.guided();
            rows.push(Row {
                rmse: e.rmse,
                psnr: e.psnr,
                max_abs: e.max_abs,
                time_ms,
                low_ms,
                depth_ms: o.depth_ms,
                filter_ms: o.filter_ms,
                project_ms: st[0],
                sort_ms: st[1],
                draw_ms: st[2],
                speedup: full_ms / time_ms.max(1e-9),
                ..base(
                    low,
                    p.method.name(),
                    if guided { p.k } else { 0 },
                    if guided { p.sigma_r } else { 0.0 },
                )
            });
        }
    }
    Ok(())
}

fn write_outputs(rows: &[Row], plan: &Plan, dir: &Path) -> Result<()> {
    let path = dir.join("jbu.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .map_err(|e| Error::Internal(format!("jbu.csv: {e}")))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| Error::Internal(format!("jbu.csv: {e}")))?;
    write_file(&path, &bytes)?;
    report::write_plots(rows, plan, dir)?;
    report::write_md(rows, plan, dir)?;
    eprintln!("jbu: wrote {}", path.display());
    Ok(())
}

/// Reads a `jbu.csv` back, with the plan it was run with (datasets, renderers, sizes).
pub fn read_rows(path: &Path) -> Result<(Vec<Row>, Plan)> {
    let err = |e: csv::Error| Error::Input(format!("{}: {e}", path.display()));
    let mut r = csv::Reader::from_path(path).map_err(err)?;
    let rows: Vec<Row> = r
        .deserialize()
        .collect::<std::result::Result<_, _>>()
        .map_err(err)?;
    let uniq = |f: fn(&Row) -> String| {
        let mut v: Vec<String> = Vec::new();
        for x in rows.iter().map(f) {
            if !v.contains(&x) {
                v.push(x);
            }
        }
        v
    };
    let first = rows.first();
    let plan = Plan {
        datasets: uniq(|r| r.dataset.clone()),
        renderers: uniq(|r| r.renderer.clone()),
        full: first.map_or(0, |r| r.full_res),
        lows: {
            let mut l: Vec<u32> = rows.iter().map(|r| r.low_res).collect();
            l.sort_unstable();
            l.dedup();
            l.retain(|&x| Some(x) != first.map(|r| r.full_res));
            l
        },
        views: {
            let n = rows.iter().map(|r| r.view + 1).max().unwrap_or(0);
            (0..n)
                .map(|v| {
                    rows.iter()
                        .find(|r| r.view == v)
                        .map_or(View::new(0.0, 0.0), |r| View::new(r.azimuth, r.elevation))
                })
                .collect()
        },
        tf: "default".into(),
        repeats: first.map_or(1, |r| r.repeats),
        notes: Vec::new(),
    };
    Ok((rows, plan))
}

pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    algorithms::io::atomic_write(path, |w| std::io::Write::write_all(w, bytes))
}
