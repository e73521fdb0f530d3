//! Mesh files (CONVENTIONS §9): readers for tetrahedral `.off`, VTK legacy `.vtk`, VTK XML `.vtu`
//! and PLOT3D structured grids; writers for `.off` and `.vtu`. Every reader returns
//! `Error::Input` with one line naming the file and the line or field at fault.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// How hexahedra (structured grids, PLOT3D) are split into tetrahedra.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// 5 tets per hex, mirrored on alternating cells so that faces conform.
    Five,
    /// 6 tets per hex around the main diagonal (Kuhn), conforming by translation.
    Six,
}

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Split non-tet cells. PLOT3D grids are always split (5 per hex unless this says 6);
    /// `.vtk`/`.vtu` files with non-tet cells are refused unless this is set.
    pub split: Option<Split>,
    /// Which scalar field to make active (a point-data array name, or for PLOT3D one of
    /// density, energy, velocity, momentum-x, momentum-y, momentum-z).
    pub scalar: Option<String>,
    /// PLOT3D q file, when it is not the xyz file's name with `xyz` replaced by `q`.
    pub q_file: Option<PathBuf>,
    /// Accept a `.off` file whose indices are 1-based (refused otherwise, with a message).
    pub one_based: bool,
}
