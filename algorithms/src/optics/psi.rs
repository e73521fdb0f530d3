//! Ψ, the integral of partial pre-integration, and its cancellation-free companions, evaluated
//! to ~1e-12 (`exact` reads them), and [`PsiTable`], Ψ tabulated for `partial` and the GPU.
//!
//! Notation (CONVENTIONS §4, `partial` row, and the optics module's docs): `Ψ(a, b) = ∫₀¹
//! exp(−a·u − b·u²) du`, computed from the end depths `fa = τ_f·l`, `fb = τ_b·l`.

use std::sync::{Arc, OnceLock};

use rayon::prelude::*;

/// The quantities of one linear piece, all in `[0, 1]`: `psi = Ψ`, `one_minus_psi = 1 − Ψ`,
/// `psi_minus_zeta = Ψ − ζ`, `zeta = ζ = exp(−g(1))`, `alpha = 1 − ζ`. Each is computed to full
/// relative precision on its own (not as a difference of the others where that would cancel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsiTerms {
    pub psi: f64,
    pub one_minus_psi: f64,
    pub psi_minus_zeta: f64,
    pub zeta: f64,
    pub alpha: f64,
}

/// Positive nodes of 10-point Gauss–Legendre on [−1, 1] (Abramowitz & Stegun, table 25.4); the
/// rule is symmetric. Checked by the test `gauss_legendre_is_exact_to_degree_19`.
#[allow(clippy::excessive_precision)]
pub(super) const GL_X: [f64; 5] = [
    0.148874338981631210884826001130,
    0.433395394129247190799265943166,
    0.679409568299024406234327365115,
    0.865063366688984510732096688423,
    0.973906528517171720077964012084,
];
#[allow(clippy::excessive_precision)]
pub(super) const GL_W: [f64; 5] = [
    0.295524224714752870173892994651,
    0.269266719309996355091226921569,
    0.219086362515982043995534934228,
    0.149451349150580593145776339658,
    0.066671344308688137593568809893,
];

/// `∫_{u0}^{u1} f(u) du` by 10-point Gauss–Legendre. `f` receives `u` and `1 − u` (the latter
/// formed from the panel's own end, so it keeps its relative precision near `u = 1`).
#[inline]
pub(super) fn gl10(u0: f64, u1: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
    let c = 0.5 * (u0 + u1);
    let h = 0.5 * (u1 - u0);
    let cm = 0.5 * ((1.0 - u0) + (1.0 - u1));
    let mut s = 0.0;
    for k in 0..5 {
        let d = h * GL_X[k];
        s += GL_W[k] * (f(c - d, cm + d) + f(c + d, cm - d));
    }
    s * h
}

/// Optical depth from the front, `g(u) = a·u + b·u² = u·(fa·(2 − u) + fb·u)/2` (sum of
/// non-negative terms for `u ∈ [0, 1]`).
#[inline]
pub(super) fn depth(fa: f64, fb: f64, u: f64) -> f64 {
    0.5 * u * (fa * (2.0 - u) + fb * u)
}

/// Optical depth to the back, `g(1) − g(u) = (1 − u)·(fa·(1 − u) + fb·(1 + u))/2`, from `v = 1 − u`.
#[inline]
pub(super) fn depth_to_back(fa: f64, fb: f64, u: f64, v: f64) -> f64 {
    0.5 * v * (fa * v + fb * (1.0 + u))
}

/// Largest change of `g` over one quadrature panel. With 10-point Gauss–Legendre the panel's
/// integrand `exp(−g)` is then integrated to ~4e-15 relative (measured: 1.3e-14 at 2, 1.6e-12 at 3,
/// 5e-11 at 4).
pub(super) const PANEL_DG: f64 = 1.5;
/// Up to this `g(1)` the expm1 forms for `1 − Ψ` and `Ψ − ζ` are integrated on one panel; beyond
/// it `Ψ ≤ 0.68` and `ζ/Ψ ≤ 0.7`, so `1 − Ψ` and `Ψ − ζ` lose at most two bits.
pub(super) const SMALL_G: f64 = 1.5;

/// `Ψ = ∫₀¹ exp(−g(u)) du` for end depths `fa, fb ≥ 0` with `0 < g(1) < ∞`.
///
/// Panels are placed where `g` has grown by [`PANEL_DG`] (inverting the quadratic `g(u) = v`), so
/// every panel is integrated to full relative precision whatever the scale of `a`, `b`; the
/// integrand is monotone decreasing (`g' = τl ≥ 0`), and the tail beyond a panel end `u₁` is at
/// most `(1 − u₁)·exp(−g(u₁))`, so integration stops once that is below 1e-18 of the sum.
///
/// A huge front depth (τ ≥ 1e30 gives `fa` ≥ 1e25 at every tabled length) takes ~28 panels
/// that way; there the integrand is gone within `u ~ 1/fa`, where the quadratic term is
/// negligible, and with `x = fa·u`, `β = b/fa² = (fb − fa)/(2fa²)`:
/// `Ψ = (1/fa)·∫₀^fa e^{−x − βx²} dx = (1/fa)·(1 − 2β + 12β² − O(β³)) − O(e^{−fa})` (from
/// `∫₀^∞ x^{2k} e^{−x} dx = (2k)!`). For `fa ≥ 1e4` and `|β| ≤ 1e-10` the dropped terms are below
/// 1e-20 relative, so that closed form is used (it made `preint` with τ = 1e30 take seconds).
pub(super) fn psi_panels(fa: f64, fb: f64) -> f64 {
    if fa >= 1e4 {
        let beta = (fb - fa) / (2.0 * fa) / fa;
        if beta.abs() <= 1e-10 {
            return (1.0 - 2.0 * beta + 12.0 * beta * beta) / fa;
        }
    }
    psi_panels_dg(fa, fb, PANEL_DG)
}
pub(super) fn psi_panels_dg(fa: f64, fb: f64, dg: f64) -> f64 {
    let g_end = 0.5 * (fa + fb);
    let integrand = |u: f64, _v: f64| (-depth(fa, fb, u)).exp();
    if g_end <= dg {
        return gl10(0.0, 1.0, integrand);
    }
    // Solve b·u² + a·u − v = 0 for the root in [0, 1] in the stable form
    // u = 2v / (a + sqrt(a² + 4bv)), everything scaled by m = max(fa, fb) against overflow.
    let m = fa.max(fb);
    let (fa_m, fb_m) = (fa / m, fb / m);
    let inv = |v: f64| -> f64 {
        let vm = v / m;
        let disc = (fa_m * fa_m + 2.0 * (fb_m - fa_m) * vm).max(0.0);
        (2.0 * vm / (fa_m + disc.sqrt())).min(1.0)
    };
    let mut sum = 0.0;
    let (mut u0, mut v0) = (0.0, 0.0);
    loop {
        let v1 = v0 + dg;
        let last = v1 >= g_end;
        let u1 = if last { 1.0 } else { inv(v1).max(u0) };
        sum += gl10(u0, u1, integrand);
        // Tail bound: g' = fa·(1 − u) + fb·u is linear, so beyond u₁ it is at least
        // min(g'(u₁), fb) and the tail is ≤ exp(−v₁)·min(1 − u₁, 1/min(g'(u₁), fb)). Without the
        // second term, huge depths (Ψ ≈ 1e-300) needed ~500 panels instead of ~30.
        let slope = (fa * (1.0 - u1) + fb * u1).min(fb);
        let tail_len = if slope > 0.0 {
            (1.0 - u1).min(1.0 / slope)
        } else {
            1.0 - u1
        };
        // exp(−v) underflows to 0 for v > 745, so the cap also guarantees termination.
        if last || u1 >= 1.0 || (-v1).exp() * tail_len <= 1e-18 * sum || v1 > 800.0 {
            break;
        }
        u0 = u1;
        v0 = v1;
    }
    sum
}

/// All the Ψ quantities of one linear piece from its end optical depths `tau_f_l = τ_f·l` and
/// `tau_b_l = τ_b·l` (negative values are clamped to 0; `+∞` is allowed).
///
/// For `g(1) ≤ 1.5` the differences are integrated directly (no cancellation at any scale, e.g.
/// τl = 1e-300):
/// `1 − Ψ = ∫₀¹ −expm1(−g(u)) du` and `Ψ − ζ = ζ·∫₀¹ expm1(g(1) − g(u)) du`, and `Ψ = ζ + (Ψ − ζ)`
/// (a sum of positives). Beyond, Ψ comes from [`psi_panels`] and the differences are formed.
pub fn psi_terms_ends(tau_f_l: f64, tau_b_l: f64) -> PsiTerms {
    if tau_f_l.is_nan() || tau_b_l.is_nan() {
        let n = f64::NAN;
        return PsiTerms {
            psi: n,
            one_minus_psi: n,
            psi_minus_zeta: n,
            zeta: n,
            alpha: n,
        };
    }
    let (fa, fb) = (tau_f_l.max(0.0), tau_b_l.max(0.0));
    let g_end = 0.5 * (fa + fb);
    if g_end == 0.0 {
        return PsiTerms {
            psi: 1.0,
            one_minus_psi: 0.0,
            psi_minus_zeta: 0.0,
            zeta: 1.0,
            alpha: 0.0,
        };
    }
    if g_end.is_infinite() {
        // Any infinite end depth makes g(u) infinite for every u > 0.
        return PsiTerms {
            psi: 0.0,
            one_minus_psi: 1.0,
            psi_minus_zeta: 0.0,
            zeta: 0.0,
            alpha: 1.0,
        };
    }
    let zeta = (-g_end).exp();
    let alpha = -(-g_end).exp_m1();
    if g_end <= SMALL_G {
        let one_minus_psi = gl10(0.0, 1.0, |u, _| -(-depth(fa, fb, u)).exp_m1());
        let psi_minus_zeta = zeta * gl10(0.0, 1.0, |u, v| depth_to_back(fa, fb, u, v).exp_m1());
        PsiTerms {
            psi: zeta + psi_minus_zeta,
            one_minus_psi,
            psi_minus_zeta,
            zeta,
            alpha,
        }
    } else {
        let psi = psi_panels(fa, fb).clamp(zeta, 1.0);
        PsiTerms {
            psi,
            one_minus_psi: 1.0 - psi,
            psi_minus_zeta: psi - zeta,
            zeta,
            alpha,
        }
    }
}

/// The end depths `(fa, fb) = (a, a + 2b)` of `Ψ(a, b)`, clamped onto the domain `a ≥ 0`,
/// `a + 2b ≥ 0`.
#[inline]
pub(super) fn ends(a: f64, b: f64) -> (f64, f64) {
    (a.max(0.0), (a + 2.0 * b).max(0.0))
}

/// `Ψ(a, b) = ∫₀¹ exp(−a·u − b·u²) du` (Moreland & Angel 2004, partial pre-integration), for
/// `a = τ_f·l ≥ 0` and `a + 2b = τ_b·l ≥ 0` (`b` may be negative). Relative error ~1e-15 over the
/// whole domain (tiny, huge and mixed scales); arguments outside the domain are clamped onto it.
pub fn psi(a: f64, b: f64) -> f64 {
    let (fa, fb) = ends(a, b);
    psi_of_ends(fa, fb)
}

/// Ψ from end depths only (what the table stores); cheaper than [`psi_terms_ends`].
pub(super) fn psi_of_ends(fa: f64, fb: f64) -> f64 {
    if fa.is_nan() || fb.is_nan() {
        return f64::NAN;
    }
    let g_end = 0.5 * (fa + fb);
    if g_end == 0.0 {
        1.0
    } else if g_end.is_infinite() {
        0.0
    } else if g_end <= SMALL_G {
        // Ψ ≥ e^{−1.5} here, so 1 − (1 − Ψ) keeps full relative precision (and is exactly 1 when
        // the depths are negligible, where summing the Gauss weights would not be).
        let zeta = (-g_end).exp();
        (1.0 - gl10(0.0, 1.0, |u, _| -(-depth(fa, fb, u)).exp_m1())).clamp(zeta, 1.0)
    } else {
        psi_panels(fa, fb)
    }
}

/// `1 − Ψ(a, b)`, computed without cancellation (see [`psi_terms_ends`]).
pub fn one_minus_psi(a: f64, b: f64) -> f64 {
    let (fa, fb) = ends(a, b);
    psi_terms_ends(fa, fb).one_minus_psi
}

/// `Ψ(a, b) − ζ`, `ζ = exp(−a − b)`, computed without cancellation (see [`psi_terms_ends`]).
pub fn psi_minus_zeta(a: f64, b: f64) -> f64 {
    let (fa, fb) = ends(a, b);
    psi_terms_ends(fa, fb).psi_minus_zeta
}

// ---------------------------------------------------------------------------------------------
// Ψ table (partial pre-integration)
// ---------------------------------------------------------------------------------------------

/// `γ = x/(1 + x)` mapping an optical depth `x ∈ [0, ∞]` to `[0, 1]` (Moreland & Angel 2004).
#[inline]
pub fn gamma_of_depth(x: f64) -> f64 {
    if x.is_infinite() {
        1.0
    } else {
        x / (1.0 + x)
    }
}

/// Inverse of [`gamma_of_depth`]: `x = γ/(1 − γ)` (`∞` at `γ = 1`).
#[inline]
pub fn depth_of_gamma(g: f64) -> f64 {
    if g >= 1.0 {
        f64::INFINITY
    } else {
        g / (1.0 - g)
    }
}

/// Ψ tabulated for partial pre-integration (Moreland & Angel 2004).
///
/// Layout: `size() × size()` `f32`, row-major, `data()[j·N + i] = Ψ` at `γ_f = i/(N − 1)`,
/// `γ_b = j/(N − 1)`, where `γ = τl/(1 + τl)` of the front (`i`, fastest) and back (`j`) end of the
/// piece. The row and column `γ = 1` (infinite depth) hold 0. Lookup is bilinear (a 2-D texture
/// with linear filtering and texel centres at `(i + 0.5)/N` gives the same values).
/// Every entry is computed by this module's [`psi`].
#[derive(Clone, Debug)]
pub struct PsiTable {
    n: usize,
    data: Vec<f32>,
}

/// Worst error of a table against the function it tabulates, over a dense sample of its domain.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TableError {
    pub max_abs: f64,
    /// Largest `|table − exact| / exact` over samples with `exact > 0`.
    pub max_rel: f64,
    /// Where `max_abs` and `max_rel` occur (table coordinates, e.g. `[γ_f, γ_b]`).
    pub at_abs: [f64; 2],
    pub at_rel: [f64; 2],
    pub samples: usize,
}

impl PsiTable {
    pub const DEFAULT_SIZE: usize = 512;

    /// The heap bytes of an `n × n` table (`n ≥ 2`), without building one.
    pub const fn heap_bytes(n: usize) -> usize {
        n * n * std::mem::size_of::<f32>()
    }

    /// Builds an `n × n` table (`n` is raised to at least 2).
    pub fn new(n: usize) -> PsiTable {
        let n = n.max(2);
        let step = 1.0 / (n - 1) as f64;
        let mut data = vec![0f32; n * n];
        data.par_chunks_mut(n).enumerate().for_each(|(j, row)| {
            let fb = depth_of_gamma(j as f64 * step);
            for (i, v) in row.iter_mut().enumerate() {
                let fa = depth_of_gamma(i as f64 * step);
                *v = psi_of_ends(fa, fb) as f32;
            }
        });
        PsiTable { n, data }
    }

    /// The default 512² table, built once per process and shared.
    pub fn shared() -> Arc<PsiTable> {
        static TABLE: OnceLock<Arc<PsiTable>> = OnceLock::new();
        TABLE
            .get_or_init(|| Arc::new(PsiTable::new(Self::DEFAULT_SIZE)))
            .clone()
    }

    /// N, the table is N × N.
    pub fn size(&self) -> usize {
        self.n
    }

    /// The raw table (layout in the type's documentation).
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Bilinear lookup at `(γ_f, γ_b)` (clamped to `[0, 1]`).
    #[inline]
    pub fn lookup_gamma(&self, gf: f64, gb: f64) -> f64 {
        let n = self.n;
        let m = (n - 1) as f64;
        let coord = |g: f64| -> (usize, f64) {
            let x = if g.is_nan() {
                0.0
            } else {
                g.clamp(0.0, 1.0) * m
            };
            // x ∈ [0, n − 1]: truncation is `floor` (the same bits), without its libm call on
            // targets without SSE4.1's `roundsd`.
            let i = (x as usize).min(n - 2);
            (i, x - i as f64)
        };
        let (i, ti) = coord(gf);
        let (j, tj) = coord(gb);
        let d = &self.data;
        let v00 = d[j * n + i] as f64;
        let v10 = d[j * n + i + 1] as f64;
        let v01 = d[(j + 1) * n + i] as f64;
        let v11 = d[(j + 1) * n + i + 1] as f64;
        let v0 = v00 + (v10 - v00) * ti;
        let v1 = v01 + (v11 - v01) * ti;
        v0 + (v1 - v0) * tj
    }

    /// Ψ for the end optical depths `τ_f·l`, `τ_b·l` (≥ 0).
    #[inline]
    pub fn lookup(&self, tau_f_l: f64, tau_b_l: f64) -> f64 {
        self.lookup_gamma(gamma_of_depth(tau_f_l), gamma_of_depth(tau_b_l))
    }

    /// Worst absolute and relative error of the table against [`psi`] over a
    /// `samples × samples` grid of cell-interior points `γ = (k + 0.5)/samples·γ_max` covering
    /// `[0, γ_max]²` (`γ_max = 1` is the whole domain; relative error near `γ = 1`, where Ψ → 0,
    /// is large by nature, so a smaller `γ_max` reports the useful range separately).
    pub fn error_report(&self, samples: usize, gamma_max: f64) -> TableError {
        let samples = samples.max(1);
        let gmax = gamma_max.clamp(0.0, 1.0);
        let g = |k: usize| (k as f64 + 0.5) / samples as f64 * gmax;
        let worst = (0..samples)
            .into_par_iter()
            .map(|j| {
                let gb = g(j);
                let fb = depth_of_gamma(gb);
                let mut e = TableError::default();
                for i in 0..samples {
                    let gf = g(i);
                    let exact = psi_of_ends(depth_of_gamma(gf), fb);
                    let abs = (self.lookup_gamma(gf, gb) - exact).abs();
                    if abs > e.max_abs {
                        e.max_abs = abs;
                        e.at_abs = [gf, gb];
                    }
                    if exact > 0.0 && abs / exact > e.max_rel {
                        e.max_rel = abs / exact;
                        e.at_rel = [gf, gb];
                    }
                }
                e
            })
            .reduce(TableError::default, |a, b| TableError {
                max_abs: a.max_abs.max(b.max_abs),
                max_rel: a.max_rel.max(b.max_rel),
                at_abs: if a.max_abs >= b.max_abs {
                    a.at_abs
                } else {
                    b.at_abs
                },
                at_rel: if a.max_rel >= b.max_rel {
                    a.at_rel
                } else {
                    b.at_rel
                },
                samples: 0,
            });
        TableError {
            samples: samples * samples,
            ..worst
        }
    }
}
