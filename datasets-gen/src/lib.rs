//! Synthetic tetrahedral meshes for tetbench: lattices (`cc5`, `cc6`, `bcc`), irregular meshes
//! made from lattices without a mesher (curvilinear warps, orientation-preserving jitter, graded
//! spacing, holes), analogues of the papers' datasets at their tet counts, hard cases that break
//! renderers, and a time-varying field. Everything is deterministic for a given seed.
//!
//! The harness calls [`generate`] by name; [`generators`] lists the names, default sizes and
//! descriptions (what `datasets-gen --list` prints). Tet counts are within 3 % of the request
//! (the hard cases with a fixed structure — e.g. `hard-cycle`, 3 tets per pinwheel — round to
//! their unit).
//!
//! # Lattice description (`mesh.field_data["lattice"]`)
//!
//! Lattice meshes (`cc5`, `cc6`, `bcc`, `fuel`, `tv-gaussian`, and the plain-lattice hard cases
//! `hard-axis-aligned`, `hard-translated`, `hard-tiny`, `hard-scalar-range`, `hard-constant`)
//! carry ten numbers under the key `"lattice"`:
//!
//! ```text
//! [kind, nx, ny, nz, ox, oy, oz, hx, hy, hz]
//! ```
//!
//! - `kind`: 0 = `cc5`, 1 = `cc6`, 2 = `bcc`;
//! - `nx, ny, nz`: grid points per axis (for `bcc`, of the primary grid);
//! - `ox, oy, oz`: the position of grid point (0, 0, 0);
//! - `hx, hy, hz`: the spacing between neighbouring grid points along each axis.
//!
//! **CC (`cc5`, `cc6`)**: vertex `i + nx·(j + ny·k)` is at `o + h·(i, j, k)`. Cell
//! `c = i + cx·(j + cy·k)` (`cx = nx − 1`, …) owns tets `5c .. 5c+5` (`cc5`) or `6c .. 6c+6`
//! (`cc6`). Cell corners are numbered `q = x + 2y + 4z`; `cc6` splits every cell around the
//! diagonal 0–7 as (0,1,3,7) (0,3,2,7) (0,2,6,7) (0,6,4,7) (0,4,5,7) (0,5,1,7); `cc5` uses
//! (0,1,2,4) (1,3,2,7) (1,2,4,7) (1,5,7,4) (2,7,6,4) on cells with `i+j+k` even and the same
//! with every corner `q` replaced by `q ^ 1` (mirrored in x) on odd cells. Each tet's vertex
//! order is then fixed (last two swapped if needed) to be positively oriented.
//!
//! **BCC** (Delaunay tetrahedralization of the body-centred cubic lattice, BCC paper §4):
//! primary vertex `i + nx·(j + ny·k)` at `o + h·(i, j, k)` (`i < nx`, …) come first; then the
//! secondary points `o + h·(i − ½, j − ½, k − ½)` for `0 ≤ i ≤ nx`, `0 ≤ j ≤ ny`, `0 ≤ k ≤ nz`
//! in `i`-fastest order, leaving out the 8 corners of that grid (no tet uses them). The
//! secondary grid reaches half a cell beyond the primary box on every side, so every primary
//! edge has its octahedron. Every primary edge from `q` to `q + e_a` is the axis of an
//! octahedron with the four secondary points `q + ½e_a ± ½e_b ± ½e_c` (`b = a+1`, `c = a+2`
//! mod 3), split into 4 tets `[P(q), P(q+e_a), S_u, S_{u+1}]`, where `S_0..S_3` go around the
//! axis: `(b,c)` offsets `(−,−) (+,−) (+,+) (−,+)`; sub-tet `u` uses the secondary edge
//! `S_u–S_{u+1 mod 4}`. Each tet has two primary and two secondary samples, all of volume
//! `hx·hy·hz/12`; a traversal step of the primary grid (point `q`, edges along +x, +y, +z)
//! makes 12 tets. Tets are stored in three blocks, x-edges first, then y, then z; within the
//! block of axis `a` with `m = n − e_a` edges per axis, the tet of edge `q` and sub-tet `u` is
//! `offset_a + 4·(q_x + m_x·(q_y + m_y·q_z)) + u`, `offset_x = 0`,
//! `offset_y = 4(nx−1)·ny·nz`, `offset_z = offset_y + 4·nx·(ny−1)·nz`
//! ([`grid::bcc_tet_index`] computes it; [`grid::Lattice::from_field_data`] reads the
//! description back). The BCC lattice with the information content of a CC lattice of spacing
//! `h` has primary spacing `√2·h` ([`catalog::bcc_spacing_for_cc`]): 29.3 % fewer samples.
//!
//! # Fields
//!
//! See [`fields`] for the formulas (Marschner–Lobb with `f_M = 6`, `α = 0.25`; sums of
//! Gaussians; spherical shell; fuel-like jets). `tv-gaussian` holds [`catalog::TV_STEPS`] steps
//! of one field; [`catalog::tv_gaussian_step`] computes any one step on its own, for
//! streaming.

pub mod catalog;
pub mod fields;
pub mod grid;
pub mod hard;
pub mod irregular;
pub mod recipe;

use algorithms::{Error, Mesh, Result};

pub use catalog::{tv_gaussian_step, TV_STEPS};
pub use grid::{bcc_lattice, cc_lattice, Lattice, LatticeKind, Split, LATTICE_KEY};

/// A generated mesh with what its construction implies, for validation.
#[derive(Debug)]
pub struct Generated {
    pub mesh: Mesh,
    /// Boundary faces the construction implies, counted from its cells (or lattice structure),
    /// not from its tets: [`algorithms::mesh::Mesh::boundary_faces`] must agree when the tets
    /// conform.
    pub expected_boundary_faces: Option<usize>,
}

impl Generated {
    pub fn new(mesh: Mesh, expected_boundary_faces: Option<usize>) -> Generated {
        Generated {
            mesh,
            expected_boundary_faces,
        }
    }
}

/// A named generator.
#[derive(Clone, Copy, Debug)]
pub struct Generator {
    pub name: &'static str,
    /// Tets made when no size is given (the paper's count for the analogues).
    pub default_tets: usize,
    pub description: &'static str,
    /// For hard cases: what the mesh is built to break.
    pub breaks: Option<&'static str>,
    /// Builds the mesh: `(tets, seed)`.
    pub build: fn(usize, u64) -> Result<Generated>,
}

/// The seed of every generated mesh when none is given (`datasets-gen --seed`, `tetbench`'s
/// `--seed` and experiment files' `seed`): one default, so a name means one mesh everywhere.
pub const DEFAULT_SEED: u64 = 1;

/// Upper bound on a requested tet count: room for the 278M-tet meshes of current papers
/// (Morrical et al. 2019's Japan Earthquake set), with four faces a tet still far inside the
/// u32 indices, while a typo's extra zero is refused at once instead of exhausting memory.
pub const MAX_TETS: usize = 500_000_000;

const fn g(
    name: &'static str,
    default_tets: usize,
    description: &'static str,
    breaks: Option<&'static str>,
    build: fn(usize, u64) -> Result<Generated>,
) -> Generator {
    Generator {
        name,
        default_tets,
        description,
        breaks,
        build,
    }
}

static GENERATORS: &[Generator] = &[
    g("cc5", 320_000, "cube lattice, 5 tets per cell (alternating), Marschner-Lobb on [-1,1]^3", None, catalog::gen_cc5),
    g("cc6", 384_000, "cube lattice, 6 tets per cell (Kuhn), Marschner-Lobb on [-1,1]^3", None, catalog::gen_cc6),
    g("bcc", catalog::BCC_DEFAULT_TETS, "BCC lattice (Delaunay, 12 tets per primary point), Marschner-Lobb; same information as the default cc5/cc6", None, catalog::gen_bcc),
    g("torus", 100_000, "solid torus (periodic curvilinear grid, a hole through it), Gaussian-sum field", None, catalog::gen_torus),
    g("shell", 100_000, "spherical shell (ball with a cavity, cube-to-ball warp), spherical-shell field", None, catalog::gen_shell),
    g("tv-gaussian", 196_608, "time-varying: a Gaussian moving on a helix, 16 steps of one field on a cc6 lattice", None, catalog::gen_tv_gaussian),
    g("spx", 13_000, "analogue of spx: jittered ball with a central cavity (non-convex), Gaussian field", None, catalog::gen_spx),
    g("spx2", 828_000, "analogue of spx2: the spx shape at 828K tets", None, catalog::gen_spx2),
    g("delta", 1_000_000, "analogue of delta: box around a thin delta wing (non-convex), curvilinear, graded 100x to the wing plane", None, catalog::gen_delta),
    g("torso", 1_080_000, "analogue of torso: jittered elliptic cylinder, organ-like Gaussians", None, catalog::gen_torso),
    g("fighter", 1_400_000, "analogue of fighter: wind-tunnel box around an aircraft (non-convex), graded 10x, jittered", None, catalog::gen_fighter),
    g("fuel", 1_500_000, "analogue of fuel: cc6 lattice with fuel-injection jets", None, catalog::gen_fuel),
    g("brain", 5_500_000, "analogue of brain: jittered ellipsoid with two ventricle cavities (non-convex)", None, catalog::gen_brain),
    g("blunt-like", 187_000, "like NASA blunt fin: half O-grid around a fin on a plate (non-convex), graded 100x, bow shock", None, catalog::gen_blunt_like),
    g("comb-like", 215_000, "like NASA combustion chamber: curvilinear tube with a bulge (non-convex), jets", None, catalog::gen_comb_like),
    g("post-like", 513_000, "like NASA post: periodic O-grid around a cylinder (non-convex), graded 100x, potential flow", None, catalog::gen_post_like),
    g("hard-zero-volume", 24_000, "cc6 lattice with one z-layer collapsed to zero thickness", Some("zero-volume tets: divisions by a zero determinant or area, NaN barycentrics"), hard::gen_zero_volume),
    g("hard-slivers", 20_000, "cc5 lattice with one z-layer 1e-4 of a cell thick", Some("slivers (four nearly coplanar vertices, no short edge): ill-conditioned ray-tet intersection, projection classes"), hard::gen_slivers),
    g("hard-needles", 24_000, "cc6 lattice with every 4th x- and y-layer 1e-4 thick", Some("needles (one long edge, tiny cross-section): thin projections, precision of exit faces"), hard::gen_needles),
    g("hard-caps", 24_000, "cc6 lattice with a thin sheared z-layer", Some("caps (a vertex just above the opposite face, dihedral near 180 deg): thick-vertex and class decisions"), hard::gen_caps),
    g("hard-axis-aligned", 24_000, "plain cc6 lattice, axis-aligned", Some("projections degenerate to classes 3 and 4 at the canonical views (faces and edges parallel to the view axis)"), hard::gen_axis_aligned),
    g("hard-translated", 24_000, "cc6 lattice on [-1,1]^3 translated by 1e6", Some("f32 precision when positions are not recentred before conversion"), hard::gen_translated),
    g("hard-tiny", 24_000, "cc6 lattice scaled to 1e-6", Some("absolute epsilons (volume, area, depth) that assume unit-sized meshes"), hard::gen_tiny),
    g("hard-scalar-range", 24_000, "scalars 10^(30 ML) from 1 to 1e30", Some("scalar normalisation and tables in f32; min/max spanning 1e30"), hard::gen_scalar_range),
    g("hard-constant", 24_000, "every scalar equal to 1", Some("transfer-function range of zero width (division by max - min)"), hard::gen_constant),
    g("hard-duplicates", 24_000, "cc6 lattice whose +x half uses duplicate copies of the middle-plane vertices", Some("duplicate vertices: an internal seam of coincident faces that adjacency sees as boundary (ray casting, MPVONC)"), hard::gen_duplicates),
    g("hard-negative", 24_000, "cc6 lattice with every other tet negatively oriented", Some("negatively oriented tets: face normals, exit-face tests and classification that assume positive orientation"), hard::gen_negative),
    g("hard-cycle", 3_000, "pinwheels of three disjoint thin tets overlapping cyclically along z", Some("a visibility cycle: no correct order exists; centroid order (equal centroid depths) is wrong at view (0,0)"), hard::gen_cycle),
    g("hard-mpvonc", 24_000, "two disconnected interleaved combs (non-convex)", Some("MPVONC: its adjacency-based order cannot see across the gaps between teeth; viewed along y the order is wrong"), hard::gen_mpvonc),
    g("hard-saturate", 40, "cc5 lattice of 2x2x2 cells: each tet spans a quarter of the mesh", Some("very large tau*l per segment: opacity saturates, exp underflows, pre-integration tables clamp"), hard::gen_saturate),
];

/// Every generator, in `--list` order.
pub fn generators() -> &'static [Generator] {
    GENERATORS
}

/// Looks a generator up by name.
pub fn find(name: &str) -> Option<&'static Generator> {
    GENERATORS.iter().find(|g| g.name == name)
}

/// Splits a dataset spec, `NAME` or `NAME:N` (N tets, at least 1), into the generator name and
/// the size; one line when the size is not a count.
pub fn parse_spec(spec: &str) -> Result<(&str, Option<usize>)> {
    match spec.split_once(':') {
        Some((name, n)) => n
            .trim()
            .parse::<usize>()
            .ok()
            .filter(|&t| t > 0)
            .map(|t| (name, Some(t)))
            .ok_or_else(|| {
                Error::Input(format!(
                    "{spec}: the size after ':' must be a tet count (at least 1)"
                ))
            }),
        None => Ok((spec, None)),
    }
}

/// Generates mesh `name` with about `tets` tets (default: the generator's size) from `seed`.
/// An unknown name or a size of 0 (or above [`MAX_TETS`]) is an [`Error::Input`].
pub fn generate(name: &str, tets: Option<usize>, seed: u64) -> Result<Mesh> {
    generate_checked(name, tets, seed).map(|g| g.mesh)
}

/// [`generate`], also returning what the construction implies (for validation).
pub fn generate_checked(name: &str, tets: Option<usize>, seed: u64) -> Result<Generated> {
    let gen = find(name).ok_or_else(|| {
        let names: Vec<&str> = GENERATORS.iter().map(|g| g.name).collect();
        Error::Input(format!(
            "unknown dataset '{name}' (known: {})",
            names.join(", ")
        ))
    })?;
    let n = tets.unwrap_or(gen.default_tets);
    if n == 0 || n > MAX_TETS {
        return Err(Error::Input(format!(
            "{name}: --tets {n} out of range (1 to {MAX_TETS})"
        )));
    }
    (gen.build)(n, seed)
}
