//! Splitting cells into tetrahedra, which the `.vtk`, `.vtu` and PLOT3D readers share:
//! hexahedra (structured and unstructured), wedges and pyramids, and the cell arrays' offsets.
//!
//! Conformity: neighbouring cells must split a shared quad face along the same diagonal.
//! - Structured grids: 5 tets per hex, mirrored on cells of odd `i + j + k` (the two
//!   decompositions pick opposite diagonals on every face, and neighbours have opposite parity),
//!   or 6 tets per hex (Kuhn) around the `c000`–`c111` diagonal, the same in every cell.
//! - Unstructured cells: every quad face is cut along the diagonal through its vertex of smallest
//!   global index (Dompierre et al. 1999), which both cells sharing the face agree on. Pyramids
//!   give 2 tets and wedges 3. A hexahedron cannot always be cut into 5 or 6 tets that honour
//!   six such independent diagonals, so each one gets a centre vertex (its scalars the mean of
//!   the 8 corners) and 2 tets per face: 12 tets. `Split::Five`/`Six` only matter for
//!   structured grids.
//!
//! Tets produced here are oriented positively (two vertices swapped when the signed volume is
//! negative); tets read as tets are left as the file has them.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::io::vtk_types::{
    cell_type_name, VTK_HEXAHEDRON, VTK_PYRAMID, VTK_TETRA, VTK_VOXEL, VTK_WEDGE,
};
use crate::io::Split;
use crate::mesh::signed_volume6;

fn corners_for(t: u8) -> Option<usize> {
    match t {
        VTK_TETRA => Some(4),
        VTK_VOXEL | VTK_HEXAHEDRON => Some(8),
        VTK_WEDGE => Some(6),
        VTK_PYRAMID => Some(5),
        _ => None,
    }
}

/// `t` (vertex indices into `p`) with two vertices swapped when its signed volume is negative.
#[inline]
pub fn orient(p: &[DVec3], mut t: [u32; 4]) -> [u32; 4] {
    if signed_volume6(t.map(|v| p[v as usize])) < 0.0 {
        t.swap(2, 3);
    }
    t
}

/// Offset `[x, y, z]` (each 0 or 1) of corner `q = x + 2y + 4z` of a hex cell: the local corner
/// index that [`hex_split_pattern`] uses.
#[inline]
pub fn hex_corner(q: usize) -> [usize; 3] {
    [q & 1, (q >> 1) & 1, (q >> 2) & 1]
}

/// The tets one hex cell of a structured grid is split into, as local corner indices (see
/// [`hex_corner`]), for a cell whose `i + j + k` is odd (`odd_parity`) or even. [`Split::Five`]:
/// 4 corner tets and a central one, (0,1,2,4) (1,3,2,7) (1,2,4,7) (1,5,7,4) (2,7,6,4) on even
/// cells; on odd cells their mirror image (corner `q` ↦ `q ^ 1`), listed central tet first.
/// [`Split::Six`]: Kuhn's 6 tets around the diagonal 0–7, the same on every cell. Not every tet
/// is positively oriented as listed: fix them up with the positions at hand.
pub fn hex_split_pattern(split: Split, odd_parity: bool) -> &'static [[usize; 4]] {
    match split {
        Split::Five if odd_parity => &FIVE_ODD,
        Split::Five => &FIVE_EVEN,
        Split::Six => &SIX,
    }
}

/// 5-tet split for even `i + j + k`: central tet 1-2-4-7 and the four corner tets at 0, 3, 5, 6.
const FIVE_EVEN: [[usize; 4]; 5] = [
    [0, 1, 2, 4],
    [1, 3, 2, 7],
    [1, 2, 4, 7],
    [1, 5, 7, 4],
    [2, 7, 6, 4],
];
/// Its mirror image for odd `i + j + k`: central tet 0-3-5-6, corner tets at 1, 2, 4, 7 (the same
/// tets as `FIVE_EVEN` with every corner `q` replaced by `q ^ 1`, in another order).
const FIVE_ODD: [[usize; 4]; 5] = [
    [0, 3, 5, 6],
    [1, 0, 3, 5],
    [2, 0, 3, 6],
    [4, 0, 5, 6],
    [7, 3, 5, 6],
];
/// Kuhn's 6-tet split around the 0–7 diagonal.
const SIX: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// Number of hex cells of a grid of `dims` points, or `None` on overflow.
pub fn structured_cells(dims: [usize; 3]) -> Option<usize> {
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d.saturating_sub(1)))
}

/// Splits a structured grid of `dims` points (index `i + ni·(j + nj·k)`) into tets, every one
/// oriented positively. `positions` must hold `ni·nj·nk` points.
pub fn split_structured(
    source: &str,
    dims: [usize; 3],
    positions: &[DVec3],
    split: Split,
) -> Result<Vec<[u32; 4]>> {
    let [ni, nj, nk] = dims;
    let n = ni
        .checked_mul(nj)
        .and_then(|v| v.checked_mul(nk))
        .filter(|&v| v == positions.len())
        .ok_or_else(|| {
            Error::input(
                source,
                format!(
                    "grid dimensions {ni}×{nj}×{nk} do not match the {} points",
                    positions.len()
                ),
            )
        })?;
    if n > u32::MAX as usize - 1 {
        return Err(Error::input(source, "more than 2^32 - 2 grid points"));
    }
    let cells = structured_cells(dims).unwrap_or(0);
    let mut tets = Vec::with_capacity(cells * split.per_cell());
    let idx = |i: usize, j: usize, k: usize| (i + ni * (j + nj * k)) as u32;
    for k in 0..nk.saturating_sub(1) {
        for j in 0..nj.saturating_sub(1) {
            for i in 0..ni.saturating_sub(1) {
                let c: [u32; 8] = std::array::from_fn(|q| {
                    let [x, y, z] = hex_corner(q);
                    idx(i + x, j + y, k + z)
                });
                for t in hex_split_pattern(split, (i + j + k) % 2 == 1) {
                    tets.push(orient(positions, t.map(|v| c[v])));
                }
            }
        }
    }
    Ok(tets)
}

/// Splits unstructured VTK cells into tets. Cell `i` is `conn[offsets[i]..offsets[i + 1]]` of
/// type `types[i]`; `offsets` has `types.len() + 1` entries, non-decreasing, within `conn`.
/// Tets are kept as they are; voxels, hexahedra, wedges and pyramids are split when `split` is
/// given (hexahedra add a centre vertex to `positions` and to every array of `point_arrays`)
/// and refused otherwise; any other type is refused.
pub fn split_cells(
    source: &str,
    types: &[u8],
    offsets: &[usize],
    conn: &[i64],
    positions: &mut Vec<DVec3>,
    point_arrays: &mut [Vec<f64>],
    split: Option<Split>,
) -> Result<Vec<[u32; 4]>> {
    let npts = positions.len();
    if offsets.len() != types.len() + 1 {
        return Err(Error::Internal(format!(
            "{source}: {} cell offsets for {} cells",
            offsets.len(),
            types.len()
        )));
    }
    // Check the whole cell list first: types, sizes, indices.
    let mut counts = [0usize; 15];
    for (c, &t) in types.iter().enumerate() {
        let Some(k) = corners_for(t) else {
            return Err(Error::input(
                source,
                format!(
                    "cell {c} has VTK type {t} ({}); only tetra (10), voxel (11), hexahedron \
                     (12), wedge (13) and pyramid (14) cells are read",
                    cell_type_name(t as i64)
                ),
            ));
        };
        let (a, b) = (offsets[c], offsets[c + 1]);
        if b < a || b > conn.len() {
            return Err(Error::input(
                source,
                format!("cell {c}: offsets {a}..{b} out of range"),
            ));
        }
        if b - a != k {
            return Err(Error::input(
                source,
                format!(
                    "cell {c} ({}) has {} vertices, expected {k}",
                    cell_type_name(t as i64),
                    b - a
                ),
            ));
        }
        if let Some(&v) = conn[a..b]
            .iter()
            .find(|&&v| v < 0 || v as u64 >= npts as u64)
        {
            return Err(Error::input(
                source,
                format!("cell {c}: vertex index {v} out of range (points: {npts})"),
            ));
        }
        counts[t as usize] += 1;
    }
    let non_tets: Vec<String> = [VTK_VOXEL, VTK_HEXAHEDRON, VTK_WEDGE, VTK_PYRAMID]
        .iter()
        .filter(|&&t| counts[t as usize] > 0)
        .map(|&t| {
            format!(
                "{} {} cells (VTK type {t})",
                counts[t as usize],
                cell_type_name(t as i64)
            )
        })
        .collect();
    if split.is_none() && !non_tets.is_empty() {
        return Err(Error::input(
            source,
            format!(
                "{} are not tetrahedra; ask for a split (--split 5 or 6) to split them",
                non_tets.join(" and ")
            ),
        ));
    }
    let hexes = counts[VTK_VOXEL as usize] + counts[VTK_HEXAHEDRON as usize];
    if npts.saturating_add(hexes) > u32::MAX as usize - 1 {
        return Err(Error::input(
            source,
            "more than 2^32 - 2 vertices after splitting",
        ));
    }
    let cap = counts[VTK_TETRA as usize]
        + 12 * hexes
        + 3 * counts[VTK_WEDGE as usize]
        + 2 * counts[VTK_PYRAMID as usize];
    let mut tets = Vec::with_capacity(cap);
    positions.reserve(hexes);
    for a in point_arrays.iter_mut() {
        a.reserve(hexes);
    }
    for (c, &t) in types.iter().enumerate() {
        let mut v = [0u32; 8];
        for (d, &x) in v.iter_mut().zip(&conn[offsets[c]..offsets[c + 1]]) {
            *d = x as u32;
        }
        match t {
            VTK_TETRA => tets.push([v[0], v[1], v[2], v[3]]),
            VTK_PYRAMID => split_pyramid(positions, [v[0], v[1], v[2], v[3]], v[4], &mut tets),
            VTK_WEDGE => split_wedge(positions, std::array::from_fn(|i| v[i]), &mut tets),
            VTK_VOXEL => {
                let h = [v[0], v[1], v[3], v[2], v[4], v[5], v[7], v[6]];
                split_hex(positions, point_arrays, h, &mut tets);
            }
            _ => split_hex(
                positions,
                point_arrays,
                std::array::from_fn(|i| v[i]),
                &mut tets,
            ),
        }
    }
    Ok(tets)
}

/// The two triangles of quad `q` (in cyclic order) cut along the diagonal through its vertex of
/// smallest index.
fn quad_triangles(q: [u32; 4]) -> [[u32; 3]; 2] {
    let m = (0..4).min_by_key(|&i| q[i]).unwrap_or(0);
    let r = |k: usize| q[(m + k) % 4];
    [[r(0), r(1), r(2)], [r(0), r(2), r(3)]]
}

fn split_pyramid(p: &[DVec3], base: [u32; 4], apex: u32, out: &mut Vec<[u32; 4]>) {
    for [a, b, c] in quad_triangles(base) {
        out.push(orient(p, [a, b, c, apex]));
    }
}

/// VTK wedge: triangles 0-1-2 and 3-4-5, edges 0-3, 1-4, 2-5.
fn split_wedge(p: &[DVec3], w: [u32; 6], out: &mut Vec<[u32; 4]>) {
    let m = (0..6).min_by_key(|&i| w[i]).unwrap_or(0);
    // Relabel so the smallest vertex is 0 (a rotation, or the top/bottom mirror).
    let (q, top) = (m % 3, m >= 3);
    let tri = |s: usize| [s + q, s + (q + 1) % 3, s + (q + 2) % 3];
    let (lo, hi) = if top {
        (tri(3), tri(0))
    } else {
        (tri(0), tri(3))
    };
    let r = [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(|i| w[i]);
    // Both quad faces at vertex 0 are cut through it: the tet 0-3-4-5 comes off, leaving a
    // pyramid on the quad 1-2-5-4 with apex 0.
    out.push(orient(p, [r[0], r[3], r[4], r[5]]));
    split_pyramid(p, [r[1], r[2], r[5], r[4]], r[0], out);
}

/// VTK hexahedron (bottom 0-1-2-3, top 4-5-6-7): centre vertex and 2 tets per face.
fn split_hex(p: &mut Vec<DVec3>, arrays: &mut [Vec<f64>], h: [u32; 8], out: &mut Vec<[u32; 4]>) {
    const FACES: [[usize; 4]; 6] = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let centre = h.iter().map(|&v| p[v as usize]).sum::<DVec3>() / 8.0;
    let ci = p.len() as u32;
    p.push(centre);
    for a in arrays.iter_mut() {
        let mean = h.iter().map(|&v| a[v as usize]).sum::<f64>() / 8.0;
        a.push(mean);
    }
    for f in FACES {
        for [a, b, c] in quad_triangles(f.map(|i| h[i])) {
            out.push(orient(p, [a, b, c, ci]));
        }
    }
}

/// Turns `[0, n0, n0 + n1, …]`-style end offsets into validated start/end offsets: `ends` are
/// the VTK XML (and legacy 5.1 without the leading 0) cell end offsets.
pub fn offsets_from_ends(
    source: &str,
    what: &str,
    ends: &[i64],
    conn_len: usize,
) -> Result<Vec<usize>> {
    let mut out = Vec::with_capacity(ends.len() + 1);
    out.push(0usize);
    for (i, &e) in ends.iter().enumerate() {
        let prev = *out.last().unwrap_or(&0);
        if e < prev as i64 || e as u64 > conn_len as u64 {
            return Err(Error::input(
                source,
                format!(
                    "{what}: offset {e} of cell {i} is out of order or past the {conn_len} \
                     connectivity entries"
                ),
            ));
        }
        out.push(e as usize);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;

    fn grid(dims: [usize; 3]) -> Vec<DVec3> {
        let mut p = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    p.push(DVec3::new(i as f64, j as f64 * 1.5, k as f64 * 0.7));
                }
            }
        }
        p
    }

    #[test]
    fn odd_five_split_mirrors_the_even_one() {
        let sorted = |mut t: [usize; 4]| {
            t.sort_unstable();
            t
        };
        let mut mirrored: Vec<[usize; 4]> = hex_split_pattern(Split::Five, false)
            .iter()
            .map(|t| sorted(t.map(|q| q ^ 1)))
            .collect();
        let mut odd: Vec<[usize; 4]> = hex_split_pattern(Split::Five, true)
            .iter()
            .map(|&t| sorted(t))
            .collect();
        mirrored.sort_unstable();
        odd.sort_unstable();
        assert_eq!(mirrored, odd);
    }

    #[test]
    fn structured_splits_conform_and_are_positive() {
        for (split, per) in [(Split::Five, 5), (Split::Six, 6)] {
            let dims = [4, 3, 5];
            let p = grid(dims);
            let tets = split_structured("g", dims, &p, split).unwrap();
            assert_eq!(tets.len(), 3 * 2 * 4 * per);
            let n = p.len();
            let m = Mesh::with_scalars("g", p, tets, "s", vec![0.0; n]).unwrap();
            assert_eq!(m.negative_tets(), 0);
            assert_eq!(m.degenerate_tets(), 0);
            let total: f64 = m.volumes().iter().sum();
            assert!((total - 3.0 * 2.0 * 1.5 * 4.0 * 0.7).abs() < 1e-9);
            // Conforming: only the outer quads (2 triangles each) are boundary.
            assert_eq!(m.boundary_faces().len(), 2 * 2 * (3 * 2 + 3 * 4 + 2 * 4));
            assert!(m.is_convex());
        }
    }

    /// Two hexahedra, a wedge and a pyramid glued together conform after splitting.
    #[test]
    fn unstructured_cells_conform() {
        // Points of a 3×2×2 grid (x fastest) plus an apex and a wedge ridge.
        let mut p = grid([3, 2, 2]);
        let g = |i: u32, j: u32, k: u32| i + 3 * (j + 2 * k);
        p.push(DVec3::new(1.0, -1.0, 0.35)); // 12: pyramid apex below the y=0 face of hex 0
        p.push(DVec3::new(3.0, 0.0, 0.35)); // 13, 14: wedge beyond x=2
        p.push(DVec3::new(3.0, 1.5, 0.35));
        let hex = |i: u32| {
            vec![
                g(i, 0, 0),
                g(i + 1, 0, 0),
                g(i + 1, 1, 0),
                g(i, 1, 0),
                g(i, 0, 1),
                g(i + 1, 0, 1),
                g(i + 1, 1, 1),
                g(i, 1, 1),
            ]
        };
        let vox = |i: u32| {
            let h = hex(i);
            vec![h[0], h[1], h[3], h[2], h[4], h[5], h[7], h[6]]
        };
        // Pyramid on the y=0 face of hex 0 (base order makes the apex side consistent).
        let pyr = vec![g(0, 0, 0), g(1, 0, 0), g(1, 0, 1), g(0, 0, 1), 12];
        // Wedge on the x=2 face of hex 1: triangles (2,0,0)-(2,1,0)-13... use the quad as 2 edges.
        let wedge = vec![g(2, 0, 0), 13, g(2, 0, 1), g(2, 1, 0), 14, g(2, 1, 1)];
        let cells = [
            (VTK_HEXAHEDRON, hex(0)),
            (VTK_VOXEL, vox(1)),
            (VTK_PYRAMID, pyr),
            (VTK_WEDGE, wedge),
        ];
        let types: Vec<u8> = cells.iter().map(|c| c.0).collect();
        let mut offsets = vec![0];
        let mut conn = Vec::new();
        for (_, c) in &cells {
            conn.extend(c.iter().map(|&v| v as i64));
            offsets.push(conn.len());
        }
        let mut s = vec![(0..p.len()).map(|i| i as f64).collect::<Vec<f64>>()];
        let err = split_cells(
            "m",
            &types,
            &offsets,
            &conn,
            &mut p.clone(),
            &mut s.clone(),
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("1 hexahedron cells (VTK type 12)"), "{err}");
        let tets = split_cells(
            "m",
            &types,
            &offsets,
            &conn,
            &mut p,
            &mut s,
            Some(Split::Five),
        )
        .unwrap();
        assert_eq!(tets.len(), 12 + 12 + 2 + 3);
        assert_eq!(p.len(), 17);
        assert_eq!(
            s[0][15],
            (0..8).map(|i| hex(0)[i] as f64).sum::<f64>() / 8.0
        );
        let m = Mesh::with_scalars("m", p, tets, "s", s.pop().unwrap()).unwrap();
        assert_eq!(m.negative_tets(), 0);
        assert_eq!(m.degenerate_tets(), 0);
        assert_eq!(m.adjacency().nonmanifold_faces, 0);
        // Boundary: 10 outer quads of the two hexes not covered + 4 pyramid triangles
        // + wedge: 2 triangles + 2 quads; every quad is 2 triangles.
        assert_eq!(m.boundary_faces().len(), 2 * 8 + 4 + 2 + 2 * 2);
    }

    #[test]
    fn unknown_and_bad_cells_are_refused() {
        let mut p = vec![DVec3::ZERO; 4];
        let e = split_cells("m", &[5], &[0, 3], &[0, 1, 2], &mut p, &mut [], None).unwrap_err();
        assert!(e.to_string().contains("VTK type 5 (triangle)"), "{e}");
        let e = split_cells("m", &[10], &[0, 4], &[0, 1, 2, 4], &mut p, &mut [], None).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
        let e = split_cells("m", &[10], &[0, 3], &[0, 1, 2], &mut p, &mut [], None).unwrap_err();
        assert!(e.to_string().contains("expected 4"), "{e}");
    }
}
