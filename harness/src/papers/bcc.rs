//! The BCC paper: CC against BCC at equal information with projected tetrahedra (§4, Fig. 10)
//! and reconstruction schemes for ray casting a regular BCC volume (§3, Fig. 9).
//!
//! `bcc_pt`: the same analytic field sampled on `cc5`/`cc6` lattices of spacing h and on the
//! BCC lattice of primary spacing √2·h over [-1, 1]³ (29.3 % fewer samples per volume: lattice
//! datasets with `cells` and `field`), rendered by every projected-tetrahedra renderer that takes
//! the `bcc-implicit` traversal, with the same transfer function (range fixed to [0, 1], so both
//! lattices map scalars alike); errors against the analytic field ray-integrated over each mesh's
//! own domain (the yardstick `analytic`). Plus empty-space skipping (`bcc-implicit-skip`) on a
//! sparse transfer function, on the shell: time with and without, and whether the images are
//! the same (their content hashes).
//!
//! `bcc_reconstruction` ([`super::bcc_reconstruction`]) shares its lattices, fields and sizes.
//!
//! Fields: Marschner–Lobb (`f_M = 6`, `α = 0.25`) and a spherical shell (radius 0.6, width
//! 0.15), both with range [0, 1] ([`crate::meshes::FIELDS`]).

use std::path::{Path, PathBuf};

use algorithms::render::{self, Family};
use algorithms::tf::{TfPoint, TransferFunction};
use algorithms::Result;

use super::common::{base_config, failed_cells, failure};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::{Config, DatasetSpec, RendererSpec, TfSpec, ViewsSpec};
use crate::meshes::FIELDS;
use crate::plots::{self, TimeError};
use crate::rows::Row;
use crate::stats::{mean, median};
use crate::table::{fixed as fmt, sci, Table};

table!(
    Pt,
    "bcc_pt",
    "BCC paper §4 / Fig. 10: CC vs BCC at equal information with projected tetrahedra (bcc-implicit), and empty-space skipping",
    "CC against BCC sampling at equal information, rendered by projected tetrahedra with the implicit BCC order; error against a ground truth integrated from the analytic field.",
    pt_exp,
    pt_build,
    pt_plots
);

/// The lattice kinds, in table order.
const LATTICES: [&str; 3] = ["cc5", "cc6", "bcc"];

/// The study's sizes: CC cells per axis over [-1, 1]³, image, views, frames, and the ground
/// truth's step (world units).
pub(super) struct Sizes {
    pub cells: usize,
    pub image: u32,
    pub views: ViewsSpec,
    pub repeats: usize,
    pub gt_step: f64,
}

pub(super) fn sizes(quick: bool) -> Sizes {
    let cells = if quick { 16 } else { 40 };
    let h = 2.0 / cells as f64;
    Sizes {
        cells,
        image: if quick { 64 } else { 192 },
        views: if quick {
            ViewsSpec {
                named: vec!["30,20".into()],
                ..Default::default()
            }
        } else {
            ViewsSpec {
                fibonacci: 2,
                ..Default::default()
            }
        },
        repeats: if quick { 1 } else { 5 },
        gt_step: if quick { h / 6.0 } else { h / 10.0 },
    }
}

/// The `default` preset with its range fixed to [0, 1].
pub(super) fn dense_tf() -> TransferFunction {
    let mut t = TransferFunction::preset("default").expect("the default preset exists");
    t.range = Some([0.0, 1.0]);
    t
}

/// Transparent below s = 0.55: on the shell most of the box maps to τ = 0.
fn sparse_tf() -> TransferFunction {
    let pts = [
        (0.0, [0.0, 0.0, 0.0], 0.0),
        (0.55, [0.2, 0.4, 1.0], 0.0),
        (0.8, [1.0, 0.6, 0.1], 20.0),
        (1.0, [1.0, 1.0, 1.0], 30.0),
    ];
    TransferFunction {
        name: "sparse".into(),
        range: Some([0.0, 1.0]),
        points: pts
            .iter()
            .map(|&(s, rgb, tau)| TfPoint { s, rgb, tau })
            .collect(),
    }
}

/// The projected-tetrahedra renderers of the registry that take the lattice order
/// (`bcc-implicit` and `bcc-implicit-skip`), the table's subject: CPU ones first.
pub fn lattice_renderers() -> Vec<&'static str> {
    let mut v: Vec<&render::RendererInfo> = render::family(Family::Pt)
        .into_iter()
        .filter(|r| r.sorts.contains(&"bcc-implicit") && r.sorts.contains(&"bcc-implicit-skip"))
        .collect();
    v.sort_by_key(|r| r.needs_gpu);
    v.into_iter().map(|r| r.name).collect()
}

/// A lattice dataset's name: `<lattice> <field>`.
pub(super) fn label(lattice: &str, field: &str) -> String {
    format!("{lattice} {field}")
}

fn pt_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let sz = sizes(ctx.quick);
    let renderers = lattice_renderers();
    let Some(&base) = renderers.first() else {
        return Err("no renderer takes the sorts bcc-implicit and bcc-implicit-skip".into());
    };
    let mut c = base_config(ctx, "bcc_pt");
    for f in &FIELDS {
        for l in LATTICES {
            c.datasets.push(DatasetSpec {
                mesh: l.into(),
                cells: Some(sz.cells),
                field: Some(f.name.into()),
                truth_step: Some(sz.gt_step),
                label: Some(label(l, f.name)),
                ..Default::default()
            });
        }
    }
    let spec = |name: &str, sorts: &[&str]| RendererSpec {
        name: name.into(),
        sorts: Some(sorts.iter().map(|s| s.to_string()).collect()),
        integrators: Some(vec!["partial".into()]),
        reference: Some("analytic".into()),
        ..Default::default()
    };
    for r in &renderers {
        c.renderers.push(spec(r, &["bcc-implicit"]));
    }
    // Empty-space skipping: the first renderer, the sparse transfer function, on the shell.
    c.renderers.push(RendererSpec {
        tf: Some(TfSpec::inline(&sparse_tf())),
        datasets: Some(LATTICES.iter().map(|l| label(l, "shell")).collect()),
        ..spec(base, &["bcc-implicit", "bcc-implicit-skip"])
    });
    c.tf = Some(TfSpec::inline(&dense_tf()));
    c.sizes = Some(vec![format!("{0}x{0}", sz.image)]);
    c.views = sz.views;
    c.repeats = Some(sz.repeats);
    c.warmup = Some(1);
    c.interleave = Some(true);
    Ok(c)
}

/// The §6 errors of a (dataset, variant) over its views: mean RMSE (and the PSNR of it), mean
/// `diff_pixels_pct` and `avg_err_pct`, worst `max_abs` and `max_err_pct`.
pub(super) fn error_cells(rows: &[&Row]) -> Vec<String> {
    let col =
        |g: fn(&Row) -> Option<f64>| -> Vec<f64> { rows.iter().filter_map(|r| g(r)).collect() };
    let worst = |v: Vec<f64>| v.into_iter().fold(f64::NAN, f64::max);
    let rmse = mean(&col(|r| r.rmse));
    vec![
        sci(rmse, 3),
        fmt(20.0 * (1.0 / rmse).log10(), 2),
        fmt(worst(col(|r| r.max_abs)), 4),
        fmt(mean(&col(|r| r.diff_pixels_pct)), 2),
        fmt(worst(col(|r| r.max_err_pct)), 2),
        fmt(mean(&col(|r| r.avg_err_pct)), 2),
    ]
}

pub(super) const ERROR_COLUMNS: [&str; 6] = [
    "rmse",
    "psnr",
    "max_abs",
    "diff_pixels_pct",
    "max_err_pct",
    "avg_err_pct",
];

/// The measured rows of (dataset, variant), views in order.
fn of<'a>(o: &'a Outcome, dataset: &str, variant: &str) -> Vec<&'a Row> {
    o.rows
        .iter()
        .filter(|r| r.dataset == dataset && r.variant == variant && r.total_ms.is_finite())
        .collect()
}

/// The variants of a run (a row of each), in the table's order whatever order the rows came
/// in (a merge of shards): the dense transfer function first, then by renderer as
/// [`lattice_renderers`] lists them, then by sort.
fn variant_order(o: &Outcome) -> Vec<&Row> {
    let mut v: Vec<&Row> = Vec::new();
    for r in &o.rows {
        if !v.iter().any(|x| x.variant == r.variant) {
            v.push(r);
        }
    }
    let renderers = lattice_renderers();
    v.sort_by_key(|r| {
        let who = renderers.iter().position(|n| *n == r.renderer);
        (r.tf != "default", who, r.sort.clone(), r.variant.clone())
    });
    v
}

fn pt_build(ctx: &Ctx, _cfg: &Config, o: &Outcome) -> Table {
    let sz = sizes(ctx.quick);
    let renderers = lattice_renderers();
    let base = renderers.first().copied().unwrap_or_default();
    let mut t = Table::default();
    for (c, hw) in [
        ("lattice", false),
        ("field", false),
        ("renderer", false),
        ("tf", false),
        ("sort", false),
        ("samples", false),
        ("tets", false),
        ("visible_tets_pct", false),
        ("time_ms", true),
        ("sort_ms", true),
        ("draw_ms", true),
        ("tets_per_s", true),
        ("bytes_per_tet", false),
    ]
    .into_iter()
    .chain(ERROR_COLUMNS.map(|c| (c, false)))
    {
        t.col(c, hw);
    }
    // (lattice, field, time, rmse) of the base renderer with the dense TF, for the summary.
    let mut summary: Vec<(&str, &str, f64, f64)> = Vec::new();
    let mut skip_notes = Vec::new();
    let variants = variant_order(o);
    for f in &FIELDS {
        for l in LATTICES {
            let ds = label(l, f.name);
            let mut noskip: Option<(Vec<&Row>, f64)> = None;
            for v in &variants {
                let mine: Vec<&Row> = o
                    .rows
                    .iter()
                    .filter(|r| r.dataset == ds && r.variant == v.variant)
                    .collect();
                let Some(first) = mine.first() else { continue };
                let mut row = vec![
                    l.to_string(),
                    f.name.to_string(),
                    first.renderer.clone(),
                    first.tf.clone(),
                    first.sort.clone(),
                    first.vertices.to_string(),
                    first.tets.to_string(),
                ];
                let ok = of(o, &ds, &v.variant);
                if ok.is_empty() {
                    let why = failure(o, |r| r.dataset == ds && r.variant == v.variant)
                        .unwrap_or_else(|| "—".into());
                    row.extend(failed_cells(why, t.columns.len() - row.len()));
                    t.rows.push(row);
                    continue;
                }
                let ntets = first.tets as f64;
                let skipped = mean(
                    &ok.iter()
                        .map(|r| r.counter("tets_skipped").unwrap_or(0.0))
                        .collect::<Vec<_>>(),
                );
                let med = |g: fn(&Row) -> f64| median(&ok.iter().map(|r| g(r)).collect::<Vec<_>>());
                let time = med(|r| r.total_ms);
                let visible = 100.0 * (ntets - skipped) / ntets;
                row.extend([
                    fmt(visible, 1),
                    fmt(time, 2),
                    fmt(med(|r| r.sort_ms), 2),
                    fmt(med(|r| r.draw_ms), 2),
                    sci(ntets / (time / 1e3), 3),
                    fmt(first.cpu_bytes_per_tet, 1),
                ]);
                row.extend(error_cells(&ok));
                t.rows.push(row);
                let rmse = mean(&ok.iter().filter_map(|r| r.rmse).collect::<Vec<_>>());
                if first.tf == "default" && first.renderer == base {
                    summary.push((l, f.name, time, rmse));
                }
                if first.tf == "sparse" {
                    // Per lattice: the run without skipping comes first, then the one with.
                    match noskip.take() {
                        None => noskip = Some((ok.clone(), time)),
                        Some((before, t0)) => {
                            let same = before.len() == ok.len()
                                && before
                                    .iter()
                                    .zip(&ok)
                                    .all(|(a, b)| a.image_hash == b.image_hash);
                            skip_notes.push(format!(
                                "Empty-space skipping on {l} (shell, sparse TF, {visible:.1} % of the tets visible): {t0:.2} ms without, {time:.2} ms with ({:.2}x); images {}.",
                                t0 / time,
                                if same { "identical (every f32 pixel)" } else { "DIFFERENT" }
                            ));
                        }
                    }
                }
            }
        }
    }
    let bcc_n = crate::meshes::LatticeSpec::new("bcc", sz.cells, &FIELDS[0], sz.gt_step)
        .map(|l| l.bcc_points())
        .unwrap_or(0);
    t.notes.push(format!(
        "Equal information: CC lattices of {c}³ cells (h = 2/{c}) and a BCC lattice of {n}³ primary points (h = 2/{m} ≈ √2·2/{c}) over [-1, 1]³. Samples = mesh vertices (the BCC secondary grid reaches half a cell beyond the box, so its count is above 70.7 % of CC's).",
        c = sz.cells,
        n = bcc_n,
        m = bcc_n.saturating_sub(1)
    ));
    t.notes.push(format!(
        "{}, integrator partial, sort bcc-implicit (the lattice traversal, for CC and BCC alike), {}² orthographic, {}, median of {} frame(s) after a warm-up, the variants of one lattice rendered in turn (interleaved, so that load from other processes falls on all alike); bytes_per_tet = heap bytes the renderer's prepare retains (counting allocator) / tets.",
        renderers.join(" and "),
        sz.image,
        views_note(o),
        sz.repeats
    ));
    t.notes.push(format!(
        "Errors: mean over views against a ground truth that ray-integrates the analytic field (not a mesh) over each mesh's own domain (box for CC, the octahedra for BCC) and with its own L, step {:.4} (h_cc/{}), `exact` integrator; max_abs and max_err_pct are maxima over views.",
        sz.gt_step,
        (2.0 / sz.cells as f64 / sz.gt_step).round()
    ));
    t.notes.push("Paper (§5, Fig. 10, timings as a chart only): \"For all tested datasets, the algorithm performs better on the BCC grid volume\"; BCC vs CC quality \"no major difference\" on Fuel.".into());
    for f in &FIELDS {
        let get = |l: &str| {
            summary
                .iter()
                .find(|s| s.0 == l && s.1 == f.name)
                .map(|s| (s.2, s.3))
        };
        if let (Some(b), Some(c5), Some(c6)) = (get("bcc"), get("cc5"), get("cc6")) {
            t.notes.push(format!(
                "{}: BCC {:.2} ms, rmse {:.3e}; cc5 {:.2} ms, rmse {:.3e}; cc6 {:.2} ms, rmse {:.3e} → BCC is {} in time than cc5 and {} in error than the better CC.",
                f.name, b.0, b.1, c5.0, c5.1, c6.0, c6.1,
                if b.0 < c5.0 { "faster" } else { "slower" },
                if b.1 < c5.1.min(c6.1) { "lower" } else { "higher" }
            ));
        }
    }
    t.notes.extend(skip_notes);
    t
}

/// `N view(s) (az, el) ...` of a run's rows.
pub(super) fn views_note(o: &Outcome) -> String {
    let mut v: Vec<(f64, f64)> = Vec::new();
    for r in &o.rows {
        if !v.contains(&(r.azimuth, r.elevation)) {
            v.push((r.azimuth, r.elevation));
        }
    }
    let list: Vec<String> = v.iter().map(|(a, e)| format!("({a:.0}, {e:.0})")).collect();
    format!("{} view(s) {}", v.len(), list.join(" "))
}

/// Time against error of the dense-TF rows (`bcc_pt-time_vs_error`), one point per lattice,
/// field and renderer.
fn pt_plots(o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut renderers: Vec<&str> = Vec::new();
    for r in o.rows.iter().filter(|r| r.tf == "default") {
        if !renderers.contains(&r.renderer.as_str()) {
            renderers.push(&r.renderer);
        }
    }
    let mut pts = Vec::new();
    for f in &FIELDS {
        for l in LATTICES {
            let ds = label(l, f.name);
            for v in variant_order(o).iter().filter(|v| v.tf == "default") {
                let ok = of(o, &ds, &v.variant);
                if ok.is_empty() {
                    continue;
                }
                let who = if Some(&v.renderer.as_str()) == renderers.first() {
                    String::new()
                } else {
                    format!(" {}", v.renderer)
                };
                pts.push(TimeError {
                    label: format!("{l} {}{who}", f.name),
                    rmse: mean(&ok.iter().filter_map(|r| r.rmse).collect::<Vec<_>>()),
                    time_ms: median(&ok.iter().map(|r| r.total_ms).collect::<Vec<_>>()),
                });
            }
        }
    }
    if pts.is_empty() {
        return Ok(Vec::new());
    }
    plots::time_vs_error(
        &pts,
        &dir.join("bcc_pt-time_vs_error"),
        &format!(
            "CC vs BCC at equal information: {} time against error",
            renderers.join(", ")
        ),
    )
}
