//! The JBU paper (Callahan & Silva): Fig. 3/4 (time per rendering resolution) and Fig. 5 (RMSE
//! of bilateral against linear and nearest upsampling), from [`crate::jbu`]'s experiment.

use algorithms::Result;

use super::{Ctx, Done, PaperTable};

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
        "Joint bilateral upsampling: time per rendering resolution (JBU Fig. 3/4) and RMSE of bilateral against linear upsampling (Fig. 5), for every CPU and GPU renderer of the papers' families."
    }
    fn run(&self, ctx: &Ctx) -> Result<Done> {
        if let Some(d) = ctx.skip_unsharded() {
            return Ok(d);
        }
        let plan = crate::jbu::Plan::new(ctx.quick);
        crate::jbu::run(&plan, &ctx.out)?;
        Ok(Done::Files(format!(
            "[{0}.csv]({0}.csv) and the `{0}_time_*.svg` (Fig. 3/4), `{0}_rmse_*.svg` (Fig. 5) plots",
            self.id()
        )))
    }
}
