//! The JBU paper (Callahan & Silva): Fig. 3/4 (time per rendering resolution) and Fig. 5 (RMSE
//! of bilateral against linear and nearest upsampling), from [`crate::jbu`]'s experiment.

use std::path::{Path, PathBuf};

use algorithms::Result;

use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;

/// JBU Fig. 3/4 and Fig. 5.
pub struct Figures;

impl PaperTable for Figures {
    fn id(&self) -> &'static str {
        "jbu"
    }
    fn title(&self) -> &'static str {
        "JBU Fig. 3/4 and Fig. 5"
    }
    fn about(&self) -> &'static str {
        "Joint bilateral upsampling on the paper's protocol (14 cube views; 128², 256², 512² upsampled to 1024²): time per rendering resolution (JBU Fig. 3/4) and mean and worst RMSE of bilateral against linear upsampling (Fig. 5), for the ray caster and cpu-pt (GPU renderers on a real GPU)."
    }
    fn run(&self, ctx: &Ctx) -> Result<Done> {
        if let Some(d) = ctx.skip_unsharded() {
            return Ok(d);
        }
        let plan = crate::jbu::Plan::new(ctx.quick);
        crate::jbu::run(&plan, &ctx.out)?;
        Ok(Done::Files(format!(
            "[{0}.md]({0}.md), [{0}.csv]({0}.csv) and the `{0}_time_*` (Fig. 3/4) and `{0}_rmse_*` (Fig. 5) plots, PNG and SVG",
            self.id()
        )))
    }
    /// From the written `jbu.csv`.
    fn replot(&self, _o: &Outcome, dir: &Path) -> Result<Vec<PathBuf>> {
        let csv = dir.join("jbu.csv");
        if !csv.exists() {
            return Ok(Vec::new());
        }
        let (rows, plan) = crate::jbu::read_rows(&csv)?;
        crate::jbu::report::write_plots(&rows, &plan, dir)?;
        crate::jbu::report::write_md(&rows, &plan, dir)?;
        Ok(plan
            .renderers
            .iter()
            .flat_map(|r| {
                let f = r.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_");
                ["time", "rmse"].map(|k| dir.join(format!("jbu_{k}_{f}.png")))
            })
            .collect())
    }
}
