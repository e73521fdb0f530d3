//! What the walk integrates with. Every crossing is the back of one segment and the front of
//! the next, so the transfer function is evaluated once per crossing ([`Shade::end`]) instead
//! of twice per segment; `partial` and `exact` take those values through their
//! `segment_eval` (the same arithmetic as `Integrator::segment`, so the same bits), and the
//! walk is compiled once per integrator kind instead of calling it through a `dyn` pointer.

use crate::optics::{Exact, Integrator, Partial, Segment};
use crate::tf::TransferFunction;

/// A per-segment integrator as the walk calls it.
pub(super) trait Shade: Sync {
    /// The transfer function's values at one crossing.
    type End: Copy;
    fn end(&self, s: f64) -> Self::End;
    /// The segment between two crossings of optical length `l > 0`.
    fn segment(&self, front: &Self::End, back: &Self::End, l: f64) -> Segment;
}

/// The integrator a ray caster was prepared with.
pub(super) enum Shader {
    Partial(Partial),
    Exact(Exact),
    /// Any other integrator, through its trait (average, preint).
    Other(Box<dyn Integrator>),
}

impl Shader {
    pub(super) fn new(name: &str, tf: &TransferFunction) -> crate::error::Result<Shader> {
        let i = crate::optics::integrator(name, tf)?;
        Ok(match name {
            "partial" => Shader::Partial(Partial::new(tf)),
            "exact" => Shader::Exact(Exact::new(tf)),
            _ => Shader::Other(i),
        })
    }
}

/// A crossing's scalar and the transfer function's colour and extinction there.
#[derive(Clone, Copy)]
pub(super) struct Eval {
    s: f64,
    c: [f64; 3],
    tau: f64,
}

impl Shade for Partial {
    type End = Eval;
    #[inline(always)]
    fn end(&self, s: f64) -> Eval {
        let (c, tau) = self.tf().eval(s);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn segment(&self, f: &Eval, b: &Eval, l: f64) -> Segment {
        // `Integrator::segment`'s input check (l > 0 is the caller's).
        if !(f.s.is_finite() && b.s.is_finite()) {
            return Segment::default();
        }
        // `Partial::segment_eval` with one libm call instead of two: ζ = 1 − α (α = −expm1(−g),
        // g the segment's optical depth) rather than exp(−g), which differs from it by an
        // ulp of 1 (≤ 1.1e-16 absolute), far inside `partial`'s own error.
        let (fa, fb) = (f.tau * l, b.tau * l);
        let alpha = -(-0.5 * (fa + fb)).exp_m1();
        let zeta = 1.0 - alpha;
        let pmz = (self.table().lookup(fa, fb) - zeta).clamp(0.0, alpha);
        let (cf, cb) = (f.c, b.c);
        Segment {
            rgb: [
                cf[0] * alpha + (cb[0] - cf[0]) * pmz,
                cf[1] * alpha + (cb[1] - cf[1]) * pmz,
                cf[2] * alpha + (cb[2] - cf[2]) * pmz,
            ],
            alpha,
        }
    }
}

impl Shade for Exact {
    type End = Eval;
    #[inline(always)]
    fn end(&self, s: f64) -> Eval {
        let (c, tau) = self.tf().eval(s);
        Eval { s, c, tau }
    }
    #[inline(always)]
    fn segment(&self, f: &Eval, b: &Eval, l: f64) -> Segment {
        self.segment_eval(f.s, (f.c, f.tau), b.s, (b.c, b.tau), l)
    }
}

impl Shade for Box<dyn Integrator> {
    type End = f64;
    #[inline(always)]
    fn end(&self, s: f64) -> f64 {
        s
    }
    #[inline(always)]
    fn segment(&self, f: &f64, b: &f64, l: f64) -> Segment {
        Integrator::segment(self.as_ref(), *f, *b, l)
    }
}
