//! Analytic scalar fields, evaluated at world positions (the generators place their meshes in or
//! around the cube `[-1, 1]³`, the domain these fields are designed for).
//!
//! | field | formula |
//! | --- | --- |
//! | [`marschner_lobb`] | `ρ(x,y,z) = (1 − sin(πz/2) + α(1 + ρ_r(√(x²+y²)))) / (2(1 + α))`, `ρ_r(r) = cos(2π f_M cos(πr/2))`, `f_M = 6`, `α = 0.25` (Marschner & Lobb 1994); range [0, 1] on `[-1,1]³` |
//! | [`gaussians`] | `Σ_i a_i exp(−‖p − c_i‖² / (2σ_i²))` over a list of [`Gaussian`]s |
//! | [`spherical_shell`] | `exp(−(‖p − c‖ − R)² / (2w²))`: 1 on the sphere of radius `R`, falling off over `w` |
//! | [`fuel`] | smooth jets: `Σ_j exp(−d_j² / (2 w_j(t)²)) · (1 − 0.6 t)` for jets from nozzles on the plane `z = −1` pointing along `a_j`; `t ∈ [0, 1]` is the distance along the jet (0 outside the jet's length), `d_j` the distance to the jet's axis, `w_j(t) = 0.06 + 0.18 t` (the jet widens and fades) |

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Marschner–Lobb frequency `f_M` (standard value).
pub const ML_FM: f64 = 6.0;
/// Marschner–Lobb modulation `α` (standard value).
pub const ML_ALPHA: f64 = 0.25;

/// The Marschner–Lobb test signal with the standard parameters `f_M = 6`, `α = 0.25`.
pub fn marschner_lobb(p: DVec3) -> f64 {
    marschner_lobb_with(p, ML_FM, ML_ALPHA)
}

/// The Marschner–Lobb test signal with explicit parameters.
pub fn marschner_lobb_with(p: DVec3, fm: f64, alpha: f64) -> f64 {
    use std::f64::consts::PI;
    let r = (p.x * p.x + p.y * p.y).sqrt();
    let rho_r = (2.0 * PI * fm * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * p.z / 2.0).sin() + alpha * (1.0 + rho_r)) / (2.0 * (1.0 + alpha))
}

/// One term of [`gaussians`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gaussian {
    pub center: DVec3,
    pub sigma: f64,
    pub amplitude: f64,
}

/// A sum of isotropic Gaussians.
pub fn gaussians(p: DVec3, terms: &[Gaussian]) -> f64 {
    terms
        .iter()
        .map(|g| g.amplitude * (-(p - g.center).length_squared() / (2.0 * g.sigma * g.sigma)).exp())
        .sum()
}

/// `n` Gaussians with centres in `[-0.7, 0.7]³`, widths in [0.08, 0.3] and amplitudes in
/// [0.3, 1], drawn from a PCG64 seeded with `seed`.
pub fn random_gaussians(n: usize, seed: u64) -> Vec<Gaussian> {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x6761_7573_7369_616e);
    (0..n)
        .map(|_| Gaussian {
            center: DVec3::new(
                rng.random_range(-0.7..0.7),
                rng.random_range(-0.7..0.7),
                rng.random_range(-0.7..0.7),
            ),
            sigma: rng.random_range(0.08..0.3),
            amplitude: rng.random_range(0.3..1.0),
        })
        .collect()
}

/// A spherical shell of radius `radius` and width `width` around `center`.
pub fn spherical_shell(p: DVec3, center: DVec3, radius: f64, width: f64) -> f64 {
    let d = (p - center).length() - radius;
    (-d * d / (2.0 * width * width)).exp()
}

/// A fuel-injection-like field: jets from nozzles on the plane `z = -1` (see the module table).
pub fn fuel(p: DVec3) -> f64 {
    // Nozzle position, direction (normalised below), length.
    const JETS: [([f64; 3], [f64; 3], f64); 4] = [
        ([0.0, 0.0, -1.0], [0.0, 0.0, 1.0], 1.9),
        ([0.35, 0.0, -1.0], [0.25, 0.05, 1.0], 1.6),
        ([-0.3, 0.2, -1.0], [-0.2, 0.2, 1.0], 1.5),
        ([0.0, -0.35, -1.0], [0.05, -0.3, 1.0], 1.4),
    ];
    JETS.iter()
        .map(|&(o, a, len)| {
            let o = DVec3::from_array(o);
            let a = DVec3::from_array(a).normalize();
            let along = (p - o).dot(a);
            if along < 0.0 || along > len {
                return 0.0;
            }
            let t = along / len;
            let d2 = (p - o - along * a).length_squared();
            let w = 0.06 + 0.18 * t;
            (-d2 / (2.0 * w * w)).exp() * (1.0 - 0.6 * t)
        })
        .sum()
}

/// Evaluates `f` at every position, in parallel.
pub fn sample(positions: &[DVec3], f: impl Fn(DVec3) -> f64 + Sync) -> Vec<f64> {
    positions.par_iter().map(|&p| f(p)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marschner_lobb_values() {
        // At the origin: r = 0, ρ_r = cos(2π·6) = 1, sin 0 = 0 → (1 + 0.25·2) / 2.5 = 0.6.
        assert!((marschner_lobb(DVec3::ZERO) - 0.6).abs() < 1e-12);
        // At z = 1 the sin term is 1: (0.25(1 + ρ_r)) / 2.5 ∈ [0, 0.2].
        let v = marschner_lobb(DVec3::new(0.3, 0.2, 1.0));
        assert!((0.0..=0.2).contains(&v));
    }

    #[test]
    fn other_fields() {
        assert!((spherical_shell(DVec3::X * 0.5, DVec3::ZERO, 0.5, 0.1) - 1.0).abs() < 1e-12);
        let g = random_gaussians(3, 7);
        assert_eq!(g, random_gaussians(3, 7));
        assert!(gaussians(g[0].center, &g) >= g[0].amplitude);
        assert!(fuel(DVec3::new(0.0, 0.0, -0.5)) > 0.5);
        assert!(fuel(DVec3::new(0.9, 0.9, -0.5)) < 1e-6);
    }
}
