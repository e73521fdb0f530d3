//! `exact`: the ground truth. A segment is split where its scalar crosses a transfer-function
//! point and each linear piece is integrated in closed form with Ψ evaluated, not tabled
//! (CONVENTIONS §4, `exact` row): `1 − Ψ` and `Ψ − ζ` by Gauss–Legendre quadrature with as few
//! nodes as its error bound allows (`gauss.rs`: within 1e-12 of the piece's opacity), and by
//! Ψ's panels ([`psi_terms_ends`]) for the few pieces too deep for that.

use super::gauss::PieceQuadrature;
use super::psi::psi_terms_ends;
use super::{composite_under, tau_len, valid_input, Integrator, IntegratorInfo, Segment};
use crate::tf::TransferFunction;

/// `exact`.
pub const EXACT: IntegratorInfo = IntegratorInfo {
    name: "exact",
    description: "the emission–absorption integral to ~1e-12, per TF piece (the reference's)",
    on_gpu: false,
    make: |tf| Box::new(Exact::new(tf)),
};

/// One piece of a segment on which colour and extinction are linear: its share `frac` of the
/// segment's length and its front/back colour and extinction.
#[derive(Clone, Copy, Debug)]
pub(super) struct Piece {
    pub(super) frac: f64,
    pub(super) cf: [f64; 3],
    pub(super) tf: f64,
    pub(super) cb: [f64; 3],
    pub(super) tb: f64,
}

/// Splits `[sf, sb]` at the transfer function's points (front to back) into `out`.
pub(super) fn split_pieces(tf: &TransferFunction, sf: f64, sb: f64, out: &mut Vec<Piece>) {
    out.clear();
    let span = sb - sf;
    let (mut s0, (mut c0, mut t0)) = (sf, tf.eval(sf));
    for s1 in tf.breakpoints_between(sf, sb).chain(std::iter::once(sb)) {
        let (c1, t1) = tf.eval(s1);
        let frac = if span != 0.0 { (s1 - s0) / span } else { 1.0 };
        if frac > 0.0 {
            out.push(Piece {
                frac,
                cf: c0,
                tf: t0,
                cb: c1,
                tb: t1,
            });
        }
        (s0, c0, t0) = (s1, c1, t1);
    }
}

/// Emission–absorption integral of one linear piece of optical length `l`.
///
/// With `u = t/l`, `C(u) = C_f + (C_b − C_f)·u` and `τ(u)·l = g'(u)`, `T(u) = exp(−g(u))`:
/// ```text
///   I = ∫₀¹ C(u) g'(u) e^{−g(u)} du
///     = C_f ∫₀¹ g' e^{−g} du + (C_b − C_f) ∫₀¹ u g' e^{−g} du
///     = C_f (1 − ζ) + (C_b − C_f) ([−u e^{−g}]₀¹ + ∫₀¹ e^{−g} du)      (by parts)
///     = C_f (1 − ζ) + (C_b − C_f) (Ψ − ζ)
///     = C_f (1 − Ψ) + C_b (Ψ − ζ),            α = 1 − ζ = 1 − exp(−(τ_f + τ_b)·l/2)
/// ```
/// (CONVENTIONS §4, `partial` row; Moreland & Angel 2004). Exact when C and τ are linear along
/// the piece, which they are between transfer-function points since `s` is linear in `t`.
#[inline]
pub(super) fn piece_segment(cf: [f64; 3], tau_f: f64, cb: [f64; 3], tau_b: f64, l: f64) -> Segment {
    let t = psi_terms_ends(tau_len(tau_f, l), tau_len(tau_b, l));
    Segment {
        rgb: [
            cf[0] * t.one_minus_psi + cb[0] * t.psi_minus_zeta,
            cf[1] * t.one_minus_psi + cb[1] * t.psi_minus_zeta,
            cf[2] * t.one_minus_psi + cb[2] * t.psi_minus_zeta,
        ],
        alpha: t.alpha,
    }
}

/// [`piece_segment`] with `1 − Ψ` and `Ψ − ζ` from the quadrature of `gauss.rs` where one of
/// its rules covers the piece (`I = C_f·(1 − Ψ) + C_b·(Ψ − ζ)`, `α = (1 − Ψ) + (Ψ − ζ)`, each
/// within 1e-12·α), else from [`piece_segment`] itself.
#[inline(always)]
fn piece_segment_quad(
    q: &PieceQuadrature,
    cf: [f64; 3],
    tau_f: f64,
    cb: [f64; 3],
    tau_b: f64,
    l: f64,
) -> Segment {
    match q.terms(tau_len(tau_f, l), tau_len(tau_b, l)) {
        Some((one_minus_psi, psi_minus_zeta)) => Segment {
            rgb: [
                cf[0] * one_minus_psi + cb[0] * psi_minus_zeta,
                cf[1] * one_minus_psi + cb[1] * psi_minus_zeta,
                cf[2] * one_minus_psi + cb[2] * psi_minus_zeta,
            ],
            alpha: one_minus_psi + psi_minus_zeta,
        },
        None => piece_segment(cf, tau_f, cb, tau_b, l),
    }
}

/// Composites the pieces of one segment of optical length `l`, front to back.
pub(super) fn integrate_pieces(pieces: &[Piece], l: f64) -> Segment {
    let mut acc = Segment::default();
    for p in pieces {
        let seg = piece_segment(p.cf, p.tf, p.cb, p.tb, p.frac * l);
        composite_under(&mut acc, seg);
        if acc.alpha >= 1.0 {
            break;
        }
    }
    acc
}

/// `exact`: the segment split at transfer-function points, each linear piece integrated in closed
/// form with Ψ evaluated (CONVENTIONS §4, `exact` row). The ground truth of the project.
#[derive(Clone, Debug)]
pub struct Exact {
    tf: TransferFunction,
    quad: &'static PieceQuadrature,
}

impl Exact {
    pub fn new(tf: &TransferFunction) -> Exact {
        Exact {
            tf: tf.clone(),
            quad: PieceQuadrature::shared(),
        }
    }
}

impl Exact {
    /// [`Integrator::segment`] given the transfer function's values at both ends,
    /// `ef = tf.eval(sf)` and `eb = tf.eval(sb)` (the same bits): a ray caster evaluates each
    /// crossing once, as the back of one segment and the front of the next. (Inlined whole, so
    /// that the ray caster's queue compiles its quadrature for its own instruction set.)
    #[inline(always)]
    pub fn segment_eval(
        &self,
        sf: f64,
        ef: ([f64; 3], f64),
        sb: f64,
        eb: ([f64; 3], f64),
        l: f64,
    ) -> Segment {
        if !valid_input(sf, sb, l) {
            return Segment::default();
        }
        // `split_pieces` + `integrate_pieces`, streamed: the same pieces composited in the same
        // order, without the two heap allocations per segment (the ray caster calls this once
        // per cell step).
        let (tf, q) = (&self.tf, self.quad);
        let span = sb - sf;
        let (lo, hi) = if sf <= sb { (sf, sb) } else { (sb, sf) };
        let mut acc = Segment::default();
        let (mut s0, (mut c0, mut t0)) = (sf, ef);
        let mut piece = |s1: f64, (c1, t1): ([f64; 3], f64)| -> bool {
            let frac = if span != 0.0 { (s1 - s0) / span } else { 1.0 };
            if frac > 0.0 {
                composite_under(&mut acc, piece_segment_quad(q, c0, t0, c1, t1, frac * l));
                if acc.alpha >= 1.0 {
                    return false;
                }
            }
            (s0, c0, t0) = (s1, c1, t1);
            true
        };
        let inner = |p: &&crate::tf::TfPoint| p.s > lo && p.s < hi;
        let more = if sf <= sb {
            tf.points
                .iter()
                .filter(inner)
                .all(|p| piece(p.s, tf.eval(p.s)))
        } else {
            tf.points
                .iter()
                .rev()
                .filter(inner)
                .all(|p| piece(p.s, tf.eval(p.s)))
        };
        if more {
            piece(sb, eb);
        }
        acc
    }

    pub fn tf(&self) -> &TransferFunction {
        &self.tf
    }
}

impl Integrator for Exact {
    fn name(&self) -> &'static str {
        "exact"
    }
    fn segment(&self, sf: f64, sb: f64, l: f64) -> Segment {
        if !valid_input(sf, sb, l) {
            return Segment::default();
        }
        self.segment_eval(sf, self.tf.eval(sf), sb, self.tf.eval(sb), l)
    }
}
