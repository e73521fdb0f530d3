//! The BCC paper: CC against BCC at equal information with projected tetrahedra (§4, Fig. 10)
//! and reconstruction schemes for ray casting a regular BCC volume (§3, Fig. 9), from
//! [`crate::bcc`]'s experiments.

use algorithms::Result;

use super::{Ctx, Done, PaperTable};

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
}
