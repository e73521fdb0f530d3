//! VTK legacy `.vtk` reader: ASCII and BINARY (big-endian), `UNSTRUCTURED_GRID` with both
//! `CELLS` layouts (4.2 `k i0 … ik` records; 5.1 `OFFSETS`/`CONNECTIVITY` arrays) and
//! `STRUCTURED_GRID` (split into tets as asked), point `SCALARS` and `FIELD` arrays as named
//! fields; `VECTORS`, `NORMALS`, `CELL_DATA`, `METADATA` and the like are skipped.
//!
//! Hand-written rather than on the `vtkio` crate: vtkio is not among the crates this workspace
//! keeps (nor in the registry cache here), and what is needed is a reader we control: every
//! count checked against the bytes left before anything is allocated (fuzzed), both `CELLS`
//! layouts (the 5.1 one is recognised by its `OFFSETS` line), and one-line errors that name the
//! file, the line and the section.
//!
//! The file is read in three steps: the header ([`read_header`]), the sections, each keyword
//! read by its own function into [`sections::Sections`], and the mesh made of what they held
//! ([`sections::Sections::into_mesh`]). [`cursor::Cur`] reads the lines and the ASCII or
//! binary arrays. A BINARY 5.1 grid of tets, the large files' format, is read as a stream
//! instead ([`stream`]), a block at a time straight into the mesh.

use std::path::Path;

use crate::error::Result;
use crate::io::LoadOptions;
use crate::mesh::Mesh;

mod cursor;
mod sections;
mod stream;
#[cfg(test)]
pub(crate) mod tests;

use cursor::Cur;
use sections::Sections;

/// Reads a VTK legacy file (see the module docs): a BINARY 5.1 all-tet grid as a stream
/// ([`stream`]), any other file whole.
pub fn read_vtk(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let source = path.display().to_string();
    if let Some(mesh) = stream::stream_vtk(crate::io::open_input(path)?, &source, opts)? {
        return Ok(mesh);
    }
    let bytes = crate::io::read_input(path, crate::io::files::ANY_SIZE)?;
    parse_vtk(&bytes, &source, opts)
}

/// Parses a VTK legacy file held in memory; `source` names it in messages.
pub fn parse_vtk(bytes: &[u8], source: &str, opts: &LoadOptions) -> Result<Mesh> {
    let mut c = Cur::new(bytes, source);
    let structured = read_header(&mut c)?;
    let mut s = Sections::default();
    while let Some((l, w)) = c.keyword_line()? {
        if !w.is_empty() {
            s.read(&mut c, l, &w)?;
        }
    }
    s.into_mesh(&c, structured, opts)
}

/// Reads the four header lines: the version line, the title, `ASCII` or `BINARY` (which sets
/// the cursor's mode) and `DATASET`. Returns whether the data set is a `STRUCTURED_GRID`.
fn read_header(c: &mut Cur) -> Result<bool> {
    let header = c
        .raw_line()
        .map(|(_, s)| String::from_utf8_lossy(s).to_ascii_lowercase());
    let header = header.unwrap_or_default();
    if !header.trim().starts_with("# vtk datafile version") {
        return Err(c.err(
            1,
            "not a VTK legacy file (expected '# vtk DataFile Version X.Y')",
        ));
    };
    if c.raw_line().is_none() {
        return Err(c.err(2, "file ends before the title line"));
    }
    let Some((l, w)) = c.keyword_line()? else {
        return Err(c.err(c.line, "file ends before ASCII/BINARY"));
    };
    c.binary = match w.first().map(|s| s.to_ascii_uppercase()).as_deref() {
        Some("ASCII") => false,
        Some("BINARY") => true,
        _ => return Err(c.err(l, "expected ASCII or BINARY")),
    };
    let Some((l, w)) = c.keyword_line()? else {
        return Err(c.err(c.line, "file ends before DATASET"));
    };
    if w.len() < 2 || !w[0].eq_ignore_ascii_case("DATASET") {
        return Err(c.err(
            l,
            "expected 'DATASET UNSTRUCTURED_GRID' or 'DATASET STRUCTURED_GRID'",
        ));
    }
    match w[1].to_ascii_uppercase().as_str() {
        "UNSTRUCTURED_GRID" => Ok(false),
        "STRUCTURED_GRID" => Ok(true),
        other => Err(c.err(
            l,
            format!("DATASET {other} is not read (only UNSTRUCTURED_GRID and STRUCTURED_GRID)"),
        )),
    }
}
