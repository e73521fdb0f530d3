//! The JBU paper (Callahan & Silva): Fig. 3/4 (time per rendering resolution) and Fig. 5 (RMSE
//! of bilateral against linear and nearest upsampling), on the paper's protocol: each dataset
//! from the 14 cube views (the 8 corners and 6 faces of a cube around it,
//! `algorithms::render::jbu::cube_views`) at the full size, and at three lower sizes upsampled to it.
//!
//! The experiment: for each renderer R of the projected-tetrahedra and ray-casting families
//! (GPU ones only on a real GPU; the exact `reference` is the yardstick of the other tables,
//! not a contender), the variant R itself at the full size and the wrappers
//! `jbu:R@<low>,method=<m>` for every low size and [`METHODS`] entry, each measured against R's
//! own full-size image of the same view (the yardstick `reference = R`). A wrapper's
//! `total_ms` is the low-res render + depth layers + filter (its counters `low_ms`, `depth_ms`,
//! `filter_ms`); the speed-up is R's full-size time over it, per view.
//!
//! The table has one row per (renderer, dataset, rendered resolution): the medians over the
//! views of the times and the speed-up, and the mean and worst view of each method's RMSE; the
//! notes hold the paper's statements and the checks. Plots: `jbu_time_<renderer>` (Fig. 3/4)
//! and `jbu_rmse_<renderer>` (Fig. 5).
//!
//! Past 600 lines only with its tests (about 575 lines of code): the table is one experiment.

use std::path::{Path, PathBuf};

use algorithms::camera::View;
use algorithms::render::jbu::{cube_views, Method, Params};
use algorithms::render::{self, jbu::LowSize, Family};
use algorithms::Result;

use super::common::{base_config, dataset, failure, mesh_used};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::{Config, DatasetSpec, RendererSpec, ViewsSpec};
use crate::rows::Row;
use crate::stats::median;
use crate::table::{fixed as f, Table};

table!(
    Figures,
    "jbu",
    "JBU (Callahan & Silva) Fig. 3/4 and Fig. 5: time and RMSE per rendered resolution, upsampled to the full size",
    "Joint bilateral upsampling on the paper's protocol (14 cube views; 128², 256², 512² upsampled to 1024²): time per rendering resolution (JBU Fig. 3/4) and mean and worst RMSE of bilateral against linear upsampling (Fig. 5), for every renderer of the projected-tetrahedra and ray-casting families (GPU renderers on a real GPU), each against its own full-size image.",
    jbu_exp,
    jbu_build,
    jbu_plots
);

/// The upsampling methods every low size is filtered with, each with its default parameters.
pub const METHODS: [Method; 4] = [
    Method::Nearest,
    Method::Linear,
    Method::Bilateral,
    Method::Gauss,
];

/// Full size, low sizes and the cube views used (indices into `cube_views()`).
fn protocol(quick: bool) -> (u32, [u32; 3], Vec<usize>) {
    if quick {
        (512, [64, 128, 256], vec![0, 8])
    } else {
        (1024, [128, 256, 512], (0..14).collect())
    }
}

/// The renderers: the papers' two families, the exact reference left out, GPU renderers only
/// on a real GPU; with the note on those left out.
fn renderers() -> (Vec<&'static str>, Option<String>) {
    let mut fam = render::family(Family::RayCasting);
    fam.extend(render::family(Family::Pt));
    let fam: Vec<&render::RendererInfo> =
        fam.into_iter().filter(|r| r.name != "reference").collect();
    let gpu: Vec<&str> = fam.iter().filter(|r| r.needs_gpu).map(|r| r.name).collect();
    let real_gpu = match algorithms::gpu::Gpu::shared() {
        Ok(g) if g.info.device_type != algorithms::gpu::wgpu::DeviceType::Cpu => Ok(()),
        Ok(g) => Err(format!(
            "the adapter is a software rasteriser ({})",
            g.info.name
        )),
        Err(e) => Err(format!("no GPU adapter ({e})")),
    };
    let note = match (&real_gpu, gpu.is_empty()) {
        (Err(why), false) => Some(format!(
            "GPU renderers ({}) left out: {why}",
            gpu.join(", ")
        )),
        _ => None,
    };
    let names = fam
        .iter()
        .filter(|r| !r.needs_gpu || real_gpu.is_ok())
        .map(|r| r.name)
        .collect();
    (names, note)
}

fn jbu_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let (full, lows, views) = protocol(ctx.quick);
    let mut c = base_config(ctx, "jbu");
    c.datasets = if ctx.quick {
        // blunt as the other quick tables have it: its analogue at 40K tets.
        vec![
            dataset(ctx, "spx", None),
            dataset(ctx, "blunt", Some(40_000)),
        ]
    } else {
        vec![
            dataset(ctx, "spx", None),
            dataset(ctx, "blunt", None),
            dataset(ctx, "spx2", None),
            DatasetSpec {
                mesh: "fighter".into(),
                tets: Some(240_000),
                label: Some("fighter:240000".into()),
                ..Default::default()
            },
            dataset(ctx, "post", None),
            dataset(ctx, "comb", None),
        ]
    };
    for r in renderers().0 {
        let own = |name: String| RendererSpec {
            name,
            reference: Some(r.to_string()),
            ..Default::default()
        };
        c.renderers.push(own(r.to_string()));
        for low in lows {
            for m in METHODS {
                c.renderers
                    .push(own(format!("jbu:{r}@{low},method={}", m.name())));
            }
        }
    }
    c.sizes = Some(vec![format!("{full}x{full}")]);
    let cube = cube_views();
    c.views = ViewsSpec {
        named: views
            .iter()
            .map(|&i| format!("{},{}", cube[i].azimuth, cube[i].elevation))
            .collect(),
        ..Default::default()
    };
    c.repeats = Some(1);
    // A full run throws one frame away per view and variant; a quick one, a smoke run, does not.
    c.warmup = Some(if ctx.quick { 0 } else { 1 });
    Ok(c)
}

/// One measured row, read as the protocol sees it.
struct Frame<'a> {
    row: &'a Row,
    /// The renderer upsampled (or measured at full size).
    inner: String,
    /// The rendered resolution (the full size for a full-size frame).
    res: u32,
    /// `None` for the full-size frame.
    method: Option<Method>,
    /// Index into `cube_views()`.
    view: usize,
}

fn frames(o: &Outcome) -> Vec<Frame<'_>> {
    let cube = cube_views();
    o.rows
        .iter()
        .filter_map(|r| {
            let view = cube
                .iter()
                .position(|v| *v == View::new(r.azimuth, r.elevation))
                .unwrap_or(usize::MAX);
            let (inner, res, method) = match render::jbu::Spec::parse(&r.renderer) {
                Ok(s) => {
                    let res = match s.low {
                        LowSize::Long(n) | LowSize::Exact(n, _) => n,
                    };
                    (s.inner, res, Some(s.params.method))
                }
                Err(_) if render::is_wrapper(&r.renderer) => return None,
                Err(_) => (r.renderer.clone(), r.width, None),
            };
            Some(Frame {
                row: r,
                inner,
                res,
                method,
                view,
            })
        })
        .collect()
}

/// One (dataset, renderer, low resolution) over its views.
struct JbuCell {
    dataset: String,
    renderer: String,
    res: u32,
    tets: usize,
    views: usize,
    /// (mean, worst) RMSE over the views, per method of [`METHODS`].
    rmse: [(f64, f64); 4],
    /// Views (cube indices) where bilateral's RMSE exceeds linear's.
    losing: Vec<usize>,
    /// Medians over the views (bilateral): frame time, its stages, the full-size time,
    /// speed-up.
    time_ms: f64,
    low_ms: f64,
    depth_ms: f64,
    filter_ms: f64,
    full_ms: f64,
    speedup: f64,
    /// Why it has no measured view, when every one failed.
    failed: Option<String>,
    /// Whether every full-size frame of its renderer failed (no time to beat).
    full_failed: bool,
}

fn mean_worst(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    (
        v.iter().sum::<f64>() / v.len() as f64,
        v.iter().cloned().fold(f64::MIN, f64::max),
    )
}

fn method_index(m: Method) -> usize {
    METHODS.iter().position(|x| *x == m).unwrap_or(0)
}

/// The cells of a run, whatever order its rows came in (a merge of shards): by dataset in the
/// order of `datasets` (others after them), renderer in the order of [`renderers`], resolution
/// ascending.
fn jbu_cells(o: &Outcome, datasets: &[String]) -> Vec<JbuCell> {
    let fr = frames(o);
    let mut keys: Vec<(String, String, u32)> = Vec::new();
    for x in fr.iter().filter(|x| x.method.is_some()) {
        let k = (x.row.dataset.clone(), x.inner.clone(), x.res);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let rs = renderers().0;
    keys.sort_by_key(|k| {
        (
            datasets
                .iter()
                .position(|d| *d == k.0)
                .unwrap_or(usize::MAX),
            rs.iter().position(|r| *r == k.1).unwrap_or(usize::MAX),
            k.1.clone(),
            k.2,
        )
    });
    keys.into_iter()
        .map(|(ds, rn, res)| {
            let mine: Vec<&Frame> = fr
                .iter()
                .filter(|x| x.row.dataset == ds && x.inner == rn)
                .collect();
            let ok = |x: &&&Frame| x.row.total_ms.is_finite();
            let full: Vec<&&Frame> = mine
                .iter()
                .filter(|x| x.method.is_none())
                .filter(ok)
                .collect();
            let of = |m: Method| -> Vec<&&Frame> {
                let mut v: Vec<&&Frame> = mine
                    .iter()
                    .filter(|x| x.res == res && x.method == Some(m))
                    .filter(ok)
                    .collect();
                v.sort_by_key(|x| x.view);
                v
            };
            let rmse =
                |v: &[&&Frame]| -> Vec<f64> { v.iter().filter_map(|x| x.row.rmse).collect() };
            let (b, l) = (of(Method::Bilateral), of(Method::Linear));
            let losing = b
                .iter()
                .filter(|x| {
                    l.iter().any(|y| {
                        y.view == x.view && x.row.rmse.unwrap_or(0.0) > y.row.rmse.unwrap_or(0.0)
                    })
                })
                .map(|x| x.view)
                .collect();
            let full_of = |view: usize| {
                full.iter()
                    .find(|x| x.view == view)
                    .map_or(f64::NAN, |x| x.row.total_ms)
            };
            let med =
                |g: &dyn Fn(&Frame) -> f64| median(&b.iter().map(|x| g(x)).collect::<Vec<_>>());
            let counter = |n: &'static str| move |x: &Frame| x.row.counter(n).unwrap_or(f64::NAN);
            let failed = b.is_empty().then(|| {
                failure(o, |r| {
                    r.dataset == ds && r.renderer.starts_with(&format!("jbu:{rn}@{res},"))
                })
                .or_else(|| failure(o, |r| r.dataset == ds && r.renderer == rn))
                .unwrap_or_else(|| "— (not measured)".into())
            });
            JbuCell {
                tets: mine.first().map_or(0, |x| x.row.tets),
                views: b.len(),
                rmse: METHODS.map(|m| mean_worst(&rmse(&of(m)))),
                losing,
                time_ms: med(&|x| x.row.total_ms),
                low_ms: med(&counter("low_ms")),
                depth_ms: med(&counter("depth_ms")),
                filter_ms: med(&counter("filter_ms")),
                full_ms: med(&|x| full_of(x.view)),
                speedup: med(&|x| full_of(x.view) / x.row.total_ms.max(1e-9)),
                failed,
                full_failed: full.is_empty() && mine.iter().any(|x| x.method.is_none()),
                dataset: ds,
                renderer: rn,
                res,
            }
        })
        .collect()
}

/// The paper's Table 1 (tets, where it gives them) for the datasets it shares with ours.
fn paper_tets(ds: &str) -> &'static str {
    match ds.split(':').next().unwrap_or("") {
        "spx" => "13 K (SPX)",
        "blunt" | "blunt-like" => "187 K (Blunt Fin)",
        "spx2" => "828 K (SPX2)",
        "fighter" => "240 K (F117)",
        _ => "–",
    }
}

fn jbu_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let (full, lows, views) = protocol(ctx.quick);
    let names: Vec<String> = cfg.datasets.iter().map(DatasetSpec::display_name).collect();
    let cs = jbu_cells(o, &names);
    let mut t = Table::default();
    for (c, hw) in [
        ("renderer", false),
        ("dataset", false),
        ("tets", false),
        ("paper tets", false),
        ("rendered", false),
        ("time ms", true),
        ("full-size ms", true),
        ("speed-up", true),
        ("paper speed-up 128²→1024²", false),
        ("render ms", true),
        ("depth + filter ms", true),
        ("bilateral RMSE mean", false),
        ("linear mean", false),
        ("bilateral worst", false),
        ("linear worst", false),
        ("nearest mean", false),
        ("gauss mean", false),
        ("views bilateral ≤ linear", false),
        ("views losing", false),
    ] {
        t.col(c, hw);
    }
    let (bi, li, ni, gi) = (
        method_index(Method::Bilateral),
        method_index(Method::Linear),
        method_index(Method::Nearest),
        method_index(Method::Gauss),
    );
    for c in &cs {
        let mut row = vec![
            c.renderer.clone(),
            c.dataset.clone(),
            c.tets.to_string(),
            paper_tets(&c.dataset).into(),
            format!("{}² → {full}²", c.res),
        ];
        if let Some(why) = &c.failed {
            row.push(why.clone());
            row.extend(std::iter::repeat_n(
                "—".to_string(),
                t.columns.len() - row.len(),
            ));
            t.rows.push(row);
            continue;
        }
        row.extend([
            f(c.time_ms, 0),
            if c.full_failed {
                "failed".into()
            } else {
                f(c.full_ms, 0)
            },
            match (c.full_failed, c.speedup.is_finite()) {
                (true, _) => "failed".into(),
                (false, true) => format!("{:.1}×", c.speedup),
                (false, false) => "—".into(),
            },
            if c.renderer == "raycast" {
                "16–28× (software RC)".into()
            } else {
                "7–12× (hardware RC)".into()
            },
            f(c.low_ms, 0),
            format!("{} + {}", f(c.depth_ms, 0), f(c.filter_ms, 0)),
            {
                let b = f(c.rmse[bi].0, 5);
                if c.rmse[bi].0 < c.rmse[li].0 {
                    format!("**{b}**")
                } else {
                    b
                }
            },
            f(c.rmse[li].0, 5),
            f(c.rmse[bi].1, 5),
            f(c.rmse[li].1, 5),
            f(c.rmse[ni].0, 5),
            f(c.rmse[gi].0, 5),
            format!("{}/{}", c.views - c.losing.len(), c.views),
            if c.losing.is_empty() {
                "–".into()
            } else {
                c.losing
                    .iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            },
        ]);
        t.rows.push(row);
    }
    let threads = o.rows.first().map_or(0, |r| r.threads);
    let p = Params::default();
    t.notes.push(format!(
        "Protocol as the paper's §5: each dataset rendered from {} of the 14 cube views (the 8 corners and 6 faces of a cube around it; `views losing` gives their indices, 0–7 corners, 8–13 faces) at {full}² and at {} upsampled to {full}²; RMSE (CONVENTIONS §6, premultiplied linear RGBA) against the same renderer's {full}² image from the same view. Times are medians over the views on {threads} threads, {} measured frame(s) after {} warm-up frame(s); `time` = low-res render + depth layers + filter, the `jbu:` wrapper's frame; `speed-up` = the full-size time over it, per view.",
        views.len(),
        lows.map(|l| format!("{l}²")).join(", "),
        cfg.repeats.unwrap_or(1),
        cfg.warmup.unwrap_or(0),
    ));
    t.notes.push(format!(
        "Methods: `bilateral` (default: bilinear tent × range term on the extrapolated boundary-depth guide, k = {}, σ_r = {} of the depth normalisation), `linear` (bilinear), `nearest`, `gauss` (the earlier Gaussian-window filter); **bold**: bilateral's mean RMSE below linear's.",
        p.k, p.sigma_r
    ));
    if let Some(n) = renderers().1 {
        t.notes.push(format!("{n}."));
    }
    let analogues: Vec<String> = cfg
        .datasets
        .iter()
        .filter(|d| d.mesh.contains("-like"))
        .map(|d| {
            format!(
                "{} for {}",
                mesh_used(cfg, d.label.as_deref().unwrap_or("")),
                d.display_name()
            )
        })
        .collect();
    if !analogues.is_empty() {
        t.notes.push(format!(
            "Not the NASA grids: their datasets-gen analogues ({}), because {}.",
            analogues.join(", "),
            if ctx.quick {
                "a quick run must stay short"
            } else {
                "the grid files were not found ($TETBENCH_DATA, or shared/datasets beside the checkout)"
            }
        ));
    }
    t.notes.push("Paper, Fig. 3/4: software ray caster (Fig. 3) 16–28× from 128² to 1024²; hardware ray caster (Fig. 4) 7–12×. Ours: `raycast` is the software ray caster; the projected-tetrahedra renderers (and the GPU renderers where a real GPU is present) stand in for Fig. 4.".into());
    t.notes.push("Paper, Fig. 5: \"In all cases, our upsampling exhibits less error than with linear interpolation alone.\"".into());
    // The checks.
    let measured: Vec<&JbuCell> = cs.iter().filter(|c| c.failed.is_none()).collect();
    let wins = measured
        .iter()
        .filter(|c| c.rmse[bi].0 < c.rmse[li].0)
        .count();
    let nviews: usize = measured.iter().map(|c| c.views).sum();
    let lose: usize = measured.iter().map(|c| c.losing.len()).sum();
    t.notes.push(format!(
        "Check: bilateral's mean RMSE below linear's in {wins} of {} cells; bilateral ≤ linear in {} of {nviews} views ({:.1} %).",
        measured.len(),
        nviews - lose,
        100.0 * (nviews - lose) as f64 / nviews.max(1) as f64
    ));
    let lo = lows[0];
    for c in measured
        .iter()
        .filter(|c| c.renderer == "raycast" && c.res == lo)
    {
        t.notes.push(format!(
            "Check: raycast {} ({} tets): {lo}²→{full}² speed-up {:.1}×{}; depth + filter {:.0} ms against the {lo}² render's {:.0} ms.",
            c.dataset,
            c.tets,
            c.speedup,
            match (c.tets >= 187_000, c.speedup >= 16.0) {
                (true, true) => " (≥ 16×)",
                (true, false) => " (below 16×)",
                _ => "",
            },
            c.depth_ms + c.filter_ms,
            c.low_ms
        ));
    }
    t
}

fn file_part(renderer: &str) -> String {
    renderer.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_")
}

/// `jbu_time_<renderer>` (median frame time per rendered resolution, bilateral, and the
/// full-size frame; Fig. 3/4) and `jbu_rmse_<renderer>` (mean RMSE per resolution, one line per
/// dataset and method; Fig. 5), PNG and SVG.
fn jbu_plots(o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut names: Vec<String> = Vec::new();
    for r in &o.rows {
        if !names.contains(&r.dataset) {
            names.push(r.dataset.clone());
        }
    }
    let cs = jbu_cells(o, &names);
    let full = o.rows.first().map_or(0, |r| r.width);
    let mut renderers: Vec<&str> = Vec::new();
    let mut datasets: Vec<&str> = Vec::new();
    for c in &cs {
        if !renderers.contains(&c.renderer.as_str()) {
            renderers.push(&c.renderer);
        }
        if !datasets.contains(&c.dataset.as_str()) {
            datasets.push(&c.dataset);
        }
    }
    let mut out = Vec::new();
    for rname in renderers {
        let file = file_part(rname);
        let mine: Vec<&JbuCell> = cs
            .iter()
            .filter(|c| c.renderer == rname && c.failed.is_none())
            .collect();
        let mut time = Vec::new();
        let mut rmse = Vec::new();
        for ds in &datasets {
            let of: Vec<&&JbuCell> = mine.iter().filter(|c| c.dataset == *ds).collect();
            let Some(first) = of.first() else { continue };
            let mut t: Vec<(f64, f64)> = of.iter().map(|c| (c.res as f64, c.time_ms)).collect();
            t.push((full as f64, first.full_ms));
            time.push((ds.to_string(), t));
            for m in [Method::Bilateral, Method::Linear, Method::Nearest] {
                let i = method_index(m);
                let p: Vec<(f64, f64)> = of.iter().map(|c| (c.res as f64, c.rmse[i].0)).collect();
                rmse.push((format!("{ds} {}", m.name()), p));
            }
        }
        if time.is_empty() {
            continue;
        }
        let n = mine.first().map_or(0, |c| c.views);
        out.extend(crate::plots::lines_loglog(
            time,
            &dir.join(format!("jbu_time_{file}")),
            &format!("{rname}: median frame time, {n} views, to {full}² (JBU Fig. 3/4)"),
            "rendered resolution (pixels per side; the largest is the full-size render)",
            "time per frame (ms)",
        )?);
        out.extend(crate::plots::lines_loglog(
            rmse,
            &dir.join(format!("jbu_rmse_{file}")),
            &format!(
                "{rname}: mean RMSE over {n} views against the full {full}² image (JBU Fig. 5)"
            ),
            "rendered resolution (pixels per side)",
            "RMSE (linear premultiplied RGBA, 0..1)",
        )?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::papers::Sweep;

    /// A quick run's rows for one dataset: `raycast` at 512² and its wrappers, two views.
    fn rows() -> Vec<Row> {
        let cube = cube_views();
        let mut v = Vec::new();
        for (k, &view) in [cube[0], cube[8]].iter().enumerate() {
            let row = |renderer: String, total_ms: f64, rmse: f64, counters: &str| Row {
                dataset: "spx".into(),
                tets: 13000,
                renderer: renderer.clone(),
                variant: format!("{renderer}/partial"),
                width: 512,
                height: 512,
                view_id: format!("named:{k}"),
                azimuth: view.azimuth,
                elevation: view.elevation,
                total_ms,
                rmse: Some(rmse),
                counters: counters.into(),
                ..Default::default()
            };
            v.push(row("raycast".into(), 100.0 + k as f64, 0.0, ""));
            for (i, low) in [64, 128, 256].into_iter().enumerate() {
                for m in METHODS {
                    // Bilateral loses to linear at 256² in the second view only.
                    let rmse = match (m, i, k) {
                        (Method::Bilateral, 2, 1) => 0.03,
                        (Method::Bilateral, _, _) => 0.01,
                        (Method::Linear, _, _) => 0.02,
                        _ => 0.05,
                    };
                    v.push(row(
                        format!("jbu:raycast@{low},method={}", m.name()),
                        10.0 * (i + 1) as f64,
                        rmse,
                        "low_ms=4;depth_ms=1;filter_ms=5",
                    ));
                }
            }
        }
        v
    }

    /// The table is the same whatever order its rows come in (a merge of shards), and its
    /// cells hold the medians, means and worst views of the rows.
    #[test]
    fn the_table_does_not_depend_on_row_order() {
        let ctx = Ctx {
            quick: true,
            out: std::env::temp_dir(),
            sweep: Sweep::Whole,
            resume: false,
            failed: Default::default(),
        };
        let cfg = Config {
            datasets: vec![DatasetSpec {
                mesh: "spx".into(),
                label: Some("spx".into()),
                ..Default::default()
            }],
            repeats: Some(1),
            warmup: Some(0),
            ..Default::default()
        };
        let forward = Outcome {
            rows: rows(),
            ..Default::default()
        };
        let mut reversed = rows();
        reversed.reverse();
        let backward = Outcome {
            rows: reversed,
            ..Default::default()
        };
        let (a, b) = (
            jbu_build(&ctx, &cfg, &forward),
            jbu_build(&ctx, &cfg, &backward),
        );
        assert_eq!(a.rows, b.rows);
        assert_eq!(a.rows.len(), 3);
        let col = |name: &str| a.columns.iter().position(|c| c == name).unwrap();
        let first = &a.rows[0];
        assert_eq!(first[col("rendered")], "64² → 512²");
        assert_eq!(first[col("time ms")], "10");
        assert_eq!(first[col("full-size ms")], "100");
        // The median over the views of 100/10 and 101/10.
        assert_eq!(first[col("speed-up")], "10.1×");
        assert_eq!(first[col("bilateral RMSE mean")], "**0.01000**");
        let last = &a.rows[2];
        assert_eq!(last[col("bilateral worst")], "0.03000");
        assert_eq!(last[col("views bilateral ≤ linear")], "1/2");
        assert_eq!(last[col("views losing")], "8");
        assert_eq!(last[col("depth + filter ms")], "1 + 5");
    }
}
