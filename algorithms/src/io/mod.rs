//! Mesh files (CONVENTIONS §9): readers for tetrahedral `.off`, VTK legacy `.vtk`, VTK XML `.vtu`
//! and PLOT3D structured grids; writers for `.off`, `.vtk` and `.vtu` ([`writers`]). Every
//! reader returns `Error::Input` with one line naming the file and the line or field at fault.
//! Every file is read through [`files`] (regular files only, sizes bounded).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// How hexahedra (structured grids, PLOT3D) are split into tetrahedra (the patterns are
/// [`split::hex_split_pattern`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// 5 tets per hex (4 corner tets and a central one), mirrored on alternate cells (parity of
    /// `i + j + k`) so that the face diagonals of neighbouring cells agree.
    Five,
    /// 6 tets per hex around the main diagonal from corner 0 to corner 7 (Kuhn), conforming by
    /// translation.
    Six,
}

impl Split {
    /// Tets per hex of a structured grid: 5 or 6.
    pub fn per_cell(self) -> usize {
        match self {
            Split::Five => 5,
            Split::Six => 6,
        }
    }
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

pub mod fields;
pub mod files;
pub mod off;
pub mod plot3d;
pub mod split;
pub mod vtk;
pub mod vtk_types;
pub mod vtu;
pub mod writers;

pub use files::{atomic_write, open_input, read_input, read_input_string};
pub use plot3d::read_plot3d;
pub use vtk::read_vtk;
pub use vtu::read_vtu;
pub use writers::vtk::write_vtk;
pub use writers::vtu::write_vtu;

/// The NASA grids known by short name (CONVENTIONS §9): name, xyz file, default scalar.
pub const SHORT_NAMES: [(&str, &str, &str); 3] = [
    ("blunt", "bluntfinxyz.bin", "density"),
    ("post", "postxyz.bin", "velocity"),
    ("comb", "combxyz.bin", "density"),
];

/// Where the NASA grids are looked up: `$TETBENCH_DATA`, else every `shared/datasets` folder in
/// a folder above the current directory, the executable or this crate: `../shared/datasets`
/// beside the checkout, however deep the checkout sits below it.
pub fn data_dirs() -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if let Some(d) = std::env::var_os("TETBENCH_DATA") {
        dirs.push(PathBuf::from(d));
    }
    let mut starts: Vec<PathBuf> = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        starts.push(cwd);
    }
    if let Ok(exe) = std::env::current_exe() {
        starts.push(exe);
    }
    starts.push(PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    for s in starts {
        for anc in s.ancestors() {
            let cand = anc.join("shared").join("datasets");
            if cand.is_dir() && !dirs.contains(&cand) {
                dirs.push(cand);
            }
        }
    }
    dirs
}

/// Resolves a short name (`blunt`, `post`, `comb`) to its xyz file and default scalar, or says
/// where it looked.
pub fn resolve_short_name(name: &str) -> Option<Result<(PathBuf, &'static str)>> {
    let &(_, file, scalar) = SHORT_NAMES.iter().find(|(n, _, _)| *n == name)?;
    let dirs = data_dirs();
    for d in &dirs {
        let p = d.join(file);
        if p.is_file() {
            return Some(Ok((p, scalar)));
        }
    }
    let looked = if dirs.is_empty() {
        format!(
            "nowhere: $TETBENCH_DATA is not set and no shared/datasets directory is beside the checkout or the binary (searched upwards from {})",
            std::env::current_dir()
                .map(|d| d.display().to_string())
                .unwrap_or_else(|_| "the current directory".into())
        )
    } else {
        dirs.iter()
            .map(|d| d.join(file).display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    Some(Err(Error::Input(format!(
        "{name}: {file} not found (looked in: {looked}); get it from VTK's example data (Data/{file}) and set TETBENCH_DATA to its directory"
    ))))
}

/// Loads a mesh by path or short name, choosing the reader by extension.
pub fn load(name_or_path: &str, opts: &LoadOptions) -> Result<Mesh> {
    if let Some(found) = resolve_short_name(name_or_path) {
        let (path, scalar) = found?;
        let mut o = opts.clone();
        o.scalar.get_or_insert_with(|| scalar.to_string());
        return load_path(&path, &o);
    }
    load_path(Path::new(name_or_path), opts)
}

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Loads a mesh file, choosing the reader by extension (`.off`, `.vtk`, `.vtu`; PLOT3D when the
/// file name contains `xyz`).
pub fn load_path(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    if !path.exists() {
        return Err(Error::Input(format!("{}: no such file", path.display())));
    }
    let fname = path
        .file_name()
        .map(|f| f.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    // The vtk, vtu and PLOT3D readers apply `opts.scalar` themselves (including `name_tNNN`
    // time steps); `.off` has one field, which the option may only name.
    match extension(path).as_str() {
        "off" => {
            let mut mesh = off::read_off(path, opts)?;
            if let Some(s) = &opts.scalar {
                mesh.select_field(s, 0)
                    .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
            }
            Ok(mesh)
        }
        "vtk" => vtk::read_vtk(path, opts),
        "vtu" => vtu::read_vtu(path, opts),
        _ if fname.contains("xyz") => plot3d::read_plot3d(path, opts),
        e => Err(Error::Input(format!(
            "{}: unknown mesh format '.{e}' (known: .off, .vtk, .vtu, PLOT3D *xyz*)",
            path.display()
        ))),
    }
}

/// Writes a mesh, choosing the writer by extension (`.off`, `.vtk`, `.vtu`; see [`writers`]).
pub fn write(mesh: &Mesh, path: &Path) -> Result<()> {
    writers::write(mesh, path)
}
