//! `average`: the Shirley–Tuchman averaging integrator (CONVENTIONS §4, `average` row).

use super::{tau_len, valid_input, Integrator, IntegratorInfo, Segment};
use crate::tf::TransferFunction;

/// `average`.
pub const AVERAGE: IntegratorInfo = IntegratorInfo {
    name: "average",
    description: "the segment's mean colour and extinction (CONVENTIONS §4; fastest, least exact)",
    on_gpu: true,
    make: |tf| Box::new(Average::new(tf)),
};

/// `average`: Shirley & Tuchman (1990), CONVENTIONS §4 `average` row:
/// `s̄ = (s_f + s_b)/2`, `α = 1 − exp(−τ(s̄)·l)`, `I = C(s̄)·α`.
#[derive(Clone, Debug)]
pub struct Average {
    tf: TransferFunction,
}

impl Average {
    pub fn new(tf: &TransferFunction) -> Average {
        Average { tf: tf.clone() }
    }
}

impl Integrator for Average {
    fn name(&self) -> &'static str {
        "average"
    }
    fn segment(&self, sf: f64, sb: f64, l: f64) -> Segment {
        if !valid_input(sf, sb, l) {
            return Segment::default();
        }
        let (c, tau) = self.tf.eval(0.5 * sf + 0.5 * sb);
        let alpha = -(-tau_len(tau, l)).exp_m1();
        Segment {
            rgb: [c[0] * alpha, c[1] * alpha, c[2] * alpha],
            alpha,
        }
    }
}
