//! The JBU experiment's summaries: per cell (dataset, renderer, resolution) the mean and worst
//! view of each method's RMSE and the median times, printed, plotted (Fig. 3/4, Fig. 5) and
//! written as `jbu.md`, laid out like the paper's figures with the paper's statements beside ours.

use std::fmt::Write as _;
use std::path::Path;

use algorithms::Result;

use super::{Plan, Row};
use crate::stats::median;

/// One cell's summary.
#[derive(Clone, Debug)]
pub struct Cell {
    pub dataset: String,
    pub tets: usize,
    pub renderer: String,
    pub low_res: u32,
    pub views: usize,
    /// (mean, worst) RMSE over the views, per method.
    pub bilateral: (f64, f64),
    pub linear: (f64, f64),
    pub nearest: (f64, f64),
    pub gauss: (f64, f64),
    /// Views where bilateral's RMSE exceeds linear's.
    pub losing: Vec<usize>,
    /// Medians over the views (bilateral): frame time, its stages, the full-size time, speed-up.
    pub time_ms: f64,
    pub low_ms: f64,
    pub depth_ms: f64,
    pub filter_ms: f64,
    pub full_ms: f64,
    pub speedup: f64,
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

/// The cells of `rows`, in the order they first appear, resolutions ascending.
pub fn cells(rows: &[Row]) -> Vec<Cell> {
    let mut keys: Vec<(String, String, u32)> = Vec::new();
    for r in rows.iter().filter(|r| r.method != "full") {
        let k = (r.dataset.clone(), r.renderer.clone(), r.low_res);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let order = keys.clone();
    keys.sort_by_key(|k| {
        let first = order
            .iter()
            .position(|o| o.0 == k.0 && o.1 == k.1)
            .unwrap_or(0);
        (first, k.2)
    });
    keys.into_iter()
        .map(|(ds, rn, low)| {
            let of = |m: &str| -> Vec<&Row> {
                let mut v: Vec<&Row> = rows
                    .iter()
                    .filter(|r| r.dataset == ds && r.renderer == rn && r.low_res == low)
                    .filter(|r| r.method == m)
                    .collect();
                v.sort_by_key(|r| r.view);
                v
            };
            let rm = |v: &[&Row]| v.iter().map(|r| r.rmse).collect::<Vec<_>>();
            let (b, l) = (of("bilateral"), of("linear"));
            let losing = b
                .iter()
                .filter(|br| l.iter().any(|lr| lr.view == br.view && br.rmse > lr.rmse))
                .map(|r| r.view)
                .collect();
            let med = |f: fn(&Row) -> f64| median(&b.iter().map(|r| f(r)).collect::<Vec<_>>());
            Cell {
                tets: b.first().map_or(0, |r| r.tets),
                views: b.len(),
                bilateral: mean_worst(&rm(&b)),
                linear: mean_worst(&rm(&l)),
                nearest: mean_worst(&rm(&of("nearest"))),
                gauss: mean_worst(&rm(&of("gauss"))),
                losing,
                time_ms: med(|r| r.time_ms),
                low_ms: med(|r| r.low_ms),
                depth_ms: med(|r| r.depth_ms),
                filter_ms: med(|r| r.filter_ms),
                full_ms: med(|r| r.full_ms),
                speedup: med(|r| r.speedup),
                dataset: ds,
                renderer: rn,
                low_res: low,
            }
        })
        .collect()
}

/// Prints the cells of one (dataset, renderer) to stderr as they finish.
pub fn print_cells(rows: &[Row], ds: &str, renderer: &str) {
    for c in cells(rows)
        .iter()
        .filter(|c| c.dataset == ds && c.renderer == renderer)
    {
        eprintln!(
            "  {renderer} {}->{}: {:.0} ms ({:.1}x; depth {:.1} filter {:.1}), rmse mean bilateral {:.5} linear {:.5}, {} of {} views lose",
            c.low_res,
            rows.first().map_or(0, |r| r.full_res),
            c.time_ms,
            c.speedup,
            c.depth_ms,
            c.filter_ms,
            c.bilateral.0,
            c.linear.0,
            c.losing.len(),
            c.views
        );
    }
}

/// One CSV line per cell on stdout.
pub fn print_summary(rows: &[Row]) {
    println!("dataset,renderer,low_res,views,time_ms,speedup,rmse_bilateral_mean,rmse_linear_mean,rmse_bilateral_worst,rmse_linear_worst,views_losing,bilateral_beats_linear");
    for c in cells(rows) {
        println!(
            "{},{},{},{},{:.1},{:.2},{:.6},{:.6},{:.6},{:.6},{},{}",
            c.dataset,
            c.renderer,
            c.low_res,
            c.views,
            c.time_ms,
            c.speedup,
            c.bilateral.0,
            c.linear.0,
            c.bilateral.1,
            c.linear.1,
            c.losing.len(),
            c.bilateral.0 < c.linear.0
        );
    }
}

fn file_part(renderer: &str) -> String {
    renderer.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_")
}

/// The plots `DIR/jbu_time_<renderer>.{png,svg}` and `DIR/jbu_rmse_<renderer>.{png,svg}`
/// (plotters, like every other plot of the harness); points sorted by resolution.
pub fn write_plots(rows: &[Row], plan: &Plan, dir: &Path) -> Result<()> {
    let cs = cells(rows);
    for rname in &plan.renderers {
        let file = file_part(rname);
        let mine: Vec<&Cell> = cs.iter().filter(|c| &c.renderer == rname).collect();
        let mut time = Vec::new();
        let mut rmse = Vec::new();
        for ds in &plan.datasets {
            let of: Vec<&&Cell> = mine.iter().filter(|c| &c.dataset == ds).collect();
            if of.is_empty() {
                continue;
            }
            let mut t: Vec<(f64, f64)> = of.iter().map(|c| (c.low_res as f64, c.time_ms)).collect();
            t.push((plan.full as f64, of[0].full_ms));
            t.sort_by(|a, b| a.0.total_cmp(&b.0));
            time.push((ds.clone(), t));
            for (m, f) in [
                ("bilateral", (|c: &Cell| c.bilateral.0) as fn(&Cell) -> f64),
                ("linear", |c: &Cell| c.linear.0),
                ("nearest", |c: &Cell| c.nearest.0),
            ] {
                let mut p: Vec<(f64, f64)> = of.iter().map(|c| (c.low_res as f64, f(c))).collect();
                p.sort_by(|a, b| a.0.total_cmp(&b.0));
                rmse.push((format!("{ds} {m}"), p));
            }
        }
        if time.is_empty() {
            continue;
        }
        let n = mine.first().map_or(0, |c| c.views);
        let title = format!(
            "{rname}: median frame time, {n} views, to {0}² (JBU Fig. 3/4)",
            plan.full
        );
        let x = "rendered resolution (pixels per side; the largest is the full-size render)";
        crate::plots::lines_loglog(
            time,
            &dir.join(format!("jbu_time_{file}")),
            &title,
            x,
            "time per frame (ms)",
        )?;
        let title = format!(
            "{rname}: mean RMSE over {n} views against the full {0}² image (JBU Fig. 5)",
            plan.full
        );
        crate::plots::lines_loglog(
            rmse,
            &dir.join(format!("jbu_rmse_{file}")),
            &title,
            "rendered resolution (pixels per side)",
            "RMSE (linear premultiplied RGBA, 0..1)",
        )?;
    }
    Ok(())
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

/// `DIR/jbu.md`: the protocol, Fig. 3/4 and Fig. 5 as tables next to the paper's statements,
/// the done-when checks, and the views bilateral loses.
pub fn write_md(rows: &[Row], plan: &Plan, dir: &Path) -> Result<()> {
    let cs = cells(rows);
    let mut s = String::new();
    let full = plan.full;
    let lows: Vec<String> = plan.lows.iter().map(|l| format!("{l}²")).collect();
    let _ = writeln!(s, "# JBU: Callahan & Silva, Fig. 3–5 (`tetbench jbu`)\n");
    let _ = writeln!(
        s,
        "Protocol as the paper's §5: each dataset rendered from {} of the 14 cube views (the 8 corners and 6 faces of a cube around it; `view` 0–7 corners, 8–13 faces), at {full}² and at {} upsampled to {full}²; RMSE against the same renderer's {full}² image from the same view (CONVENTIONS §6, premultiplied linear RGBA). Times are the median over the views on {} threads; `time` = low-res render + depth layers + filter. Methods: `bilateral` (default: bilinear tent × range term on the extrapolated boundary-depth guide, k = 4, σ_r = 0.02 of the depth normalisation), `linear` (bilinear), `nearest`, `gauss` (the earlier Gaussian-window filter). Raw rows: [jbu.csv](jbu.csv), one per view and method.\n",
        plan.views.len(),
        lows.join(", "),
        rows.first().map_or(0, |r| r.threads)
    );
    for n in &plan.notes {
        let _ = writeln!(s, "- Note: {n}.");
    }
    if !plan.notes.is_empty() {
        s.push('\n');
    }
    // Datasets.
    let _ = writeln!(s, "## Datasets (paper's Table 1 beside ours)\n");
    let _ = writeln!(s, "| dataset | tets (ours) | paper |\n|---|---:|---|");
    for ds in &plan.datasets {
        if let Some(c) = cs.iter().find(|c| &c.dataset == ds) {
            let _ = writeln!(s, "| {ds} | {} | {} |", c.tets, paper_tets(ds));
        }
    }
    // Fig. 3/4.
    let _ = writeln!(
        s,
        "\n## Fig. 3/4: time per frame (ms) by rendered resolution, upsampled to {full}²\n"
    );
    let _ = writeln!(
        s,
        "Paper: software ray caster (Fig. 3) 16–28× from 128² to 1024²; hardware ray caster (Fig. 4) 7–12×. Ours: `raycast` is the software ray caster; cpu-pt (and the GPU renderers where a real GPU is present) stand in for Fig. 4.\n"
    );
    for rname in &plan.renderers {
        let mine: Vec<&Cell> = cs.iter().filter(|c| &c.renderer == rname).collect();
        if mine.is_empty() {
            continue;
        }
        let paper = if rname == "raycast" {
            "16–28×"
        } else {
            "7–12× (hardware RC)"
        };
        let _ = writeln!(
            s,
            "### {rname}\n\n![time](jbu_time_{}.png)\n",
            file_part(rname)
        );
        let mut hdr = format!("| dataset | {full}² (full) |");
        for l in &plan.lows {
            let _ = write!(hdr, " {l}² |");
        }
        let lo = plan.lows.first().copied().unwrap_or(0);
        let _ = writeln!(
            s,
            "{hdr} speed-up {lo}²→{full}² | depth + filter at {lo}² | paper |\n|---|{}",
            "---:|".repeat(plan.lows.len() + 4)
        );
        for ds in &plan.datasets {
            let of: Vec<&&Cell> = mine.iter().filter(|c| &c.dataset == ds).collect();
            let Some(first) = of.first() else { continue };
            let mut line = format!("| {ds} | {:.0} |", first.full_ms);
            for l in &plan.lows {
                match of.iter().find(|c| c.low_res == *l) {
                    Some(c) => {
                        let _ = write!(line, " {:.0} |", c.time_ms);
                    }
                    None => line.push_str(" – |"),
                }
            }
            let c0 = of.iter().find(|c| c.low_res == lo);
            let _ = writeln!(
                s,
                "{line} {} | {} | {paper} |",
                c0.map_or("–".into(), |c| format!("{:.1}×", c.speedup)),
                c0.map_or("–".into(), |c| format!(
                    "{:.0} + {:.0} ms (render {:.0} ms)",
                    c.depth_ms, c.filter_ms, c.low_ms
                ))
            );
        }
        s.push('\n');
    }
    // Fig. 5.
    let _ = writeln!(
        s,
        "## Fig. 5: RMSE against the full {full}² image, mean and worst of the views\n"
    );
    let _ = writeln!(
        s,
        "Paper: \"In all cases, our upsampling exhibits less error than with linear interpolation alone.\"\n"
    );
    for rname in &plan.renderers {
        let mine: Vec<&Cell> = cs.iter().filter(|c| &c.renderer == rname).collect();
        if mine.is_empty() {
            continue;
        }
        let _ = writeln!(
            s,
            "### {rname}\n\n![rmse](jbu_rmse_{}.png)\n",
            file_part(rname)
        );
        let _ = writeln!(s, "| dataset | res | bilateral mean | linear mean | bilateral worst | linear worst | nearest mean | gauss mean | views bilateral ≤ linear | views losing |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
        for c in &mine {
            let _ = writeln!(
                s,
                "| {} | {}² | {}{:.5}{} | {:.5} | {:.5} | {:.5} | {:.5} | {:.5} | {}/{} | {} |",
                c.dataset,
                c.low_res,
                if c.bilateral.0 < c.linear.0 { "**" } else { "" },
                c.bilateral.0,
                if c.bilateral.0 < c.linear.0 { "**" } else { "" },
                c.linear.0,
                c.bilateral.1,
                c.linear.1,
                c.nearest.0,
                c.gauss.0,
                c.views - c.losing.len(),
                c.views,
                if c.losing.is_empty() {
                    "–".to_string()
                } else {
                    c.losing
                        .iter()
                        .map(|v| v.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            );
        }
        s.push('\n');
    }
    // Done-when.
    let wins = cs.iter().filter(|c| c.bilateral.0 < c.linear.0).count();
    let views: usize = cs.iter().map(|c| c.views).sum();
    let lose: usize = cs.iter().map(|c| c.losing.len()).sum();
    let _ = writeln!(s, "## Checks (issue 14)\n");
    let _ = writeln!(
        s,
        "- Cells: {} ({} views each at most); bilateral's mean RMSE below linear's in {wins} of {}.",
        cs.len(),
        cs.iter().map(|c| c.views).max().unwrap_or(0),
        cs.len()
    );
    let _ = writeln!(
        s,
        "- Views: bilateral ≤ linear in {} of {views} ({:.1} %).",
        views - lose,
        100.0 * (views - lose) as f64 / views.max(1) as f64
    );
    let lo = plan.lows.first().copied().unwrap_or(0);
    for c in cs
        .iter()
        .filter(|c| c.renderer == "raycast" && c.low_res == lo)
    {
        let _ = writeln!(
            s,
            "- raycast {} ({} tets): {lo}²→{full}² speed-up {:.1}×{}; depth + filter {:.0} ms vs the {lo}² render {:.0} ms.",
            c.dataset,
            c.tets,
            c.speedup,
            if c.tets >= 187_000 {
                if c.speedup >= 16.0 { " (≥ 16×)" } else { " (below 16×)" }
            } else {
                ""
            },
            c.depth_ms + c.filter_ms,
            c.low_ms
        );
    }
    super::write_file(&dir.join("jbu.md"), s.as_bytes())
}
