//! Hard cases: meshes built to break renderers, sorts and loaders. Each one's
//! [`crate::Generator::breaks`] says what it breaks.

use algorithms::{Mesh, Result};

use crate::Generated;
use glam::DVec3;

use crate::catalog::{cc_box, finish};
use crate::fields;
use crate::grid::{Block, Built, Split, LATTICE_KEY};
use crate::recipe::{block_boundary_faces, fit_cells, fit_masked};

/// Boundary faces of a full block: two triangles per cell face on its six sides.
fn full(cells: [usize; 3]) -> usize {
    let [cx, cy, cz] = cells;
    4 * (cx * cy + cy * cz + cz * cx)
}

fn ok(mesh: Mesh, boundary: usize) -> Result<Generated> {
    Ok(Generated::new(mesh, Some(boundary)))
}

/// A block over `[-1, 1]³` sized for `tets`, with uniform grid coordinates except where
/// `thin(axis, layer)` gives a layer's relative thickness (1 = normal, 0 = collapsed).
/// Returns the block and its coordinate arrays.
fn layered_coords(cells: [usize; 3], thin: &dyn Fn(usize, usize) -> f64) -> [Vec<f64>; 3] {
    std::array::from_fn(|a| {
        let widths: Vec<f64> = (0..cells[a]).map(|l| thin(a, l)).collect();
        let total: f64 = widths.iter().sum();
        let mut x = vec![-1.0];
        let mut acc = 0.0;
        for w in widths {
            acc += w;
            x.push(-1.0 + 2.0 * acc / total);
        }
        x
    })
}

fn build_coords(block: &Block, c: &[Vec<f64>; 3], map: &(dyn Fn(DVec3) -> DVec3 + Sync)) -> Built {
    block.build(&|_| true, &|[i, j, k]| {
        map(DVec3::new(c[0][i], c[1][j], c[2][k]))
    })
}

fn ml(name: &str, b: Built) -> Result<Mesh> {
    finish(
        name,
        b.positions,
        b.tets,
        "marschner-lobb",
        fields::marschner_lobb,
    )
}

/// Collapsed layer: the middle z-layer of a `cc6` lattice has zero thickness, so its
/// `6·cx·cy` tets have zero volume (conforming, none negative).
pub fn gen_zero_volume(tets: usize, _seed: u64) -> Result<Generated> {
    let mut cells = fit_cells(tets, Split::Six, [1.0, 1.0, 1.0], false, 1.0);
    cells[2] = cells[2].max(3);
    let mid = cells[2] / 2;
    let c = layered_coords(cells, &|a, l| if a == 2 && l == mid { 0.0 } else { 1.0 });
    ok(
        ml(
            "hard-zero-volume",
            build_coords(&Block::new(cells, Split::Six), &c, &|p| p),
        )?,
        full(cells),
    )
}

/// Relative thickness of the flattened layers of `hard-slivers`, `hard-caps`, `hard-needles`.
pub const THIN: f64 = 1e-4;

/// A `cc5` lattice whose middle z-layer is `THIN` of a cell thick: its central tets become
/// slivers (four nearly coplanar vertices, no short edge), the corner tets flat caps.
pub fn gen_slivers(tets: usize, _seed: u64) -> Result<Generated> {
    let mut cells = fit_cells(tets, Split::Five, [1.0, 1.0, 1.0], false, 1.0);
    cells[2] = cells[2].max(3);
    let mid = cells[2] / 2;
    let c = layered_coords(cells, &|a, l| if a == 2 && l == mid { THIN } else { 1.0 });
    ok(
        ml(
            "hard-slivers",
            build_coords(&Block::new(cells, Split::Five), &c, &|p| p),
        )?,
        full(cells),
    )
}

/// A `cc6` lattice whose every fourth x- and y-layer is `THIN` thick: where such layers cross,
/// the tets are needles (one long edge along z, tiny cross-section).
pub fn gen_needles(tets: usize, _seed: u64) -> Result<Generated> {
    let cells = fit_cells(tets, Split::Six, [1.0, 1.0, 1.0], false, 1.0);
    let c = layered_coords(cells, &|a, l| if a < 2 && l % 4 == 1 { THIN } else { 1.0 });
    ok(
        ml(
            "hard-needles",
            build_coords(&Block::new(cells, Split::Six), &c, &|p| p),
        )?,
        full(cells),
    )
}

/// A `cc6` lattice whose middle z-layer is `THIN` thick and sheared: everything above it is
/// shifted by (−0.3, −0.5) cells, so in that layer a vertex lies just above the inside of the
/// opposite face (caps: a dihedral angle near 180°).
pub fn gen_caps(tets: usize, _seed: u64) -> Result<Generated> {
    let mut cells = fit_cells(tets, Split::Six, [1.0, 1.0, 1.0], false, 1.0);
    cells[2] = cells[2].max(3);
    let mid = cells[2] / 2;
    let c = layered_coords(cells, &|a, l| if a == 2 && l == mid { THIN } else { 1.0 });
    let top = c[2][mid + 1];
    let shift = DVec3::new(
        -0.3 * 2.0 / cells[0] as f64,
        -0.5 * 2.0 / cells[1] as f64,
        0.0,
    );
    let map = move |p: DVec3| if p.z >= top { p + shift } else { p };
    ok(
        ml(
            "hard-caps",
            build_coords(&Block::new(cells, Split::Six), &c, &map),
        )?,
        full(cells),
    )
}

fn lattice_case(
    name: &str,
    tets: usize,
    map: impl Fn(DVec3) -> DVec3,
    f: impl Fn(DVec3) -> f64 + Sync,
) -> Result<Generated> {
    let (b, mut l) = cc_box(tets, Split::Six);
    // Fields are evaluated on the untransformed lattice so every variant has the same scalars.
    let s = fields::sample(&b.positions, f);
    let positions: Vec<DVec3> = b.positions.iter().map(|&p| map(p)).collect();
    let o = map(l.origin);
    l.spacing = map(l.origin + l.spacing) - o;
    l.origin = o;
    let mut m = Mesh::with_scalars(name, positions, b.tets, "s", s)?;
    m.field_data.insert(LATTICE_KEY.into(), l.to_field_data());
    ok(m, full(l.n.map(|n| n - 1)))
}

/// The plain `cc6` lattice, axis-aligned: at views (0,0), (90,0), (0,90) faces and edges are
/// parallel to the view direction.
pub fn gen_axis_aligned(tets: usize, _seed: u64) -> Result<Generated> {
    lattice_case("hard-axis-aligned", tets, |p| p, fields::marschner_lobb)
}

/// `cc6` over `[-1, 1]³` translated by (1e6, 1e6, 1e6).
pub fn gen_translated(tets: usize, _seed: u64) -> Result<Generated> {
    lattice_case(
        "hard-translated",
        tets,
        |p| p + DVec3::splat(1e6),
        fields::marschner_lobb,
    )
}

/// `cc6` over `[-1, 1]³` scaled by 1e-6.
pub fn gen_tiny(tets: usize, _seed: u64) -> Result<Generated> {
    lattice_case("hard-tiny", tets, |p| p * 1e-6, fields::marschner_lobb)
}

/// Scalars `10^(30·ML(p))`, from 1 to about 1e30.
pub fn gen_scalar_range(tets: usize, _seed: u64) -> Result<Generated> {
    lattice_case(
        "hard-scalar-range",
        tets,
        |p| p,
        |p| 10f64.powf(30.0 * fields::marschner_lobb(p).clamp(0.0, 1.0)),
    )
}

/// Every scalar 1.
pub fn gen_constant(tets: usize, _seed: u64) -> Result<Generated> {
    lattice_case("hard-constant", tets, |p| p, |_| 1.0)
}

/// `cc6` lattice cut at the middle x-plane: the cells on the +x side use their own copies of
/// the vertices on that plane (same position and scalar). Topologically two blocks that touch.
pub fn gen_duplicates(tets: usize, _seed: u64) -> Result<Generated> {
    let mut cells = fit_cells(tets, Split::Six, [1.0, 1.0, 1.0], false, 1.0);
    cells[0] = cells[0].max(2);
    let block = Block::new(cells, Split::Six);
    let b = block.build(&|_| true, &|[i, j, k]| {
        DVec3::new(i as f64, j as f64, k as f64) * 2.0
            / DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64)
            - DVec3::ONE
    });
    let px = block.points()[0];
    let cut = cells[0] / 2;
    let mut positions = b.positions;
    // Grid vertex ids are i + px (j + py k) (no mask): copy the plane i = cut.
    let mut copy = vec![u32::MAX; positions.len()];
    for g in 0..positions.len() {
        if g % px == cut {
            copy[g] = positions.len() as u32;
            positions.push(positions[g]);
        }
    }
    let per = Split::Six.per_cell();
    let mut tets = b.tets;
    for (t, tet) in tets.iter_mut().enumerate() {
        let cell = t / per;
        if cell % cells[0] >= cut {
            for v in tet.iter_mut() {
                if copy[*v as usize] != u32::MAX {
                    *v = copy[*v as usize];
                }
            }
        }
    }
    let seam = 4 * cells[1] * cells[2];
    let mesh = ml(
        "hard-duplicates",
        Built {
            positions,
            tets,
            interior: Vec::new(),
        },
    )?;
    ok(mesh, full(cells) + seam)
}

/// `cc6` lattice with every odd-numbered tet's last two vertices swapped: half the tets are
/// negatively oriented (same faces, still conforming).
pub fn gen_negative(tets: usize, _seed: u64) -> Result<Generated> {
    let (mut b, l) = cc_box(tets, Split::Six);
    for t in b.tets.iter_mut().skip(1).step_by(2) {
        t.swap(2, 3);
    }
    ok(ml("hard-negative", b)?, full(l.n.map(|n| n - 1)))
}

/// Pinwheels of three disjoint thin tets ("sticks") along the sides of a triangle, each rising
/// in z from start to end, so that stick 0 lies over 1, 1 over 2 and 2 over 0 seen along z:
/// a visibility cycle. The sticks' centroids are at the same depth. Pinwheels are tiled on a
/// 3D grid (3 × 3 × 1.5 apart) to reach the requested count (3 tets each).
pub fn gen_cycle(tets: usize, _seed: u64) -> Result<Generated> {
    let n = (tets as f64 / 3.0).round().max(1.0) as usize;
    let side = (n as f64).cbrt().ceil() as usize;
    let mut positions = Vec::with_capacity(12 * n);
    let mut tet_list = Vec::with_capacity(3 * n);
    for w in 0..n {
        let centre = DVec3::new(
            (w % side) as f64 * 3.0,
            ((w / side) % side) as f64 * 3.0,
            (w / (side * side)) as f64 * 1.5,
        );
        for i in 0..3 {
            let ang = |k: usize| 2.0 * std::f64::consts::PI * (k % 3) as f64 / 3.0 + 0.5;
            let vi = DVec3::new(ang(i).cos(), ang(i).sin(), 0.0);
            let vj = DVec3::new(ang(i + 1).cos(), ang(i + 1).sin(), 0.0);
            let d = (vj - vi).normalize();
            let normal = DVec3::new(-d.y, d.x, 0.0);
            let start = centre + vi - 0.4 * d + DVec3::new(0.0, 0.0, -0.4);
            let end = centre + vj + 0.4 * d + DVec3::new(0.0, 0.0, 0.4);
            let w = 0.08;
            let base = positions.len() as u32;
            positions.extend([
                start,
                end,
                start + w * normal,
                end + w * normal + DVec3::new(0.0, 0.0, w),
            ]);
            tet_list.push([base, base + 1, base + 2, base + 3]);
        }
    }
    for t in tet_list.iter_mut() {
        *t = algorithms::io::split::orient(&positions, *t);
    }
    let faces = 4 * tet_list.len();
    ok(
        finish("hard-cycle", positions, tet_list, "s", |p| 0.5 + 0.5 * p.z)?,
        faces,
    )
}

/// The cell mask of `hard-mpvonc`: two combs whose teeth interleave along y with one empty
/// cell between teeth, and one between a tooth and the other comb's spine. Returns
/// 0 (removed), 1 (comb A) or 2 (comb B).
pub fn comb_cell(cells: [usize; 3], [i, j, _k]: [usize; 3]) -> u8 {
    let spine = (cells[0] / 8).max(1);
    let tooth = (cells[1] / 12).max(1);
    let period = 2 * (tooth + 1);
    let r = j % period;
    if i < spine || (r < tooth && i + spine + 1 < cells[0]) {
        1
    } else if i + spine >= cells[0] || (r > tooth && r < 2 * tooth + 1 && i > spine) {
        2
    } else {
        0
    }
}

/// Two interleaved combs (see [`comb_cell`]), `cc6`.
pub fn gen_mpvonc(tets: usize, _seed: u64) -> Result<Generated> {
    let block = fit_masked(tets, Split::Six, [1.0, 1.0, 0.5], false, &|b: &Block| {
        let cells = b.cells;
        Box::new(move |ijk| comb_cell(cells, ijk) != 0)
    });
    let cells = block.cells;
    let b = block.build(&|ijk| comb_cell(cells, ijk) != 0, &|[i, j, k]| {
        DVec3::new(
            2.0 * i as f64 / cells[0] as f64 - 1.0,
            2.0 * j as f64 / cells[1] as f64 - 1.0,
            k as f64 / cells[2] as f64 - 0.5,
        )
    });
    let expected = block_boundary_faces(&block, &|ijk| comb_cell(cells, ijk) != 0);
    ok(ml("hard-mpvonc", b)?, expected)
}

/// A `cc5` lattice of very few cells (2×2×2 by default): each tet spans a quarter of the
/// mesh, so τ·l per segment is large and opacity saturates.
pub fn gen_saturate(tets: usize, _seed: u64) -> Result<Generated> {
    let (b, l) = cc_box(tets, Split::Five);
    let m = finish("hard-saturate", b.positions, b.tets, "s", |p| {
        0.9 + 0.1 * fields::marschner_lobb(p)
    })?;
    ok(m, full(l.n.map(|n| n - 1)))
}
