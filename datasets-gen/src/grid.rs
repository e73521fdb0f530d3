//! Lattices: structured blocks of hexahedra split into 5 or 6 tets (`cc5`, `cc6`), optionally
//! with cells masked out (holes) or wrapped around one axis (periodic, for rings and tubes), and
//! the body-centred cubic lattice (`bcc`).

/// The lattice description and BCC tet numbering live in `algorithms` (the lattice sorts read
/// them); re-exported here, where the lattices are built.
pub use algorithms::bcc::lattice::{
    bcc_num_tets, bcc_tet_index, Lattice, LatticeKind, LATTICE_KEY,
};
use algorithms::io::split::{hex_corner, hex_split_pattern};
use algorithms::mesh::signed_volume6;
use glam::DVec3;
use rayon::prelude::*;

/// How each hexahedral cell is split (re-exported from the readers, which split hexahedra the
/// same way; [`Block::build`] fixes the order of the tets within a cell).
pub use algorithms::io::Split;

/// The split patterns as local corner indices `q = x + 2y + 4z`, `[even parity, odd parity]`:
/// the even pattern of [`hex_split_pattern`], and for [`Split::Five`] on odd cells the same tets
/// mirrored in x (corner `q` ↦ `q ^ 1`) in the same order; each tet then reordered (last two
/// swapped if needed) to be positively oriented in the unit cube.
fn patterns(split: Split) -> [Vec<[usize; 4]>; 2] {
    let fix = |mut t: [usize; 4]| {
        if signed_volume6(t.map(corner)) < 0.0 {
            t.swap(2, 3);
        }
        t
    };
    let even = hex_split_pattern(split, false);
    let mirror = |q: usize| match split {
        Split::Five => q ^ 1,
        Split::Six => q,
    };
    [
        even.iter().map(|&t| fix(t)).collect(),
        even.iter().map(|t| fix(t.map(mirror))).collect(),
    ]
}

/// Corner `q` of the unit cube.
fn corner(q: usize) -> DVec3 {
    DVec3::from(hex_corner(q).map(|x| x as f64))
}

/// A structured block: `cells` hexahedra per axis, split as `split`. With `periodic_x` the last
/// layer of cells along x wraps around to the first grid plane (a ring or tube; with
/// [`Split::Five`] the number of cells along x must then be even).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    pub cells: [usize; 3],
    pub split: Split,
    pub periodic_x: bool,
}

/// Output of [`Block::build`].
#[derive(Clone, Debug)]
pub struct Built {
    pub positions: Vec<DVec3>,
    pub tets: Vec<[u32; 4]>,
    /// Per output vertex: true when all 8 cells around it exist and are kept (so moving it a
    /// little changes no boundary).
    pub interior: Vec<bool>,
}

impl Block {
    pub fn new(cells: [usize; 3], split: Split) -> Block {
        Block {
            cells,
            split,
            periodic_x: false,
        }
    }

    /// Grid points per axis.
    pub fn points(&self) -> [usize; 3] {
        let [cx, cy, cz] = self.cells;
        [if self.periodic_x { cx } else { cx + 1 }, cy + 1, cz + 1]
    }

    pub fn num_cells(&self) -> usize {
        self.cells.iter().product()
    }

    /// Tets of the full block (no mask).
    pub fn num_tets(&self) -> usize {
        self.num_cells() * self.split.per_cell()
    }

    /// Cell `(i, j, k)` from its linear index `i + cx (j + cy k)`.
    #[inline]
    pub fn cell_ijk(&self, c: usize) -> [usize; 3] {
        let [cx, cy, _] = self.cells;
        [c % cx, (c / cx) % cy, c / (cx * cy)]
    }

    /// Number of cells `keep` keeps.
    pub fn count_kept(&self, keep: &(dyn Fn([usize; 3]) -> bool + Sync)) -> usize {
        (0..self.num_cells())
            .into_par_iter()
            .filter(|&c| keep(self.cell_ijk(c)))
            .count()
    }

    /// Builds the tets of the kept cells (in cell order `i + cx (j + cy k)`, then the split's
    /// order) over the grid points `point(i, j, k)`. Vertices no kept cell uses are dropped.
    /// `point` must be an orientation-preserving (or everywhere orientation-reversing) map of
    /// the grid; in the second case every tet is flipped so that volumes come out positive.
    pub fn build(
        &self,
        keep: &(dyn Fn([usize; 3]) -> bool + Sync),
        point: &(dyn Fn([usize; 3]) -> DVec3 + Sync),
    ) -> Built {
        let [px, py, pz] = self.points();
        let [cx, cy, cz] = self.cells;
        assert!(cx >= 1 && cy >= 1 && cz >= 1, "empty block");
        assert!(
            !(self.periodic_x && self.split == Split::Five && cx % 2 == 1),
            "periodic 5-split needs an even number of cells"
        );
        let ncells = self.num_cells();
        let kept: Vec<bool> = (0..ncells)
            .into_par_iter()
            .map(|c| keep(self.cell_ijk(c)))
            .collect();
        let all_kept = kept.iter().all(|&k| k);
        let gid = |i: usize, j: usize, k: usize| (i % px + px * (j + py * k)) as u32;
        let pats = patterns(self.split);
        let mut tets: Vec<[u32; 4]> = (0..ncells)
            .into_par_iter()
            .filter(|&c| kept[c])
            .flat_map_iter(|c| {
                let [i, j, k] = self.cell_ijk(c);
                let pat = &pats[(i + j + k) & 1];
                let corner_id = move |q: usize| {
                    let [x, y, z] = hex_corner(q);
                    gid(i + x, j + y, k + z)
                };
                pat.iter().map(move |t| t.map(corner_id))
            })
            .collect();
        let npts = px * py * pz;
        // Cells around each grid point: interior when all 8 exist and are kept.
        let cell_kept = |i: isize, j: isize, k: isize| -> bool {
            let i = if self.periodic_x {
                i.rem_euclid(cx as isize)
            } else {
                i
            };
            if i < 0 || j < 0 || k < 0 || i >= cx as isize || j >= cy as isize || k >= cz as isize {
                return false;
            }
            kept[i as usize + cx * (j as usize + cy * k as usize)]
        };
        let interior_grid: Vec<bool> = (0..npts)
            .into_par_iter()
            .map(|g| {
                let (i, j, k) = (
                    (g % px) as isize,
                    ((g / px) % py) as isize,
                    (g / (px * py)) as isize,
                );
                (0..8).all(|q| cell_kept(i - 1 + (q & 1), j - 1 + ((q >> 1) & 1), k - 1 + (q >> 2)))
            })
            .collect();
        let grid_pos = |g: usize| point([g % px, (g / px) % py, g / (px * py)]);
        let (positions, interior) = if all_kept {
            (
                (0..npts).into_par_iter().map(grid_pos).collect::<Vec<_>>(),
                interior_grid,
            )
        } else {
            let mut used = vec![false; npts];
            for t in &tets {
                for &v in t {
                    used[v as usize] = true;
                }
            }
            let mut remap = vec![u32::MAX; npts];
            let mut keep_ids = Vec::new();
            for g in 0..npts {
                if used[g] {
                    remap[g] = keep_ids.len() as u32;
                    keep_ids.push(g);
                }
            }
            tets.par_iter_mut()
                .for_each(|t| *t = t.map(|v| remap[v as usize]));
            (
                keep_ids.par_iter().map(|&g| grid_pos(g)).collect(),
                keep_ids.iter().map(|&g| interior_grid[g]).collect(),
            )
        };
        let mut built = Built {
            positions,
            tets,
            interior,
        };
        orient_majority(&built.positions, &mut built.tets);
        built
    }
}

/// Flips every tet (swaps its last two vertices) when most tets are negatively oriented, as
/// after an orientation-reversing map. Tets of the other sign are left as they are, so a map
/// that folds the mesh still shows up as negative volumes.
pub fn orient_majority(positions: &[DVec3], tets: &mut [[u32; 4]]) {
    let negative = tets
        .par_iter()
        .filter(|t| signed_volume6(t.map(|v| positions[v as usize])) < 0.0)
        .count();
    if 2 * negative > tets.len() {
        tets.par_iter_mut().for_each(|t| t.swap(2, 3));
    }
}

/// A cube lattice of `cells` cells over the box `origin + [0, cells·spacing]`: vertex
/// `i + nx (j + ny k)` at `origin + spacing·(i, j, k)` (`n = cells + 1`), tets of cell
/// `c = i + cx (j + cy k)` at `per_cell·c .. per_cell·(c + 1)`.
pub fn cc_lattice(
    cells: [usize; 3],
    split: Split,
    origin: DVec3,
    spacing: DVec3,
) -> (Built, Lattice) {
    let block = Block::new(cells, split);
    let built = block.build(&|_| true, &|[i, j, k]| {
        origin + spacing * DVec3::new(i as f64, j as f64, k as f64)
    });
    let lattice = Lattice {
        kind: if split == Split::Five {
            LatticeKind::Cc5
        } else {
            LatticeKind::Cc6
        },
        n: block.points(),
        origin,
        spacing,
    };
    (built, lattice)
}

/// Boundary faces of a BCC lattice with `n` primary points per axis, counted from the
/// lattice's structure (not from its tets): every boundary face is a secondary edge along some
/// axis `b` with a primary point `p` beside it, at offsets `σ_a`, `σ_c` along the other two axes.
/// That face lies in the octahedra of the primary edges `p → p + σ_a e_a` and `p → p + σ_c e_c`
/// and is on the boundary when exactly one of the two edges exists.
pub fn bcc_boundary_faces(n: [usize; 3]) -> usize {
    let exists = |p: [usize; 3], axis: usize, up: bool| {
        if up {
            p[axis] + 1 < n[axis]
        } else {
            p[axis] >= 1
        }
    };
    let mut count = 0;
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let p = [i, j, k];
                for b in 0..3 {
                    let (a, c) = ((b + 1) % 3, (b + 2) % 3);
                    for sa in [false, true] {
                        for sc in [false, true] {
                            if exists(p, a, sa) != exists(p, c, sc) {
                                count += 1;
                            }
                        }
                    }
                }
            }
        }
    }
    count
}

/// The BCC lattice as a tetrahedral mesh (the Delaunay tetrahedralization of the body-centred
/// cubic grid, BCC paper §4): primary points `origin + spacing·(i, j, k)` for `i < nx` …;
/// secondary points `origin + spacing·(i − ½, j − ½, k − ½)` for `i ≤ nx` … (half a cell
/// beyond the primary box on every side, less the 8 corner points no tet uses). Every
/// primary edge `q → q + e_a` is the axis of an octahedron with the four secondary points
/// around its midpoint, split into 4 tets, each with the two primary points and one edge of
/// the secondary square: 2 primary + 2 secondary samples per tet, 12 tets per primary point.
/// Returns the positions and tets (in the order of [`bcc_tet_index`]) and the lattice.
pub fn bcc_lattice(
    n: [usize; 3],
    origin: DVec3,
    spacing: DVec3,
) -> (Vec<DVec3>, Vec<[u32; 4]>, Lattice) {
    let [nx, ny, nz] = n;
    assert!(nx >= 1 && ny >= 1 && nz >= 1);
    let nprim = nx * ny * nz;
    let s = [nx + 1, ny + 1, nz + 1];
    let nsec = s[0] * s[1] * s[2];
    let is_corner = |i: usize, j: usize, k: usize| {
        (i == 0 || i == nx) && (j == 0 || j == ny) && (k == 0 || k == nz)
    };
    // Secondary grid index → vertex index (corners dropped).
    let mut sec_id = vec![u32::MAX; nsec];
    let mut positions: Vec<DVec3> = (0..nprim)
        .into_par_iter()
        .map(|g| {
            let (i, j, k) = (g % nx, (g / nx) % ny, g / (nx * ny));
            origin + spacing * DVec3::new(i as f64, j as f64, k as f64)
        })
        .collect();
    positions.reserve(nsec);
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                if !is_corner(i, j, k) {
                    sec_id[i + s[0] * (j + s[1] * k)] = positions.len() as u32;
                    positions.push(
                        origin
                            + spacing * DVec3::new(i as f64 - 0.5, j as f64 - 0.5, k as f64 - 0.5),
                    );
                }
            }
        }
    }
    let mut tets: Vec<[u32; 4]> = Vec::with_capacity(bcc_num_tets(n));
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let mut m = n;
        m[a] -= 1;
        let nedges = m[0] * m[1] * m[2];
        let block: Vec<[u32; 4]> = (0..nedges)
            .into_par_iter()
            .flat_map_iter(|e| {
                let q = [e % m[0], (e / m[0]) % m[1], e / (m[0] * m[1])];
                let p0 = (q[0] + nx * (q[1] + ny * q[2])) as u32;
                let mut q1 = q;
                q1[a] += 1;
                let p1 = (q1[0] + nx * (q1[1] + ny * q1[2])) as u32;
                // Secondary square at s_a = q_a + 1, (s_b, s_c) ∈ {q_b, q_b+1} × {q_c, q_c+1}.
                let sq = |db: usize, dc: usize| {
                    let mut t = [0usize; 3];
                    t[a] = q[a] + 1;
                    t[b] = q[b] + db;
                    t[c] = q[c] + dc;
                    sec_id[t[0] + s[0] * (t[1] + s[1] * t[2])]
                };
                // Counter-clockwise around the axis in the right-handed (b, c) frame.
                let ring = [sq(0, 0), sq(1, 0), sq(1, 1), sq(0, 1)];
                (0..4).map(move |u| [p0, p1, ring[u], ring[(u + 1) % 4]])
            })
            .collect();
        tets.extend(block);
    }
    let lattice = Lattice {
        kind: LatticeKind::Bcc,
        n,
        origin,
        spacing,
    };
    (positions, tets, lattice)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_are_positive_and_fill_the_cube() {
        for split in [Split::Five, Split::Six] {
            for pat in patterns(split) {
                let mut total = 0.0;
                for t in &pat {
                    let v = signed_volume6(t.map(corner));
                    assert!(v > 0.0);
                    total += v / 6.0;
                }
                assert!((total - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn bcc_index_matches_layout() {
        let n = [3, 4, 2];
        let (p, tets, _) = bcc_lattice(n, DVec3::ZERO, DVec3::ONE);
        assert_eq!(tets.len(), bcc_num_tets(n));
        for a in 0..3 {
            for k in 0..n[2] {
                for j in 0..n[1] {
                    for i in 0..n[0] {
                        let q = [i, j, k];
                        for sub in 0..4 {
                            let Some(t) = bcc_tet_index(n, q, a, sub) else {
                                assert_eq!(q[a] + 1, n[a]);
                                continue;
                            };
                            let p0 = DVec3::new(i as f64, j as f64, k as f64);
                            let mut e = DVec3::ZERO;
                            e[a] = 1.0;
                            assert_eq!(p[tets[t][0] as usize], p0);
                            assert_eq!(p[tets[t][1] as usize], p0 + e);
                        }
                    }
                }
            }
        }
    }
}
