//! The BCC paper: CC against BCC at equal information with projected tetrahedra (§4, Fig. 10)
//! and reconstruction schemes for ray casting a regular BCC volume (§3, Fig. 9), from
//! [`crate::bcc`]'s experiments.

use std::path::{Path, PathBuf};

use algorithms::{Error, Result};

use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::plots::{self, TimeError};

/// The rows of a written table `DIR/<id>.csv` as column-name → value maps.
fn table_rows(dir: &Path, id: &str) -> Result<Vec<std::collections::HashMap<String, String>>> {
    let p = dir.join(format!("{id}.csv"));
    if !p.exists() {
        return Ok(Vec::new());
    }
    let err = |e: csv::Error| Error::Input(format!("{}: {e}", p.display()));
    let mut r = csv::Reader::from_path(&p).map_err(err)?;
    let head = r.headers().map_err(err)?.clone();
    r.records()
        .map(|rec| {
            let rec = rec.map_err(err)?;
            Ok(head
                .iter()
                .zip(rec.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect())
        })
        .collect()
}

fn num(row: &std::collections::HashMap<String, String>, k: &str) -> f64 {
    row.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
}

/// `bcc_pt`.
pub struct Pt;

impl PaperTable for Pt {
    fn id(&self) -> &'static str {
        crate::bcc::PT_ID
    }
    fn title(&self) -> &'static str {
        "BCC paper §4 / Fig. 10: CC vs BCC at equal information with projected tetrahedra (bcc-implicit), and empty-space skipping"
    }
    fn about(&self) -> &'static str {
        "CC against BCC sampling at equal information, rendered by projected tetrahedra with the implicit BCC order; error against a ground truth integrated from the analytic field."
    }
    fn run(&self, ctx: &Ctx) -> Result<Done> {
        if let Some(d) = ctx.skip_unsharded() {
            return Ok(d);
        }
        let (table, plots) = crate::bcc::pt_table(ctx.quick, &ctx.out)?;
        Ok(Done::Table { table, plots })
    }
    /// From the written `bcc_pt.csv`: the dense-TF rows, as the run draws them.
    fn replot(&self, _o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
        let rows = table_rows(dir, self.id())?;
        let mut renderers: Vec<&str> = Vec::new();
        for r in &rows {
            if !renderers.contains(&r["renderer"].as_str()) {
                renderers.push(&r["renderer"]);
            }
        }
        let pts: Vec<TimeError> = rows
            .iter()
            .filter(|r| r["tf"] == "default")
            .map(|r| TimeError {
                label: if Some(&r["renderer"].as_str()) == renderers.first() {
                    format!("{} {}", r["lattice"], r["field"])
                } else {
                    format!("{} {} {}", r["lattice"], r["field"], r["renderer"])
                },
                rmse: num(r, "rmse"),
                time_ms: num(r, "time_ms"),
            })
            .collect();
        plots::time_vs_error(
            &pts,
            &dir.join("bcc_pt-time_vs_error"),
            &format!(
                "CC vs BCC at equal information: {} time against error",
                renderers.join(", ")
            ),
        )
    }
}

/// `bcc_reconstruction`.
pub struct Reconstruction;

impl PaperTable for Reconstruction {
    fn id(&self) -> &'static str {
        crate::bcc::RECON_ID
    }
    fn title(&self) -> &'static str {
        "BCC paper §3 / Fig. 9: ray casting with trilinear on CC and bil, bilspat, bary, shtril on BCC, time and error"
    }
    fn about(&self) -> &'static str {
        "Reconstruction schemes for ray casting a regular BCC volume against trilinear on CC: time and error per scheme (BCC paper Fig. 9)."
    }
    fn run(&self, ctx: &Ctx) -> Result<Done> {
        if let Some(d) = ctx.skip_unsharded() {
            return Ok(d);
        }
        let (table, plots) = crate::bcc::recon_table(ctx.quick, &ctx.out)?;
        Ok(Done::Table { table, plots })
    }
    /// From the written `bcc_reconstruction.csv`.
    fn replot(&self, _o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
        let pts: Vec<TimeError> = table_rows(dir, self.id())?
            .iter()
            .map(|r| TimeError {
                label: format!("{} {}", r["scheme"], r["field"]),
                rmse: num(r, "rmse"),
                time_ms: num(r, "time_ms"),
            })
            .collect();
        plots::time_vs_error(
            &pts,
            &dir.join("bcc_reconstruction-time_vs_error"),
            "Reconstruction schemes: ray-casting time against error (BCC paper Fig. 9)",
        )
    }
}
