//! `tetbench jbu [--quick] [--out DIR]`: the joint bilateral upsampling experiment (issue 8),
//! after Callahan & Silva's Fig. 3/4 (time per resolution, upsampled to 1024²) and Fig. 5 (RMSE
//! rate–distortion, bilateral against linear and nearest).
//!
//! For every dataset and every renderer in the registry (less `reference` and wrappers): one
//! full-size frame (the reference image and the time to beat), then per low resolution one
//! low-res frame, upsampled by `nearest`, `linear` and `bilateral` with k = 1..4 depth layers
//! from that same low-res image. A row's `time_ms` = `low_ms` + `depth_ms` + `filter_ms`, the
//! frame time of the `jbu:<renderer>@<low_res>` wrapper; `speedup` = full-size time / `time_ms`;
//! `rmse` (CONVENTIONS §6) is against the full-size image of the same renderer.
//!
//! Writes `DIR/jbu.csv` and the plots `DIR/jbu_time_<renderer>.png|svg` (log time per resolution,
//! bilateral with the default k) and `DIR/jbu_rmse_<renderer>.png|svg` (RMSE per resolution, one
//! colour per dataset, solid bilateral, dashed linear, dotted nearest). The SVG is written by
//! hand (no plotting dependency).

use std::path::Path;

use algorithms::camera::{Camera, Projection, View};
use algorithms::image::Image;
use algorithms::jbu::{low_camera, Method, Params, Upsampler};
use algorithms::render::{self, Family, RenderOptions, Renderer};
use algorithms::{metrics, Error, Mesh, Result, TransferFunction};

use crate::measure::{measure, Frames};
use crate::meshes::{load_mesh, MeshSpec};
use crate::stats::median;

/// The experiment's settings.
#[derive(Clone, Debug)]
pub struct Plan {
    pub datasets: Vec<String>,
    pub renderers: Vec<String>,
    pub full: u32,
    pub lows: Vec<u32>,
    pub view: View,
    pub tf: String,
    pub repeats: usize,
}

impl Plan {
    pub fn new(quick: bool) -> Plan {
        // Every renderer of the papers' families (the exact reference is the yardstick, not a
        // contender; wrappers and external programs are not upsampled).
        let renderers = render::REGISTRY
            .iter()
            .filter(|r| matches!(r.family, Family::Pt | Family::RayCasting))
            .map(|r| r.name)
            .filter(|n| *n != "reference")
            .map(String::from)
            .collect();
        let (datasets, full, lows): (&[&str], u32, Vec<u32>) = if quick {
            (&["spx", "blunt"], 512, vec![64, 128, 256])
        } else {
            (
                &["blunt", "post", "comb", "spx", "torso:200000"],
                1024,
                vec![128, 256, 512],
            )
        };
        Plan {
            datasets: datasets.iter().map(|s| present_or_analogue(s)).collect(),
            renderers,
            full,
            lows,
            view: View::new(30.0, 20.0),
            tf: "default".into(),
            repeats: 1,
        }
    }
}

/// A NASA grid's name when its file is found, else its `datasets-gen` analogue (`blunt-like`),
/// saying so on stderr: the experiment runs without downloaded data.
fn present_or_analogue(name: &str) -> String {
    match algorithms::io::resolve_short_name(name) {
        Some(Err(_)) => {
            eprintln!("jbu: {name}: NASA grid not found, using its analogue {name}-like");
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
    summary(&rows);
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

/// Runs the plan; one row per (dataset, renderer, low size, method, k) plus one `full` row.
pub fn experiment(plan: &Plan) -> Result<Vec<Row>> {
    let tf = TransferFunction::load(&plan.tf)?;
    let threads = rayon::current_num_threads();
    let mut rows = Vec::new();
    let variants: Vec<Params> = [Method::Nearest, Method::Linear]
        .into_iter()
        .map(|method| Params {
            method,
            ..Params::default()
        })
        .chain((1..=4).map(|k| Params {
            k,
            ..Params::default()
        }))
        .collect();
    for ds in &plan.datasets {
        let mesh = load_mesh(&MeshSpec::named(ds))?;
        eprintln!("jbu: {ds} ({} tets)", mesh.num_tets());
        let mut ups: Vec<Upsampler> = variants
            .iter()
            .map(|p| Upsampler::new(*p))
            .collect::<Result<_>>()?;
        for u in &mut ups {
            u.prepare(&mesh);
        }
        let full_cam = Camera::new(
            &mesh.bbox(),
            plan.view,
            Projection::Ortho,
            plan.full,
            plan.full,
        );
        for rname in &plan.renderers {
            let mut r = render::make(rname, &RenderOptions::default())?;
            r.prepare(&mesh, &tf)?;
            // A first frame warms caches and the thread pool; it is not timed.
            r.render(&mesh, &low_camera(&mesh, &full_cam, 64, 64))?;
            let (full_img, full_ms, st) = timed(r.as_mut(), &mesh, &full_cam, plan.repeats)?;
            eprintln!("  {rname} {0}x{0}: {full_ms:.0} ms", plan.full);
            let base = |low: u32, method: &str, k: usize, sigma: f64| Row {
                dataset: ds.clone(),
                tets: mesh.num_tets(),
                renderer: rname.clone(),
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
                azimuth: plan.view.azimuth,
                elevation: plan.view.elevation,
            };
            rows.push(Row {
                time_ms: full_ms,
                low_ms: full_ms,
                project_ms: st[0],
                sort_ms: st[1],
                draw_ms: st[2],
                ..base(plan.full, "full", 0, 0.0)
            });
            let largest = plan.lows.iter().copied().max().unwrap_or(0);
            for &low in &plan.lows {
                let reps = if low == largest {
                    plan.repeats
                } else {
                    plan.repeats.max(3)
                };
                let low_cam = low_camera(&mesh, &full_cam, low, low);
                let (low_img, low_ms, st) = timed(r.as_mut(), &mesh, &low_cam, reps)?;
                for u in &ups {
                    let mut depth = Vec::new();
                    let mut filter = Vec::new();
                    let mut img = None;
                    for _ in 0..reps.max(3) {
                        let o = u.run(&low_img, &low_cam, &full_cam)?;
                        depth.push(o.depth_ms);
                        filter.push(o.filter_ms);
                        img = Some(o.image);
                    }
                    let img = img.unwrap_or_else(|| Image::new(1, 1));
                    let e = metrics::compare(&img, &full_img)?;
                    let (depth_ms, filter_ms) = (median(&depth), median(&filter));
                    let time_ms = low_ms + depth_ms + filter_ms;
                    let p = u.params;
                    let bil = p.method == Method::Bilateral;
                    rows.push(Row {
                        rmse: e.rmse,
                        psnr: e.psnr,
                        max_abs: e.max_abs,
                        time_ms,
                        low_ms,
                        depth_ms,
                        filter_ms,
                        project_ms: st[0],
                        sort_ms: st[1],
                        draw_ms: st[2],
                        speedup: full_ms / time_ms.max(1e-9),
                        repeats: reps,
                        ..base(
                            low,
                            p.method.name(),
                            if bil { p.k } else { 0 },
                            if bil { p.sigma_r } else { 0.0 },
                        )
                    });
                }
                let b = rows
                    .iter()
                    .rev()
                    .find(|r| r.method == "bilateral" && r.k == Params::default().k)
                    .map(|r| (r.time_ms, r.speedup, r.rmse))
                    .unwrap_or_default();
                let lin = rows
                    .iter()
                    .rev()
                    .find(|r| r.method == "linear")
                    .map(|r| r.rmse)
                    .unwrap_or_default();
                eprintln!(
                    "  {rname} {low}->{}: {:.0} ms ({:.1}x), rmse bilateral {:.5} linear {:.5}",
                    plan.full, b.0, b.1, b.2, lin
                );
            }
        }
    }
    Ok(rows)
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
    write_plots(rows, plan, dir)?;
    eprintln!("jbu: wrote {}", path.display());
    Ok(())
}

/// The plots `DIR/jbu_time_<renderer>.{png,svg}` and `DIR/jbu_rmse_<renderer>.{png,svg}`
/// (plotters, like every other plot of the harness).
pub fn write_plots(rows: &[Row], plan: &Plan, dir: &Path) -> Result<()> {
    for rname in &plan.renderers {
        let file = rname.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_");
        time_plot(rows, plan, rname, &dir.join(format!("jbu_time_{file}")))?;
        rmse_plot(rows, plan, rname, &dir.join(format!("jbu_rmse_{file}")))?;
    }
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
        lows: Vec::new(),
        view: first.map_or(View::new(30.0, 20.0), |r| View::new(r.azimuth, r.elevation)),
        tf: "default".into(),
        repeats: first.map_or(1, |r| r.repeats),
    };
    Ok((rows, plan))
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    algorithms::io::atomic_write(path, |w| std::io::Write::write_all(w, bytes))
}

/// One line per (dataset, renderer) with the default bilateral at every size.
fn summary(rows: &[Row]) {
    let k = Params::default().k;
    println!("dataset,renderer,low_res,full_res,time_ms,speedup,rmse_bilateral,rmse_linear,rmse_nearest,bilateral_beats_linear");
    for r in rows.iter().filter(|r| r.method == "bilateral" && r.k == k) {
        let same = |m: &str| {
            rows.iter()
                .find(|o| {
                    o.method == m
                        && o.dataset == r.dataset
                        && o.renderer == r.renderer
                        && o.low_res == r.low_res
                })
                .map(|o| o.rmse)
                .unwrap_or(f64::NAN)
        };
        let (l, n) = (same("linear"), same("nearest"));
        println!(
            "{},{},{},{},{:.1},{:.2},{:.6},{:.6},{:.6},{}",
            r.dataset,
            r.renderer,
            r.low_res,
            r.full_res,
            r.time_ms,
            r.speedup,
            r.rmse,
            l,
            n,
            r.rmse < l
        );
    }
}

/// Fig. 3/4: time per resolution, bilateral with the default k; the full size is the
/// renderer itself.
fn time_plot(rows: &[Row], plan: &Plan, renderer: &str, stem: &Path) -> Result<()> {
    let k = Params::default().k;
    let series = plan
        .datasets
        .iter()
        .map(|ds| {
            let pts = rows
                .iter()
                .filter(|r| &r.dataset == ds && r.renderer == renderer)
                .filter(|r| r.method == "full" || (r.method == "bilateral" && r.k == k))
                .map(|r| (r.low_res as f64, r.time_ms))
                .collect();
            (ds.clone(), pts)
        })
        .collect();
    let title = format!(
        "{renderer}: time per frame, upsampled to {0}² (JBU Fig. 3/4)",
        plan.full
    );
    let x = "rendered resolution (pixels per side; the largest is the full-size render)";
    crate::plots::lines_loglog(series, stem, &title, x, "time per frame (ms)")?;
    Ok(())
}

/// Fig. 5: RMSE against the full-size image per resolution, per dataset and method
/// (bilateral with the default k, linear, nearest).
fn rmse_plot(rows: &[Row], plan: &Plan, renderer: &str, stem: &Path) -> Result<()> {
    let k = Params::default().k;
    let mut series = Vec::new();
    for ds in &plan.datasets {
        for m in ["bilateral", "linear", "nearest"] {
            let pts = rows
                .iter()
                .filter(|r| &r.dataset == ds && r.renderer == renderer && r.method == m)
                .filter(|r| m != "bilateral" || r.k == k)
                .map(|r| (r.low_res as f64, r.rmse))
                .collect();
            series.push((format!("{ds} {m}"), pts));
        }
    }
    let title = format!(
        "{renderer}: RMSE against the full {0}² image (JBU Fig. 5)",
        plan.full
    );
    let x = "rendered resolution (pixels per side)";
    crate::plots::lines_loglog(series, stem, &title, x, "RMSE (linear RGBA, 0..1)")?;
    Ok(())
}
