//! The named generators: lattices, shapes with holes, paper-sized analogues and the
//! time-varying Gaussian (the hard cases are in [`crate::hard`]).

use std::f64::consts::PI;

use algorithms::mesh::Field;
use algorithms::{Mesh, Result};
use glam::{DVec2, DVec3};

use crate::fields::{self, Gaussian};
use crate::grid::{
    bcc_boundary_faces, bcc_lattice, bcc_num_tets, cc_lattice, Lattice, Split, LATTICE_KEY,
};
use crate::irregular::{
    annulus, cube_shell_to_sphere_shell, cube_to_ball, graded, graded_middle, sine_warp,
    square_to_disk, torus,
};
use crate::recipe::{fit_cells, fit_dims, lin, Recipe};
use crate::Generated;

/// `[0, 1]³ → [-1, 1]³`.
fn to_box(p: DVec3) -> DVec3 {
    2.0 * p - DVec3::ONE
}

/// Builds the mesh (one field) from positions, tets and a scalar function.
pub(crate) fn finish(
    name: &str,
    positions: Vec<DVec3>,
    tets: Vec<[u32; 4]>,
    field: &str,
    f: impl Fn(DVec3) -> f64 + Sync,
) -> Result<Mesh> {
    let s = fields::sample(&positions, f);
    Mesh::with_scalars(name, positions, tets, field, s)
}

/// Builds `recipe` for about `tets` tets (jitter from `seed`) and samples one field on it.
fn from_recipe(
    name: &str,
    recipe: &Recipe,
    tets: usize,
    seed: u64,
    field: &str,
    f: impl Fn(DVec3) -> f64 + Sync,
) -> Result<Generated> {
    let plan = recipe.build(tets, seed);
    let b = plan.built;
    let m = finish(name, b.positions, b.tets, field, f)?;
    Ok(Generated::new(m, Some(plan.expected_boundary)))
}

/// Boundary faces of a full cube lattice: two triangles per cell face on the box.
pub fn box_boundary(l: &Lattice) -> usize {
    let [cx, cy, cz] = l.n.map(|n| n - 1);
    4 * (cx * cy + cy * cz + cz * cx)
}

fn with_lattice(mut mesh: Mesh, lattice: &Lattice) -> Mesh {
    mesh.field_data
        .insert(LATTICE_KEY.to_string(), lattice.to_field_data());
    mesh
}

/// A cube lattice over `[-1, 1]³` with about `tets` tets (cells per axis fitted; the spacing may
/// differ slightly between axes).
pub fn cc_box(tets: usize, split: Split) -> (crate::grid::Built, Lattice) {
    let cells = fit_cells(tets, split, [1.0, 1.0, 1.0], false, 1.0);
    let spacing = DVec3::new(
        2.0 / cells[0] as f64,
        2.0 / cells[1] as f64,
        2.0 / cells[2] as f64,
    );
    cc_lattice(cells, split, DVec3::splat(-1.0), spacing)
}

/// A BCC lattice over `[-1, 1]³` (primary grid) with about `tets` tets.
pub fn bcc_box(tets: usize) -> (Vec<DVec3>, Vec<[u32; 4]>, Lattice) {
    let n = fit_dims(tets as f64, [1.0, 1.0, 1.0], 2, false, &|n| {
        bcc_num_tets(n) as f64
    });
    let spacing = DVec3::new(
        2.0 / (n[0] - 1) as f64,
        2.0 / (n[1] - 1) as f64,
        2.0 / (n[2] - 1) as f64,
    );
    bcc_lattice(n, DVec3::splat(-1.0), spacing)
}

/// A [`cc_box`] lattice with one field, carrying its lattice description.
fn cc_case(
    name: &str,
    tets: usize,
    split: Split,
    field: &str,
    f: impl Fn(DVec3) -> f64 + Sync,
) -> Result<Generated> {
    let (b, l) = cc_box(tets, split);
    let m = finish(name, b.positions, b.tets, field, f)?;
    Ok(Generated::new(with_lattice(m, &l), Some(box_boundary(&l))))
}

/// Primary spacing of the BCC lattice that carries the same spectrum as a cube lattice of
/// spacing `h_cc`: `√2·h_cc` (2 samples per `(√2 h)³`, i.e. `1/√2 ≈ 70.7 %` of the CC samples,
/// 29.3 % fewer).
pub fn bcc_spacing_for_cc(h_cc: f64) -> f64 {
    std::f64::consts::SQRT_2 * h_cc
}

/// Default size of `bcc`: the lattice with the information of the default `cc5`/`cc6`
/// (40 cells, 41 points per axis over `[-1, 1]³`): primary spacing `√2·(2/40)`, 29 points.
pub const BCC_DEFAULT_TETS: usize = 4 * 3 * 28 * 29 * 29;

pub fn gen_cc5(tets: usize, _seed: u64) -> Result<Generated> {
    cc_case(
        "cc5",
        tets,
        Split::Five,
        "marschner-lobb",
        fields::marschner_lobb,
    )
}

pub fn gen_cc6(tets: usize, _seed: u64) -> Result<Generated> {
    cc_case(
        "cc6",
        tets,
        Split::Six,
        "marschner-lobb",
        fields::marschner_lobb,
    )
}

pub fn gen_bcc(tets: usize, _seed: u64) -> Result<Generated> {
    let (p, t, l) = bcc_box(tets);
    let m = finish("bcc", p, t, "marschner-lobb", fields::marschner_lobb)?;
    Ok(Generated::new(
        with_lattice(m, &l),
        Some(bcc_boundary_faces(l.n)),
    ))
}

/// Solid torus (ring radius 0.7, tube 0.3) — a hole through it — Gaussian-sum field.
pub fn gen_torus(tets: usize, seed: u64) -> Result<Generated> {
    let warp = |p: DVec3| torus(p.x, 2.0 * p.y - 1.0, 2.0 * p.z - 1.0, 0.7, 0.3);
    let r = Recipe {
        periodic_x: true,
        aspect: [4.0, 1.0, 1.0],
        ..Recipe::new(Split::Six, &warp)
    };
    let g = fields::random_gaussians(6, seed);
    from_recipe("torus", &r, tets, seed, "gaussians", move |p| {
        fields::gaussians(p, &g)
    })
}

/// Spherical shell (radii 0.4 to 1): a cavity inside; spherical-shell field.
pub fn gen_shell(tets: usize, seed: u64) -> Result<Generated> {
    const A: f64 = 0.4;
    // Cube shells ‖q‖∞ = t → spheres of radius 0.4·t/A inside the hole (removed), then
    // linearly from 0.4 at t = A to 1 at t = 1: continuous and one-to-one.
    let warp = |p: DVec3| {
        let q = to_box(p);
        if q.abs().max_element() < A {
            cube_to_ball(q) * (0.4 / A)
        } else {
            cube_shell_to_sphere_shell(q, A, 0.4, 1.0)
        }
    };
    let hole = |q: DVec3| q.length() < 0.4;
    let r = Recipe {
        hole: Some(&hole),
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("shell", &r, tets, seed, "shell", |p| {
        fields::spherical_shell(p, DVec3::ZERO, 0.7, 0.1)
    })
}

/// Steps of `tv-gaussian`.
pub const TV_STEPS: usize = 16;

/// Step `k` of `steps` of the moving Gaussian: `exp(−‖p − c(k)‖² / (2·0.25²))` with centre
/// `c = (0.5 cos 2πτ, 0.5 sin 2πτ, 0.8 (τ − ½))`, `τ = k / steps`. Evaluate one step at a time
/// to stream a long sequence.
pub fn tv_gaussian_step(positions: &[DVec3], k: usize, steps: usize) -> Vec<f64> {
    let tau = k as f64 / steps.max(1) as f64;
    let g = [Gaussian {
        center: DVec3::new(
            0.5 * (2.0 * PI * tau).cos(),
            0.5 * (2.0 * PI * tau).sin(),
            0.8 * (tau - 0.5),
        ),
        sigma: 0.25,
        amplitude: 1.0,
    }];
    fields::sample(positions, |p| fields::gaussians(p, &g))
}

/// The `tv-gaussian` mesh: a `cc6` lattice over `[-1, 1]³` with field `gaussian` holding
/// [`TV_STEPS`] steps.
pub fn gen_tv_gaussian(tets: usize, _seed: u64) -> Result<Generated> {
    let (b, l) = cc_box(tets, Split::Six);
    let steps = (0..TV_STEPS)
        .map(|k| tv_gaussian_step(&b.positions, k, TV_STEPS))
        .collect();
    let m = Mesh::new(
        "tv-gaussian",
        b.positions,
        b.tets,
        vec![Field {
            name: "gaussian".into(),
            steps,
        }],
    )?;
    Ok(Generated::new(with_lattice(m, &l), Some(box_boundary(&l))))
}

// ---------------------------------------------------------------------------------------------
// Paper-sized analogues.

/// A ball with a central cavity (cube shell 0.3 ≤ ‖q‖∞ ≤ 1 mapped to a ball), jittered.
fn spx_like(name: &str, tets: usize, seed: u64) -> Result<Generated> {
    let warp = |p: DVec3| cube_to_ball(to_box(p));
    let hole = |q: DVec3| q.length() < 0.3;
    let r = Recipe {
        hole: Some(&hole),
        jitter: 0.2,
        ..Recipe::new(Split::Five, &warp)
    };
    let g = fields::random_gaussians(8, seed);
    from_recipe(name, &r, tets, seed, "gaussians", move |p| {
        fields::gaussians(p, &g) + 0.5 * fields::spherical_shell(p, DVec3::ZERO, 0.3, 0.1)
    })
}

pub fn gen_spx(tets: usize, seed: u64) -> Result<Generated> {
    spx_like("spx", tets, seed)
}

pub fn gen_spx2(tets: usize, seed: u64) -> Result<Generated> {
    spx_like("spx2", tets, seed)
}

/// Gaussian tube around the segment from `a` to `b`, width `w`.
fn tube(p: DVec3, a: DVec3, b: DVec3, w: f64) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    let d2 = (p - a - t * ab).length_squared();
    (-d2 / (2.0 * w * w)).exp()
}

/// Delta wing: box with a thin triangular wing removed, graded towards the wing plane (100×),
/// curvilinear (sine warp); leading-edge vortex field.
pub fn gen_delta(tets: usize, seed: u64) -> Result<Generated> {
    let gz = |t: f64| graded_middle(t, 100.0);
    let warp = |p: DVec3| sine_warp(to_box(p), 0.04);
    let wing = |q: DVec3| {
        q.z.abs() < 0.025 && q.x > -0.6 && q.x < 0.5 && q.y.abs() < 0.6 * (q.x + 0.6) / 1.1
    };
    let r = Recipe {
        grading: [&lin, &lin, &gz],
        hole: Some(&wing),
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("delta", &r, tets, seed, "vorticity", |p| {
        let apex = DVec3::new(-0.6, 0.0, 0.05);
        tube(p, apex, DVec3::new(1.0, 0.5, 0.2), 0.06)
            + tube(p, apex, DVec3::new(1.0, -0.5, 0.2), 0.06)
    })
}

/// Torso: elliptic cylinder (square-to-disk cross-sections), jittered; "organ" Gaussians.
pub fn gen_torso(tets: usize, seed: u64) -> Result<Generated> {
    let warp = |p: DVec3| {
        let q = to_box(p);
        let d = square_to_disk(DVec2::new(q.x, q.y));
        DVec3::new(0.9 * d.x, 0.6 * d.y, q.z)
    };
    let r = Recipe {
        aspect: [1.5, 1.0, 1.7],
        jitter: 0.2,
        ..Recipe::new(Split::Five, &warp)
    };
    let mut g = fields::random_gaussians(5, seed);
    g.push(Gaussian {
        center: DVec3::new(0.15, 0.1, 0.2),
        sigma: 0.15,
        amplitude: 1.5,
    });
    from_recipe("torso", &r, tets, seed, "potential", move |p| {
        fields::gaussians(p, &g)
    })
}

/// Fighter in a wind tunnel: box graded towards the aircraft (10× per side), aircraft
/// (fuselage, swept wings, fin) removed, jittered.
pub fn gen_fighter(tets: usize, seed: u64) -> Result<Generated> {
    let gm = |t: f64| graded_middle(t, 10.0);
    let warp = |p: DVec3| to_box(p);
    let aircraft = |q: DVec3| {
        let fuselage = (q.x / 0.7).powi(2) + (q.y / 0.09).powi(2) + (q.z / 0.09).powi(2) < 1.0;
        let wing =
            q.z.abs() < 0.03 && q.x > -0.25 && q.x < 0.3 && q.y.abs() < 0.6 * (q.x + 0.25) / 0.55;
        let fin = q.y.abs() < 0.03
            && q.z > 0.0
            && q.z < 0.3
            && q.x > 0.35
            && q.x < 0.65 - 0.5 * (0.3 - q.z);
        fuselage || wing || fin
    };
    let r = Recipe {
        aspect: [1.2, 1.0, 0.8],
        grading: [&gm, &gm, &gm],
        hole: Some(&aircraft),
        jitter: 0.15,
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("fighter", &r, tets, seed, "pressure", |p| {
        let nose = DVec3::new(-0.7, 0.0, 0.0);
        (-(p - nose).length_squared() / 0.02).exp()
            + 0.6
                * tube(
                    p,
                    DVec3::new(0.3, 0.0, 0.0),
                    DVec3::new(1.0, 0.0, 0.05),
                    0.1,
                )
            + 0.2 * fields::marschner_lobb(p)
    })
}

/// Fuel injection: a `cc6` lattice (like the 64³ volume split into tets) with the jets field.
pub fn gen_fuel(tets: usize, _seed: u64) -> Result<Generated> {
    cc_case("fuel", tets, Split::Six, "fuel", fields::fuel)
}

/// Brain: ellipsoid (cube mapped to a ball) with two ventricle cavities, jittered.
pub fn gen_brain(tets: usize, seed: u64) -> Result<Generated> {
    let warp = |p: DVec3| cube_to_ball(to_box(p)) * DVec3::new(0.75, 0.95, 0.7);
    let ventricles = |q: DVec3| {
        [-0.18, 0.18].iter().any(|&cx| {
            ((q.x - cx) / 0.08).powi(2)
                + ((q.y - 0.05) / 0.35).powi(2)
                + ((q.z - 0.05) / 0.12).powi(2)
                < 1.0
        })
    };
    let r = Recipe {
        hole: Some(&ventricles),
        jitter: 0.2,
        ..Recipe::new(Split::Five, &warp)
    };
    let g = fields::random_gaussians(12, seed);
    from_recipe("brain", &r, tets, seed, "intensity", move |p| {
        fields::gaussians(p, &g) + 0.5 * fields::spherical_shell(p, DVec3::ZERO, 0.6, 0.08)
    })
}

/// Blunt fin: a half O-grid around a half-cylinder fin standing on a plate, radially graded
/// 100× towards the fin and 10× towards the plate; bow-shock density field.
pub fn gen_blunt_like(tets: usize, seed: u64) -> Result<Generated> {
    let gr = |t: f64| graded(t, 100.0);
    let gz = |t: f64| graded(t, 10.0);
    // Parameters: x = angle (half turn facing −x), y = radius, z = height.
    let warp = |p: DVec3| {
        let a = annulus(p.x, p.y, p.z, 0.15, 1.0, 0.5);
        // Rotate so the half ring faces −x: angle from π/2 to 3π/2.
        DVec3::new(-a.y, a.x, a.z)
    };
    let r = Recipe {
        aspect: [1.25, 1.0, 1.0],
        grading: [&lin, &gr, &gz],
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("blunt-like", &r, tets, seed, "density", |p| {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let shock = 0.45 + 0.25 * p.z;
        1.0 + 0.8 * 0.5 * (1.0 + ((shock - r) / 0.04).tanh()) + 0.3 * (-(r - 0.15) / 0.05).exp()
    })
}

/// Combustion chamber: a tube along x whose radius bulges (not concave: non-convex),
/// square-to-disk cross-sections; jets field along the tube.
pub fn gen_comb_like(tets: usize, seed: u64) -> Result<Generated> {
    let warp = |p: DVec3| {
        let d = square_to_disk(DVec2::new(2.0 * p.y - 1.0, 2.0 * p.z - 1.0));
        let radius = 0.35 + 0.2 * (1.0 - (2.0 * PI * p.x).cos());
        DVec3::new(2.0 * p.x - 1.0, radius * d.x, radius * d.y)
    };
    let r = Recipe {
        aspect: [1.75, 1.0, 0.75],
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("comb-like", &r, tets, seed, "density", |p| {
        // The fuel jets, turned to run along +x.
        fields::fuel(DVec3::new(p.y, p.z, p.x))
    })
}

/// Post: a full O-grid (periodic angle) around a cylinder, radially graded 100×; velocity
/// magnitude of potential flow past the cylinder plus a wake.
pub fn gen_post_like(tets: usize, seed: u64) -> Result<Generated> {
    const A: f64 = 0.12;
    let gr = |t: f64| graded(t, 100.0);
    let warp = |p: DVec3| annulus(p.x, p.y, p.z - 0.5, A, 1.0, 1.0);
    let r = Recipe {
        periodic_x: true,
        aspect: [2.0, 1.0, 1.0],
        grading: [&lin, &gr, &lin],
        ..Recipe::new(Split::Five, &warp)
    };
    from_recipe("post-like", &r, tets, seed, "velocity", |p| {
        let r2 = (p.x * p.x + p.y * p.y).max(A * A);
        let th = p.y.atan2(p.x);
        let a2 = A * A / r2;
        let speed = (1.0 + a2 * a2 - 2.0 * a2 * (2.0 * th).cos())
            .max(0.0)
            .sqrt();
        let wake = if p.x > 0.0 {
            0.5 * (-(p.y * p.y) / (0.02 + 0.05 * p.x)).exp() * (3.0 * PI * p.x).sin().abs()
        } else {
            0.0
        };
        speed * (1.0 - wake) * (1.0 + 0.1 * p.z)
    })
}
