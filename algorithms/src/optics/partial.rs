//! `partial`: Moreland & Angel's partial pre-integration with a tabulated Ψ (CONVENTIONS §4,
//! `partial` row).

use std::sync::Arc;

use super::psi::PsiTable;
use super::{tau_len, valid_input, Integrator, IntegratorInfo, Segment};
use crate::tf::TransferFunction;

/// `partial`.
pub const PARTIAL: IntegratorInfo = IntegratorInfo {
    name: "partial",
    description: "partial pre-integration (Moreland & Angel 2004): linear τ, per-piece Ψ table",
    on_gpu: true,
    make: |tf| Box::new(Partial::new(tf)),
};

/// `partial`: Moreland & Angel (2004) partial pre-integration, CONVENTIONS §4 `partial` row:
/// `ζ = exp(−l(τ_f + τ_b)/2)`, `α = 1 − ζ`, `I = C_f(1 − Ψ) + C_b(Ψ − ζ)` with Ψ read (bilinearly)
/// from a [`PsiTable`] and clamped to `[ζ, 1]`. Ignores transfer-function points between the ends.
#[derive(Clone, Debug)]
pub struct Partial {
    tf: TransferFunction,
    table: Arc<PsiTable>,
}

impl Partial {
    /// With the shared default table ([`PsiTable::shared`]).
    pub fn new(tf: &TransferFunction) -> Partial {
        Partial::with_table(tf, PsiTable::shared())
    }
    pub fn with_table(tf: &TransferFunction, table: Arc<PsiTable>) -> Partial {
        Partial {
            tf: tf.clone(),
            table,
        }
    }
    pub fn table(&self) -> &PsiTable {
        &self.table
    }
}

impl Partial {
    /// [`Integrator::segment`] for finite `sf`, `sb` and `l > 0`, given the transfer
    /// function's values at both ends, `tf.eval(sf)` and `tf.eval(sb)` (the same bits): a ray
    /// caster evaluates each crossing once, as the back of one segment and the front of the
    /// next.
    #[inline]
    pub fn segment_eval(
        &self,
        (cf, tau_f): ([f64; 3], f64),
        (cb, tau_b): ([f64; 3], f64),
        l: f64,
    ) -> Segment {
        let (fa, fb) = (tau_len(tau_f, l), tau_len(tau_b, l));
        let g_end = 0.5 * (fa + fb);
        let zeta = (-g_end).exp();
        let alpha = -(-g_end).exp_m1();
        // Ψ − ζ from the table, kept in [0, α] (Ψ ∈ [ζ, 1]).
        let pmz = (self.table.lookup(fa, fb) - zeta).clamp(0.0, alpha);
        Segment::from_partial(cf, cb, alpha, pmz)
    }

    pub fn tf(&self) -> &TransferFunction {
        &self.tf
    }
}

impl Integrator for Partial {
    fn name(&self) -> &'static str {
        "partial"
    }
    fn segment(&self, sf: f64, sb: f64, l: f64) -> Segment {
        if !valid_input(sf, sb, l) {
            return Segment::default();
        }
        self.segment_eval(self.tf.eval(sf), self.tf.eval(sb), l)
    }
}
