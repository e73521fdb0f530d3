//! The lattice description that travels with a lattice mesh (`mesh.field_data["lattice"]`), read
//! by the lattice sorts (`bcc-implicit` in the sort module) and written by `datasets-gen`, which
//! builds the meshes: one definition for both sides.
//!
//! `[kind, nx, ny, nz, ox, oy, oz, hx, hy, hz]`: kind 0 = `cc5`, 1 = `cc6`, 2 = `bcc`; grid
//! points per axis (for `bcc`, of the primary grid); the position of grid point (0, 0, 0); the
//! spacing along each axis. The vertex and tet numbering this implies is documented in
//! `datasets-gen`'s crate docs (and computed by [`bcc_tet_index`] for `bcc`).

use glam::DVec3;

use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// A lattice kind as stored in `field_data["lattice"][0]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LatticeKind {
    Cc5 = 0,
    Cc6 = 1,
    Bcc = 2,
}

/// The description of a lattice mesh that travels with it in `mesh.field_data["lattice"]` as
/// `[kind, nx, ny, nz, ox, oy, oz, hx, hy, hz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub kind: LatticeKind,
    /// Grid points per axis (for `bcc`, of the primary grid).
    pub n: [usize; 3],
    /// Position of grid point (0, 0, 0).
    pub origin: DVec3,
    /// Distance between neighbouring grid points along each axis.
    pub spacing: DVec3,
}

/// The `field_data` key of the lattice description.
pub const LATTICE_KEY: &str = "lattice";

impl Lattice {
    pub fn to_field_data(&self) -> Vec<f64> {
        vec![
            self.kind as u8 as f64,
            self.n[0] as f64,
            self.n[1] as f64,
            self.n[2] as f64,
            self.origin.x,
            self.origin.y,
            self.origin.z,
            self.spacing.x,
            self.spacing.y,
            self.spacing.z,
        ]
    }

    /// Reads the description back; `None` if `v` is not one.
    pub fn from_field_data(v: &[f64]) -> Option<Lattice> {
        if v.len() != 10 {
            return None;
        }
        if v[0].fract() != 0.0 {
            return None;
        }
        let kind = match v[0] as i64 {
            0 => LatticeKind::Cc5,
            1 => LatticeKind::Cc6,
            2 => LatticeKind::Bcc,
            _ => return None,
        };
        let count = |x: f64| (x >= 1.0 && x.fract() == 0.0).then_some(x as usize);
        Some(Lattice {
            kind,
            n: [count(v[1])?, count(v[2])?, count(v[3])?],
            origin: DVec3::new(v[4], v[5], v[6]),
            spacing: DVec3::new(v[7], v[8], v[9]),
        })
    }

    /// The description a mesh carries, checked against the mesh (tet and vertex counts, and
    /// the grid positions of the vertices the lattice numbering puts there): `who` names the
    /// caller in the one-line [`Error::Input`] when there is none or it does not fit.
    pub fn of_mesh(mesh: &Mesh, who: &str) -> Result<Lattice> {
        let bad = |why: String| Error::Input(format!("{who}: {why}"));
        let v = mesh.field_data.get(LATTICE_KEY).ok_or_else(|| {
            bad(
                "the mesh carries no lattice description (field data \"lattice\"); only \
                 meshes datasets-gen built on a cc5, cc6 or bcc lattice can be traversed"
                    .into(),
            )
        })?;
        let l = Lattice::from_field_data(v)
            .ok_or_else(|| bad(format!("malformed lattice description {v:?}")))?;
        let h = l.spacing;
        if !(h.x > 0.0 && h.y > 0.0 && h.z > 0.0 && h.is_finite() && l.origin.is_finite()) {
            return Err(bad(format!(
                "lattice spacing {h} must be positive and finite"
            )));
        }
        if l.n.iter().any(|&n| n < 2 && l.kind != LatticeKind::Bcc)
            || l.n.iter().any(|&n| n > 1 << 20)
        {
            return Err(bad(format!("lattice size {:?} out of range", l.n)));
        }
        let [nx, ny, nz] = l.n;
        let nverts = match l.kind {
            LatticeKind::Bcc => nx * ny * nz + (nx + 1) * (ny + 1) * (nz + 1) - 8,
            _ => nx * ny * nz,
        };
        if l.num_tets() != mesh.num_tets() || nverts != mesh.num_vertices() {
            return Err(bad(format!(
                "the lattice description ({:?}, {nx}x{ny}x{nz}: {} tets, {nverts} vertices) does \
                 not fit the mesh ({} tets, {} vertices)",
                l.kind,
                l.num_tets(),
                mesh.num_tets(),
                mesh.num_vertices()
            )));
        }
        // The primary (or only) grid comes first in the vertex order.
        let tol = 1e-6 * (h.x + h.y + h.z);
        let p = mesh.positions();
        for (g, &pg) in p.iter().enumerate().take(nx * ny * nz) {
            let ijk = DVec3::new(
                (g % nx) as f64,
                ((g / nx) % ny) as f64,
                (g / (nx * ny)) as f64,
            );
            if (pg - (l.origin + h * ijk)).abs().max_element() > tol {
                return Err(bad(format!(
                    "vertex {g} at {pg} is not at its lattice position; the mesh was changed \
                     after its lattice description was written"
                )));
            }
        }
        Ok(l)
    }

    /// Number of tets this lattice has.
    pub fn num_tets(&self) -> usize {
        let [nx, ny, nz] = self.n;
        match self.kind {
            LatticeKind::Cc5 => 5 * (nx - 1) * (ny - 1) * (nz - 1),
            LatticeKind::Cc6 => 6 * (nx - 1) * (ny - 1) * (nz - 1),
            LatticeKind::Bcc => bcc_num_tets(self.n),
        }
    }
}

/// Tets of a BCC lattice with `n` primary points per axis: 4 per primary edge.
pub fn bcc_num_tets(n: [usize; 3]) -> usize {
    let [nx, ny, nz] = n;
    4 * ((nx - 1) * ny * nz + nx * (ny - 1) * nz + nx * ny * (nz - 1))
}

/// Index of the tet of a BCC lattice with `n` primary points per axis that lies on the primary
/// edge from point `q` to `q + e_axis`, with secondary edge `sub` (0..4, see `datasets-gen`'s
/// crate docs); `None` when that edge leaves the lattice.
pub fn bcc_tet_index(n: [usize; 3], q: [usize; 3], axis: usize, sub: usize) -> Option<usize> {
    if q[axis] + 1 >= n[axis] || sub >= 4 || (0..3).any(|a| q[a] >= n[a]) {
        return None;
    }
    let mut m = n;
    m[axis] -= 1;
    Some(bcc_axis_offset(n, axis) + 4 * (q[0] + m[0] * (q[1] + m[1] * q[2])) + sub)
}

/// First tet of the block of primary edges along `axis` (x-edges, then y, then z).
pub fn bcc_axis_offset(n: [usize; 3], axis: usize) -> usize {
    (0..axis)
        .map(|a| {
            let mut ma = n;
            ma[a] -= 1;
            4 * ma[0] * ma[1] * ma[2]
        })
        .sum()
}
