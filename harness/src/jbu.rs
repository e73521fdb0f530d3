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
//! Writes `DIR/jbu.csv` and the plots `DIR/jbu_time_<renderer>.svg` (log time per resolution,
//! bilateral with the default k) and `DIR/jbu_rmse_<renderer>.svg` (RMSE per resolution, one
//! colour per dataset, solid bilateral, dashed linear, dotted nearest). The SVG is written by
//! hand (no plotting dependency).

use std::fmt::Write as _;
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
            datasets: datasets.iter().map(|s| s.to_string()).collect(),
            renderers,
            full,
            lows,
            view: View::new(30.0, 20.0),
            tf: "default".into(),
            repeats: 1,
        }
    }
}

/// One CSV row.
#[derive(Clone, Debug, serde::Serialize)]
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
    for rname in &plan.renderers {
        let file = rname.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_");
        let svg = time_plot(rows, plan, rname);
        write_file(&dir.join(format!("jbu_time_{file}.svg")), svg.as_bytes())?;
        let svg = rmse_plot(rows, plan, rname);
        write_file(&dir.join(format!("jbu_rmse_{file}.svg")), svg.as_bytes())?;
    }
    eprintln!("jbu: wrote {}", path.display());
    Ok(())
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

// ---- hand-written SVG line plots ----

const COLORS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

struct Series {
    label: String,
    color: &'static str,
    dash: &'static str,
    points: Vec<(f64, f64)>,
}

/// A line plot with a log2 x axis (resolutions) and a linear or log10 y axis.
fn svg_plot(title: &str, xlabel: &str, ylabel: &str, series: &[Series], log_y: bool) -> String {
    let (w, h) = (720.0, 460.0);
    let (l, r, t, b) = (80.0, 200.0, 40.0, 60.0);
    let pts = || series.iter().flat_map(|s| s.points.iter().copied());
    let fy = |y: f64| if log_y { y.max(1e-12).log10() } else { y };
    let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
    for (x, y) in pts() {
        if !(x > 0.0 && y.is_finite()) || (log_y && y <= 0.0) {
            continue;
        }
        x0 = x0.min(x.log2());
        x1 = x1.max(x.log2());
        y0 = y0.min(fy(y));
        y1 = y1.max(fy(y));
    }
    if !(x0.is_finite() && y0.is_finite()) {
        x0 = 0.0;
        x1 = 1.0;
        y0 = 0.0;
        y1 = 1.0;
    }
    if log_y {
        y0 = y0.floor();
        y1 = y1.ceil().max(y0 + 1.0);
    } else {
        y0 = 0.0;
        y1 = if y1 > 0.0 { y1 * 1.1 } else { 1.0 };
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let (pw, ph) = (w - l - r, h - t - b);
    let sx = |x: f64| l + (x.log2() - x0) / (x1 - x0) * pw;
    let sy = |y: f64| t + ph - (fy(y) - y0) / (y1 - y0) * ph;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
        l + pw / 2.0,
        esc(title)
    );
    let _ = writeln!(
        s,
        r#"<rect x="{l}" y="{t}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
    );
    // x ticks at the powers of two in range.
    let mut e = x0.ceil();
    while e <= x1 + 1e-9 {
        let x = 2f64.powf(e);
        let px = sx(x);
        let _ = writeln!(
            s,
            r##"<line x1="{px}" y1="{t}" x2="{px}" y2="{}" stroke="#dddddd"/><text x="{px}" y="{}" text-anchor="middle">{}²</text>"##,
            t + ph,
            t + ph + 16.0,
            x
        );
        e += 1.0;
    }
    // y ticks: decades (log) or 5 steps.
    let ticks: Vec<f64> = if log_y {
        (y0 as i32..=y1 as i32).map(|d| 10f64.powi(d)).collect()
    } else {
        (0..=5).map(|i| y1 * i as f64 / 5.0).collect()
    };
    for v in ticks {
        let py = sy(v);
        let _ = writeln!(
            s,
            r##"<line x1="{l}" y1="{py}" x2="{}" y2="{py}" stroke="#dddddd"/><text x="{}" y="{}" text-anchor="end">{}</text>"##,
            l + pw,
            l - 6.0,
            py + 4.0,
            fmt_tick(v)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        l + pw / 2.0,
        h - 18.0,
        esc(xlabel)
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">{}</text>"#,
        t + ph / 2.0,
        t + ph / 2.0,
        esc(ylabel)
    );
    for (n, se) in series.iter().enumerate() {
        let p: Vec<String> = se
            .points
            .iter()
            .filter(|(x, y)| *x > 0.0 && y.is_finite() && (!log_y || *y > 0.0))
            .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2" stroke-dasharray="{}"/>"#,
            p.join(" "),
            se.color,
            se.dash
        );
        for q in &p {
            let (x, y) = q.split_once(',').unwrap_or(("0", "0"));
            let _ = writeln!(
                s,
                r#"<circle cx="{x}" cy="{y}" r="3" fill="{}"/>"#,
                se.color
            );
        }
        let ly = t + 14.0 + 18.0 * n as f64;
        let lx = l + pw + 12.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="2" stroke-dasharray="{}"/><text x="{}" y="{}">{}</text>"#,
            lx + 28.0,
            se.color,
            se.dash,
            lx + 34.0,
            ly + 4.0,
            esc(&se.label)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn fmt_tick(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&v.abs()) {
        let t = format!("{v:.4}");
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Fig. 3/4: time per resolution (log), bilateral with the default k; the full size is the
/// renderer itself.
fn time_plot(rows: &[Row], plan: &Plan, renderer: &str) -> String {
    let k = Params::default().k;
    let series: Vec<Series> = plan
        .datasets
        .iter()
        .enumerate()
        .map(|(n, ds)| Series {
            label: ds.clone(),
            color: COLORS[n % COLORS.len()],
            dash: "none",
            points: rows
                .iter()
                .filter(|r| &r.dataset == ds && r.renderer == renderer)
                .filter(|r| r.method == "full" || (r.method == "bilateral" && r.k == k))
                .map(|r| (r.low_res as f64, r.time_ms))
                .collect(),
        })
        .collect();
    svg_plot(
        &format!(
            "{renderer}: time per frame, upsampled to {0}² (JBU Fig. 3/4)",
            plan.full
        ),
        "rendered resolution (the largest is the full-size render)",
        "time per frame (ms, log)",
        &series,
        true,
    )
}

/// Fig. 5: RMSE against the full-size image per resolution; bilateral (solid, default k),
/// linear (dashed), nearest (dotted).
fn rmse_plot(rows: &[Row], plan: &Plan, renderer: &str) -> String {
    let k = Params::default().k;
    let mut series = Vec::new();
    for (n, ds) in plan.datasets.iter().enumerate() {
        for (m, dash) in [("bilateral", "none"), ("linear", "6,4"), ("nearest", "2,3")] {
            series.push(Series {
                label: format!("{ds} {m}"),
                color: COLORS[n % COLORS.len()],
                dash,
                points: rows
                    .iter()
                    .filter(|r| &r.dataset == ds && r.renderer == renderer && r.method == m)
                    .filter(|r| m != "bilateral" || r.k == k)
                    .map(|r| (r.low_res as f64, r.rmse))
                    .collect(),
            });
        }
    }
    svg_plot(
        &format!(
            "{renderer}: RMSE against the full {0}² image (JBU Fig. 5)",
            plan.full
        ),
        "rendered resolution",
        "RMSE",
        &series,
        false,
    )
}
