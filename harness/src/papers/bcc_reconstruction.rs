//! The BCC paper's §3 / Fig. 9, `bcc_reconstruction`: the samples of [`super::bcc`]'s CC and BCC
//! lattices ray cast as regular volumes by `volume-raycast`, trilinear on CC and the four BCC
//! schemes (`bil`, `bilspat`, `bary`, `shtril`), one camera framing the box both sample
//! (`frame = "box"`); time per scheme and error against the analytic field ray-integrated over
//! that box (the yardstick `analytic-box`).

use std::path::{Path, PathBuf};

use algorithms::bcc::recon::Scheme;
use algorithms::Result;

use super::bcc::{dense_tf, error_cells, label, sizes, views_note, ERROR_COLUMNS};
use super::common::{base_config, failed_cells, failure};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::{Config, DatasetSpec, RendererSpec, TfSpec};
use crate::meshes::FIELDS;
use crate::plots::{self, TimeError};
use crate::rows::Row;
use crate::stats::{mean, median};
use crate::table::{fixed as fmt, Table};

table!(
    Reconstruction,
    "bcc_reconstruction",
    "BCC paper §3 / Fig. 9: ray casting with trilinear on CC and bil, bilspat, bary, shtril on BCC, time and error",
    "Reconstruction schemes for ray casting a regular BCC volume against trilinear on CC: time and error per scheme (BCC paper Fig. 9).",
    recon_exp,
    recon_build,
    recon_plots
);

/// A scheme's place in the paper's Fig. 9 timings (a chart only): bil fastest, then tril,
/// shtril ≈ bilspat, bary slowest.
fn fig9_rank(s: Scheme) -> &'static str {
    match s {
        Scheme::Bilinear => "1 (fastest)",
        Scheme::Trilinear => "2",
        Scheme::ShearedTrilinear | Scheme::BilinearSpatial => "3 (similar)",
        Scheme::Barycentric => "5 (slowest)",
    }
}

/// The ray caster's step, h_cc/2, as the `step` parameter writes it.
fn rc_step(cells: usize) -> String {
    (1.0 / cells as f64).to_string()
}

fn recon_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let sz = sizes(ctx.quick);
    let mut c = base_config(ctx, "bcc_reconstruction");
    for f in &FIELDS {
        for (l, mesh) in [("CC", "cc5"), ("BCC", "bcc")] {
            c.datasets.push(DatasetSpec {
                mesh: mesh.into(),
                cells: Some(sz.cells),
                field: Some(f.name.into()),
                truth_step: Some(sz.gt_step),
                label: Some(label(l, f.name)),
                // One camera for both lattices: the box they sample.
                frame: Some("box".into()),
                ..Default::default()
            });
        }
    }
    for s in Scheme::ALL {
        let params = [
            ("scheme", s.name().to_string()),
            ("step", rc_step(sz.cells)),
        ];
        c.renderers.push(RendererSpec {
            name: "volume-raycast".into(),
            integrators: Some(vec!["exact".into()]),
            params: params
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            datasets: Some(FIELDS.iter().map(|f| label(s.lattice(), f.name)).collect()),
            reference: Some("analytic-box".into()),
            ..Default::default()
        });
    }
    c.tf = Some(TfSpec::inline(&dense_tf()));
    c.sizes = Some(vec![format!("{0}x{0}", sz.image)]);
    c.views = sz.views;
    c.repeats = Some(sz.repeats);
    c.warmup = Some(0);
    Ok(c)
}

/// The scheme a `volume-raycast` row ran with (its `scheme` parameter, in the variant label).
fn scheme_of(r: &Row) -> Option<Scheme> {
    let params = r.variant.split_once('[')?.1.trim_end_matches(']');
    let name = params
        .split(',')
        .find_map(|kv| kv.strip_prefix("scheme="))?;
    Scheme::ALL.into_iter().find(|s| s.name() == name)
}

/// (scheme, field, its rows) for every scheme and field measured, in the table's order.
fn recon_groups(o: &Outcome) -> Vec<(Scheme, &'static str, Vec<&Row>)> {
    let mut out = Vec::new();
    for f in &FIELDS {
        for s in Scheme::ALL {
            let ds = label(s.lattice(), f.name);
            let rows: Vec<&Row> = o
                .rows
                .iter()
                .filter(|r| r.dataset == ds && scheme_of(r) == Some(s))
                .collect();
            if !rows.is_empty() {
                out.push((s, f.name, rows));
            }
        }
    }
    out
}

fn recon_build(ctx: &Ctx, _cfg: &Config, o: &Outcome) -> Table {
    let sz = sizes(ctx.quick);
    let mut t = Table::default();
    for (c, hw) in [
        ("scheme", false),
        ("lattice", false),
        ("field", false),
        ("samples", false),
        ("time_ms", true),
        ("paper_fig9_rank", false),
    ]
    .into_iter()
    .chain(ERROR_COLUMNS.map(|c| (c, false)))
    {
        t.col(c, hw);
    }
    for (s, field, rows) in recon_groups(o) {
        let mut row = vec![
            s.name().to_string(),
            s.lattice().to_string(),
            field.to_string(),
        ];
        let ok: Vec<&Row> = rows
            .iter()
            .copied()
            .filter(|r| r.total_ms.is_finite())
            .collect();
        let Some(first) = ok.first() else {
            let why = failure(o, |r| rows.iter().any(|x| std::ptr::eq(*x, r)))
                .unwrap_or_else(|| "—".into());
            row.extend(failed_cells(why, t.columns.len() - row.len()));
            t.rows.push(row);
            continue;
        };
        row.extend([
            first
                .counter("samples")
                .map_or("—".into(), |n| n.to_string()),
            fmt(
                median(&ok.iter().map(|r| r.total_ms).collect::<Vec<_>>()),
                2,
            ),
            fig9_rank(s).to_string(),
        ]);
        row.extend(error_cells(&ok));
        t.rows.push(row);
    }
    let bcc_n = crate::meshes::LatticeSpec::new("bcc", sz.cells, &FIELDS[0], sz.gt_step)
        .map(|l| l.bcc_points())
        .unwrap_or(0);
    t.notes.push(format!(
        "Ray casting regular volumes over [-1, 1]³ (`volume-raycast` on the lattice meshes' samples): CC {c1}³ samples (h = 2/{c}), BCC {n}³ primary + {n1}³ secondary samples (h = 2/{m}); orthographic {s}², {v}, step {st:.4} (h_cc/2) for tril, bilspat, bary, shtril; bil samples where the ray meets the planes (spacing h_bcc/2 ≈ h_cc/√2); each segment between samples integrated by `exact` with the `default` TF (range [0, 1]); median of {r} frame(s).",
        c1 = sz.cells + 1,
        c = sz.cells,
        n = bcc_n,
        n1 = bcc_n + 1,
        m = bcc_n.saturating_sub(1),
        s = sz.image,
        v = views_note(o),
        st = 1.0 / sz.cells as f64,
        r = sz.repeats
    ));
    t.notes.push(format!(
        "Errors against the analytic field ray-integrated over the same box at step {:.4} with `exact` (mean over views). Both lattices are seen by one camera framing the box [-1, 1]³ (`frame = \"box\"`: the BCC mesh's secondary grid reaches half a cell beyond it) and integrated with the box's L.",
        sz.gt_step
    ));
    t.notes.push("paper_fig9_rank: the order of the paper's Fig. 9 timings (a chart, no numbers in the text): bil fastest, then tril, shtril and bilspat similar and slightly slower than tril, bary slowest; the paper found shtril and bilspat best in quality on BCC, tril on CC most detailed.".into());
    t
}

/// Time against error per scheme and field (`bcc_reconstruction-time_vs_error`).
fn recon_plots(o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
    let pts: Vec<TimeError> = recon_groups(o)
        .into_iter()
        .filter_map(|(s, field, rows)| {
            let ok: Vec<&Row> = rows
                .into_iter()
                .filter(|r| r.total_ms.is_finite())
                .collect();
            (!ok.is_empty()).then(|| TimeError {
                label: format!("{} {field}", s.name()),
                rmse: mean(&ok.iter().filter_map(|r| r.rmse).collect::<Vec<_>>()),
                time_ms: median(&ok.iter().map(|r| r.total_ms).collect::<Vec<_>>()),
            })
        })
        .collect();
    if pts.is_empty() {
        return Ok(Vec::new());
    }
    plots::time_vs_error(
        &pts,
        &dir.join("bcc_reconstruction-time_vs_error"),
        "Reconstruction schemes: ray-casting time against error (BCC paper Fig. 9)",
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use algorithms::bcc::recon::{self, Sampling};
    use algorithms::camera::{Camera, Projection, View};
    use algorithms::glam::DVec3;
    use algorithms::mesh::Aabb;
    use algorithms::metrics::compare;
    use algorithms::optics::integrator;

    /// The ground truth converges: halving the step changes the image far less than the
    /// lattice errors the tables report.
    #[test]
    fn ground_truth_is_converged() {
        let bbox = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::ONE,
        };
        let t = dense_tf();
        let exact = integrator("exact", &t).unwrap();
        let c = Camera::new(&bbox, View::new(30.0, 20.0), Projection::Ortho, 32, 32);
        let gt = |step: f64| {
            recon::ground_truth(
                &datasets_gen::fields::marschner_lobb,
                &|_| true,
                &bbox,
                &c,
                Sampling {
                    map: t.scalar_map((0.0, 1.0)),
                    integ: exact.as_ref(),
                    step,
                    diag: bbox.diagonal(),
                },
            )
            .unwrap()
        };
        let e = compare(&gt(0.01), &gt(0.005)).unwrap();
        assert!(e.rmse < 2e-3, "{}", e.rmse);
    }

    /// Scheme names survive the variant label.
    #[test]
    fn schemes_are_read_back_from_the_label() {
        let r = Row {
            variant: "volume-raycast/exact[scheme=bilspat,step=0.0625]".into(),
            ..Default::default()
        };
        assert_eq!(scheme_of(&r), Some(Scheme::BilinearSpatial));
        let plain = Row {
            variant: "volume-raycast/exact".into(),
            ..Default::default()
        };
        assert_eq!(scheme_of(&plain), None);
    }
}
