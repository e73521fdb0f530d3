//! Optical model and per-segment integrators (CONVENTIONS §4), in f64.
//!
//! Emission–absorption (Max 1995, "Optical models for direct volume rendering"): along a ray,
//! `I = ∫ C(s(t)) τ(s(t)) T(t) dt` with `T(t) = exp(−∫₀ᵗ τ)`. A ray is cut into segments, one per
//! cell; a segment is described by the transfer-function scalar at its front and back (`s_f`,
//! `s_b`, with `s` linear along the segment) and its optical length `l` (world length / `L`). Each
//! [`Integrator`] turns that into a premultiplied [`Segment`], and segments are composited with
//! [`composite_under`] (front to back) or `I ← I_seg + (1 − α_seg)·I` (back to front).
//!
//! Notation used throughout (CONVENTIONS §4, `partial` row): along one linear piece, with
//! `u = t / l ∈ [0, 1]`, the optical depth from the front is
//! `g(u) = a·u + b·u²`, `a = τ_f·l`, `b = (τ_b − τ_f)·l/2`, so `g'(u) = τ(u)·l ≥ 0` and
//! `g(1) = (τ_f + τ_b)·l/2`. Then `ζ = exp(−g(1))` and `Ψ(a, b) = ∫₀¹ exp(−g(u)) du`.
//! Internally Ψ is computed from the two end depths `fa = τ_f·l` and `fb = τ_b·l` (both ≥ 0), which
//! write every quantity as a sum of non-negative terms (no cancellation).
//!
//! Tables meant for GPU upload ([`PsiTable`], [`PreintTable`]) are plain `f32` arrays whose layout
//! is documented on each type.

use crate::error::{Error, Result};
use crate::tf::TransferFunction;

mod average;
mod exact;
pub mod fast;
mod gauss;
pub mod gpu;
mod partial;
mod preint;
mod preint_table;
mod psi;

pub use average::{Average, AVERAGE};
pub use exact::{Exact, EXACT};
pub use partial::{Partial, PARTIAL};
pub use preint::{Preint, PREINT};
pub use preint_table::PreintTable;
pub use psi::{
    depth_of_gamma, gamma_of_depth, one_minus_psi, psi, psi_minus_zeta, psi_terms_ends, PsiTable,
    PsiTerms, TableError,
};

/// Premultiplied colour and opacity of one ray segment.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Segment {
    pub rgb: [f64; 3],
    pub alpha: f64,
}

impl Segment {
    /// The `partial` segment from its end colours, opacity α = 1 − ζ and Ψ − ζ:
    /// I = C_f(1 − Ψ) + C_b(Ψ − ζ) written as C_f·α + (C_b − C_f)(Ψ − ζ) (see `piece_segment`),
    /// so that a constant colour gives exactly C·α however thin the segment. Shared by
    /// [`Partial`] and the ray caster's own evaluation of it (same operations, same bits).
    #[inline(always)]
    pub fn from_partial(cf: [f64; 3], cb: [f64; 3], alpha: f64, pmz: f64) -> Segment {
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

/// A per-segment integrator of the emission–absorption model.
pub trait Integrator: Send + Sync {
    fn name(&self) -> &'static str;
    /// One segment through one cell: `sf`, `sb` = normalised scalars (the TF's `s`) at the front and
    /// back of the segment, `l` = optical length (world length / L, so l >= 0).
    ///
    /// `l <= 0`, a NaN `l`, or a non-finite `sf`/`sb` give a zero (fully transparent) segment.
    fn segment(&self, sf: f64, sb: f64, l: f64) -> Segment;
}

/// An integrator's registry entry, declared in the integrator's own file.
pub struct IntegratorInfo {
    pub name: &'static str,
    pub description: &'static str,
    /// Whether the GPU renderers have it (their tables are in the gpu module).
    pub on_gpu: bool,
    pub make: fn(&TransferFunction) -> Box<dyn Integrator>,
}

/// Every integrator, in `tetbench list` order: the one place integrator names are known (adding
/// one is a file in this folder declaring its entry, and a line here).
pub static REGISTRY: &[&IntegratorInfo] = &[&AVERAGE, &PARTIAL, &PREINT, &EXACT];

/// Names accepted by [`integrator`] (the registry's, for renderer entries).
pub const INTEGRATORS: [&str; 4] = [AVERAGE.name, PARTIAL.name, PREINT.name, EXACT.name];

/// The registry entry of an integrator name: the one check of integrator names (an unknown
/// one is one line with the known ones and the closest).
pub fn info(name: &str) -> Result<&'static IntegratorInfo> {
    REGISTRY
        .iter()
        .copied()
        .find(|i| i.name == name)
        .ok_or_else(|| {
            Error::Input(format!(
                "unknown integrator '{name}' (known: {}){}",
                INTEGRATORS.join(", "),
                crate::plugin::did_you_mean(name, &INTEGRATORS)
            ))
        })
}

/// Builds an integrator by name for a transfer function.
pub fn integrator(name: &str, tf: &TransferFunction) -> Result<Box<dyn Integrator>> {
    Ok((info(name)?.make)(tf))
}

/// Front-to-back compositing helper: `acc = acc + (1 − acc.alpha)·seg` (premultiplied "under";
/// Porter & Duff 1984).
#[inline]
pub fn composite_under(acc: &mut Segment, seg: Segment) {
    let t = 1.0 - acc.alpha;
    for c in 0..3 {
        acc.rgb[c] += t * seg.rgb[c];
    }
    acc.alpha += t * seg.alpha;
}

/// `τ·l` with `0·∞ = 0` (a transparent stretch stays transparent however long).
#[inline]
fn tau_len(tau: f64, l: f64) -> f64 {
    if tau == 0.0 || l == 0.0 {
        0.0
    } else {
        tau * l
    }
}

#[inline]
fn valid_input(sf: f64, sb: f64, l: f64) -> bool {
    sf.is_finite() && sb.is_finite() && l > 0.0
}

#[cfg(test)]
mod tests;
