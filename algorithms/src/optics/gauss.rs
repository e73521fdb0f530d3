//! The two integrals of one linear piece that `exact` needs, by Gauss–Legendre quadrature with
//! as few nodes as a proven error bound allows.
//!
//! Notation of the optics module: `g(u) = a·u + b·u²` is the optical depth from the piece's
//! front, `g'(u) = τ(u)·l = fa·(1 − u) + fb·u ≥ 0` with the end depths `fa = τ_f·l`, `fb = τ_b·l`,
//! and `G = g(1) = (fa + fb)/2`. A piece's colour is `I = C_f·(1 − Ψ) + C_b·(Ψ − ζ)` (see
//! `exact::piece_segment`), and integrating `∫₀¹ u·g'·e^{−g} du` by parts
//! (`= [−u·e^{−g}]₀¹ + ∫₀¹ e^{−g} du`) gives
//! ```text
//!   Ψ − ζ = ∫₀¹ u·g'(u)·e^{−g(u)} du,        1 − Ψ = ∫₀¹ (1 − u)·g'(u)·e^{−g(u)} du,
//! ```
//! whose sum is `∫₀¹ g'·e^{−g} du = 1 − ζ = α`. Both integrands are non-negative, so neither
//! integral cancels at any depth (where `1 − Ψ` and `Ψ − ζ` formed from Ψ would for thin pieces),
//! and the `m` exponentials at the nodes serve both.
//!
//! **Error bound.** For `f` analytic in the Bernstein ellipse `E_ρ` (foci ±1, semi-axes summing
//! to ρ) with `|f| ≤ M` there, `m`-point Gauss–Legendre on `[−1, 1]` errs by at most
//! `(64/15)·M·ρ^{2−2m}/(ρ² − 1)` (Trefethen 2008, "Is Gauss quadrature better than
//! Clenshaw–Curtis?", SIAM Review 50(1), Theorem 4.5, with its `n + 1 = m` nodes). On `[0, 1]`
//! (`u = (1 + t)/2`) the error is half that, for the ellipse about `1/2` with semi-major axis
//! `(ρ + 1/ρ)/4`, on which `|u|, |1 − u| ≤ R = 1/2 + (ρ + 1/ρ)/4`. Since `fa, fb ≤ 2G` and
//! `|fb − fa|/2 ≤ G`, there `|g(u)| ≤ G·R·(2 + R)` and `|g'(u)| ≤ 2G·(1 + R)`, so
//! `M ≤ 2G·R·(1 + R)·e^{G·R·(2 + R)}`; and `α = 1 − e^{−G} ≥ G·e^{−G}`. So for every ρ > 1
//! ```text
//!   |error| / α ≤ (64/15)·R·(1 + R)·e^{G·(R·(2 + R) + 1)}·ρ^{2−2m} / (ρ² − 1).
//! ```
//! [`RULES`] lists per node count a `G` up to which this bound, minimised over ρ, is at most
//! [`REL_ERROR`] (the test `gauss_rules_meet_their_bound` recomputes it), and a piece takes the
//! first rule whose `G` covers it. Each integral of a piece is then within `1e-12·α` of its
//! value (the nodes' and the sums' rounding add ~1e-15 relative), and a ray's colour, a sum of
//! pieces weighted by their transmittance `T_k` with `Σ T_k·α_k ≤ 1`, within `2e-12·max|C|`.
//! Pieces deeper than the last rule's `G` are left to [`psi_terms_ends`](super::psi_terms_ends)
//! (Ψ on panels), as are the degenerate ones (no depth, infinite or NaN depths).

use std::sync::OnceLock;

/// The largest relative error (against the piece's α) the rules are chosen for.
// Outside the tests it is read only by the documentation (the rules were chosen from it).
#[cfg_attr(not(test), allow(dead_code))]
pub(super) const REL_ERROR: f64 = 1e-12;

/// Node counts and the largest `G = g(1)` each is used for, in increasing `G`: the bound of the
/// module's documentation stays ≤ [`REL_ERROR`] up to each `G` (rounded down from where it
/// reaches it: 2.47e-3, 2.47e-2, 9.34e-2, 0.2206, 0.4026, 0.8932, 1.4972, 2.8882).
pub(super) const RULES: [(usize, f64); 8] = [
    (4, 2.4e-3),
    (5, 2.4e-2),
    (6, 9.3e-2),
    (7, 0.22),
    (8, 0.40),
    (10, 0.89),
    (12, 1.49),
    (16, 2.88),
];

/// Most nodes of a rule in [`RULES`].
const MAX_NODES: usize = 16;

/// An `m`-point Gauss–Legendre rule mapped to `[0, 1]`: nodes `u`, `v = 1 − u` (each rounded
/// once from the node on `[−1, 1]`, so that `v` keeps its relative precision near `u = 1`) and
/// weights summing to 1.
#[derive(Clone, Debug)]
pub(super) struct GaussRule {
    m: usize,
    g_max: f64,
    u: [f64; MAX_NODES],
    v: [f64; MAX_NODES],
    w: [f64; MAX_NODES],
}

impl GaussRule {
    /// The `m`-point rule (`1 ≤ m ≤ MAX_NODES`): the roots of the Legendre polynomial `P_m` by
    /// Newton's method from Tricomi's estimate `cos(π(k − 1/4)/(m + 1/2))`, `P_m` and `P_m'` by
    /// the three-term recurrence, weights `2/((1 − t²)·P_m'(t)²)` (Abramowitz & Stegun 25.4.29).
    /// The test `gauss_rules_are_the_tabled_ones` holds the 10-point rule to A&S's table.
    pub(super) fn new(m: usize, g_max: f64) -> GaussRule {
        let mut r = GaussRule {
            m,
            g_max,
            u: [0.0; MAX_NODES],
            v: [0.0; MAX_NODES],
            w: [0.0; MAX_NODES],
        };
        for k in 0..m {
            let mut t = (std::f64::consts::PI * (k as f64 + 0.75) / (m as f64 + 0.5)).cos();
            // Quadratic convergence from the estimate: a few steps reach the last bit, the rest
            // change nothing (or one ulp back and forth).
            for _ in 0..12 {
                let (p, d) = legendre(m, t);
                t -= p / d;
            }
            let (_, dp) = legendre(m, t);
            r.u[k] = 0.5 + 0.5 * t;
            r.v[k] = 0.5 - 0.5 * t;
            r.w[k] = 1.0 / ((1.0 - t * t) * dp * dp);
        }
        r
    }
}

/// `P_m(t)` and `P_m'(t)` (`m ≥ 1`, `|t| < 1`).
fn legendre(m: usize, t: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, t);
    for k in 2..=m {
        let kf = k as f64;
        (p0, p1) = (p1, ((2.0 * kf - 1.0) * t * p1 - (kf - 1.0) * p0) / kf);
    }
    (p1, m as f64 * (t * p1 - p0) / (t * t - 1.0))
}

/// The rules of [`RULES`], built once per process (in static storage, no heap).
#[derive(Debug)]
pub(super) struct PieceQuadrature {
    rules: [GaussRule; RULES.len()],
}

impl PieceQuadrature {
    pub(super) fn shared() -> &'static PieceQuadrature {
        static Q: OnceLock<PieceQuadrature> = OnceLock::new();
        Q.get_or_init(|| PieceQuadrature {
            rules: RULES.map(|(m, g)| GaussRule::new(m, g)),
        })
    }

    /// `(1 − Ψ, Ψ − ζ)` of the piece of end depths `fa`, `fb` (see the module's documentation),
    /// or `None` where no rule covers it: a depth negative or NaN, `G = 0`, or `G` beyond the
    /// last rule's (including infinite).
    #[inline(always)]
    pub(super) fn terms(&self, fa: f64, fb: f64) -> Option<(f64, f64)> {
        if !(fa >= 0.0 && fb >= 0.0) {
            return None;
        }
        let g_end = 0.5 * (fa + fb);
        if g_end.is_nan() || g_end <= 0.0 {
            return None;
        }
        let i = self.rules.iter().position(|r| g_end <= r.g_max)?;
        let r = &self.rules[i];
        // Up to 8 nodes on 8 lanes, more on 16: fixed trip counts the vectoriser takes.
        Some(if r.m <= 8 {
            sum_nodes::<8>(r, fa, fb)
        } else {
            sum_nodes::<16>(r, fa, fb)
        })
    }
}

/// The rule's sums `Σ w·(1 − u)·g'·e^{−g}` and `Σ w·u·g'·e^{−g}` over its nodes, the
/// exponentials on `N ≥ m` lanes ([`exp_neg`]; lanes past `m` have weight 0 and are computed and
/// ignored), the sums in node order.
#[inline(always)]
fn sum_nodes<const N: usize>(r: &GaussRule, fa: f64, fb: f64) -> (f64, f64) {
    let (u, v): (&[f64; N], &[f64; N]) =
        (r.u[..N].try_into().unwrap(), r.v[..N].try_into().unwrap());
    // g(u) = u·(fa·(1 + v) + fb·u)/2 and g'(u) = fa·v + fb·u: sums of non-negatives, g ≤ G.
    let e: [f64; N] =
        std::array::from_fn(|k| exp_neg(0.5 * u[k] * (fa * (1.0 + v[k]) + fb * u[k])));
    let (mut a, mut b) = (0.0, 0.0);
    for k in 0..r.m {
        let wge = r.w[k] * (fa * v[k] + fb * u[k]) * e[k];
        a += v[k] * wge;
        b += u[k] * wge;
    }
    (a, b)
}

/// `e^{−x}` for `0 ≤ x ≤ 708` (the quadrature's `x = g(u) ≤ G ≤ 2.88`), in operations that
/// vectorise (no libm call, no table): relative error ≤ 1e-14.
///
/// `e^{−x} = 2^k·e^r` with `k = round(−x·log₂e)` and `r = −x − k·ln 2` (Cody & Waite's two-part
/// ln 2, fdlibm's `ln2_hi`/`ln2_lo`: `k·ln2_hi` is exact for `|k| < 2²⁰`), `|r| ≤ ln 2/2 + 1e-16`;
/// `e^r` by its Taylor polynomial of degree 12 (Horner), whose truncation is at most
/// `|r|¹³/13!·e^{|r|} ≤ 2.4e-16` absolute, `3.3e-16` relative to `e^r ≥ 0.707`; the reduction
/// errs by ~2 ulp of `r`, and Horner's rounding by at most `γ₂₄·Σ|r|ʲ/j! ≤ 24.1u·e^{|r|}`, so
/// `≤ 49u = 5.4e-15` relative to `e^r` (Higham, "Accuracy and Stability of Numerical
/// Algorithms", §5.1); `2^k` is exact (`k ≥ −1022`). The test `exp_neg_is_within_its_bound`
/// holds it to 1e-14 of libm's `exp` over the quadrature's range and beyond.
#[inline(always)]
fn exp_neg(x: f64) -> f64 {
    // Round to nearest by the 1.5·2⁵² trick (`f64::round` is a libm call on baseline x86-64);
    // k from the bits of t = 1.5·2⁵² + k, for |k| < 2⁵¹.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let t = -x * std::f64::consts::LOG2_E + SHIFT;
    let kf = t - SHIFT;
    let r = (-x - kf * LN2_HI) - kf * LN2_LO;
    // Horner from the degree-12 coefficient 1/12! down to 1.
    let mut p = INV_FACT[12];
    for j in (0..12).rev() {
        p = p * r + INV_FACT[j];
    }
    let k = (t.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64);
    p * f64::from_bits((k.wrapping_add(1023) as u64) << 52)
}

/// `1/j!` for `j = 0..=12`, each the nearest f64.
#[allow(clippy::excessive_precision)]
const INV_FACT: [f64; 13] = [
    1.0,
    1.0,
    0.5,
    1.666_666_666_666_666_666_67e-1,
    4.166_666_666_666_666_666_67e-2,
    8.333_333_333_333_333_333_33e-3,
    1.388_888_888_888_888_888_89e-3,
    1.984_126_984_126_984_126_98e-4,
    2.480_158_730_158_730_158_73e-5,
    2.755_731_922_398_589_065_26e-6,
    2.755_731_922_398_589_065_26e-7,
    2.505_210_838_544_171_877_51e-8,
    2.087_675_698_786_809_897_92e-9,
];

#[cfg(test)]
mod tests {
    use super::super::psi::{psi_terms_ends, GL_W, GL_X};
    use super::*;

    /// `∫₀¹ f(u, 1 − u) du` by rule `r`.
    fn integrate(r: &GaussRule, f: impl Fn(f64, f64) -> f64) -> f64 {
        (0..r.m).map(|k| r.w[k] * f(r.u[k], r.v[k])).sum()
    }

    /// The bound of the module's documentation on `|error| / α` of an `m`-point rule for a piece of
    /// `G = g(1)`, minimised over ρ on a geometric grid from 1.001 to 1e4 (any ρ > 1 bounds it).
    fn rel_error_bound(m: usize, g_end: f64) -> f64 {
        let mut best = f64::INFINITY;
        let mut rho: f64 = 1.001;
        while rho < 1e4 {
            let r = 0.5 + 0.25 * (rho + 1.0 / rho);
            let b = 64.0 / 15.0
                * r
                * (1.0 + r)
                * (g_end * (r * (2.0 + r) + 1.0)).exp()
                * rho.powi(2 - 2 * m as i32)
                / (rho * rho - 1.0);
            best = best.min(b);
            rho *= 1.005;
        }
        best
    }

    /// `exp_neg` is within 1e-14 (relative) of libm's `exp` (itself within an ulp) on a dense
    /// sample of `[0, 3]` (the quadrature's range, `g ≤ 2.88`), at its ends and at the points
    /// where the rounding of `k` changes (odd multiples of ln 2/2), and on `[0, 708]`.
    #[test]
    fn exp_neg_is_within_its_bound() {
        let half = std::f64::consts::LN_2 / 2.0;
        let mut xs: Vec<f64> = (0..=300_000).map(|i| 3.0 * i as f64 / 300_000.0).collect();
        xs.extend((0..=70_800).map(|i| i as f64 / 100.0));
        for j in 0..2045 {
            let c = (2 * j + 1) as f64 * half;
            xs.extend(
                [c.next_down(), c, c.next_up()]
                    .into_iter()
                    .filter(|&x| x <= 708.0),
            );
        }
        xs.extend([0.0, f64::MIN_POSITIVE, 1e-300, 1e-17, 2.88, 708.0]);
        let mut worst = 0.0f64;
        for &x in &xs {
            let want = (-x).exp();
            let e = (exp_neg(x) - want).abs() / want;
            worst = worst.max(e);
            assert!(e <= 1e-14, "exp(-{x}): {} vs {want}", exp_neg(x));
        }
        assert_eq!(exp_neg(0.0), 1.0);
        println!("exp_neg against libm: worst relative {worst:.3e}");
    }

    /// The 10-point rule is Abramowitz & Stegun's (table 25.4) mapped to [0, 1].
    #[test]
    fn gauss_rules_are_the_tabled_ones() {
        let r = GaussRule::new(10, 1.0);
        let mut got: Vec<(f64, f64, f64)> = (0..10).map(|k| (r.u[k], r.v[k], r.w[k])).collect();
        got.sort_by(|a, b| a.0.total_cmp(&b.0));
        for k in 0..5 {
            // Nodes 5 + k and 4 − k are ½ ± GL_X[k]/2; their weights GL_W[k]/2.
            for (i, sign) in [(5 + k, 1.0), (4 - k, -1.0)] {
                let (u, v, w) = got[i];
                assert!(
                    (u - (0.5 + sign * 0.5 * GL_X[k])).abs() <= 2e-16,
                    "node {i}: {u}"
                );
                assert!(
                    (v - (0.5 - sign * 0.5 * GL_X[k])).abs() <= 2e-16,
                    "node {i}: 1 − u = {v}"
                );
                assert!((w - 0.5 * GL_W[k]).abs() <= 2e-16, "weight {i}: {w}");
            }
        }
    }

    /// Every rule of `RULES` integrates `u^k` and `(1 − u)^k` exactly (to rounding) up to degree
    /// 2m − 1, and not degree 2m where that error, `(m!)⁴/((2m + 1)·((2m)!)²)`, is above rounding
    /// (m ≤ 10): it has exactly m points' worth of precision.
    #[test]
    fn gauss_rules_are_exact_to_degree_2m_minus_1() {
        for r in &PieceQuadrature::shared().rules {
            let m = r.m as i32;
            for k in 0..2 * m {
                let want = 1.0 / (k + 1) as f64;
                let got = integrate(r, |u, _| u.powi(k));
                assert!(
                    (got - want).abs() <= 1e-15 * want.max(1.0) * 4.0,
                    "m = {m}, u^{k}: {got}"
                );
                let got = integrate(r, |_, v| v.powi(k));
                assert!(
                    (got - want).abs() <= 1e-15 * want.max(1.0) * 4.0,
                    "m = {m}, (1 − u)^{k}: {got}"
                );
            }
            let k = 2 * m;
            let got = integrate(r, |u, _| u.powi(k));
            if m <= 10 {
                assert!(
                    (got - 1.0 / (k + 1) as f64).abs() > 1e-13,
                    "m = {m}, u^{k} exact"
                );
            }
        }
    }

    /// The depth up to which each rule is used meets the error bound, with fewer nodes it would
    /// not, and the rules cover depths in increasing order.
    #[test]
    fn gauss_rules_meet_their_bound() {
        let mut prev = (0, 0.0);
        for &(m, g) in &RULES {
            let b = rel_error_bound(m, g);
            assert!(b <= REL_ERROR, "{m} nodes up to G = {g}: bound {b:e}");
            assert!(
                rel_error_bound(m - 1, g) > REL_ERROR,
                "{m} nodes: {} would do",
                m - 1
            );
            assert!(m > prev.0 && g > prev.1, "rules out of order at {m}");
            prev = (m, g);
        }
    }

    /// `1 − Ψ` and `Ψ − ζ` by the rules agree with Ψ's own evaluation (`psi_terms_ends`:
    /// `expm1` integrands on one 10-point panel, or Ψ on panels) within the bound, relative to
    /// α, across every rule's band and at its ends, for end depths of every ratio (one of them
    /// 0 included); and the pieces beyond the rules, and the degenerate ones, are left to it.
    #[test]
    fn quadrature_terms_match_psi_within_the_bound() {
        let q = PieceQuadrature::shared();
        let mut seed = 0x5555_aaaa_1234_5678u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        let mut lo = 1e-300;
        for &(m, hi) in &RULES {
            for i in 0..400 {
                let g = match i {
                    0 => hi,
                    1 => lo,
                    _ => lo * (hi / lo).powf(next()),
                };
                let r = match i % 4 {
                    0 => 0.0,
                    1 => 1.0,
                    _ => next(),
                };
                let (fa, fb) = (2.0 * g * r, 2.0 * g * (1.0 - r));
                let Some((a, b)) = q.terms(fa, fb) else {
                    panic!("{m} nodes: ({fa}, {fb}) not covered");
                };
                let t = psi_terms_ends(fa, fb);
                let e = ((a - t.one_minus_psi).abs()).max((b - t.psi_minus_zeta).abs()) / t.alpha;
                worst = worst.max(e);
                // The bound, and Ψ's own error (~1e-15 relative on each term).
                assert!(
                    e <= REL_ERROR + 1e-14,
                    "{m} nodes, ({fa:e}, {fb:e}): {e:e} of α"
                );
            }
            lo = hi;
        }
        println!("quadrature against psi_terms_ends: worst {worst:.3e} of α");
        let last = RULES[RULES.len() - 1].1;
        for (fa, fb) in [
            (0.0, 0.0),
            (2.0 * last, 2.0 * last),
            (f64::INFINITY, 0.0),
            (f64::NAN, 1.0),
            (-1.0, 0.5),
        ] {
            assert!(q.terms(fa, fb).is_none(), "({fa}, {fb}) covered");
        }
    }
}
