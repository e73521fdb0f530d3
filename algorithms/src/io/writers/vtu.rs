//! VTK XML `.vtu` writer: appended raw little-endian data with UInt64 headers, Float64 points,
//! fields (every step) and field data, Int64 connectivity and offsets, UInt8 types: lossless.
//! The active field is the point data's `Scalars`.
//!
//! The XML header gives each array's offset into the appended block, so the offsets are
//! computed from the sizes first; then the arrays stream from the mesh to the file.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use crate::error::Result;
use crate::io::{fields, vtk_types};
use crate::mesh::Mesh;

/// XML-escapes an attribute value.
fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            '\n' => o.push_str("&#10;"),
            '\r' => o.push_str("&#13;"),
            '\t' => o.push_str("&#9;"),
            c => o.push(c),
        }
    }
    o
}

/// Offsets of the arrays in the appended block: each is a UInt64 byte count and its bytes.
struct Offsets(u64);

impl Offsets {
    /// The offset of the next array of `bytes` bytes.
    fn next(&mut self, bytes: u64) -> u64 {
        let at = self.0;
        self.0 += 8 + bytes;
        at
    }
}

/// Writes `mesh` as a `.vtu` (see the module docs), through a temporary file.
pub fn write_vtu(mesh: &Mesh, path: &Path) -> Result<()> {
    let n = mesh.num_vertices() as u64;
    let nt = mesh.num_tets() as u64;
    let mut off = Offsets(0);
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\"?>\n");
    x.push_str("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
    x.push_str("  <UnstructuredGrid>\n");
    if !mesh.field_data.is_empty() {
        x.push_str("    <FieldData>\n");
        for (name, v) in &mesh.field_data {
            let _ = writeln!(
                x,
                "      <DataArray type=\"Float64\" Name=\"{}\" NumberOfTuples=\"{}\" format=\"appended\" offset=\"{}\"/>",
                esc(name),
                v.len(),
                off.next(8 * v.len() as u64)
            );
        }
        x.push_str("    </FieldData>\n");
    }
    let _ = writeln!(
        x,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{nt}\">"
    );
    let _ = writeln!(
        x,
        "      <PointData Scalars=\"{}\">",
        esc(&super::active_name(mesh))
    );
    for f in mesh.fields() {
        for k in 0..f.steps.len() {
            let _ = writeln!(
                x,
                "        <DataArray type=\"Float64\" Name=\"{}\" format=\"appended\" offset=\"{}\"/>",
                esc(&fields::step_name(&f.name, k, f.steps.len())),
                off.next(8 * n)
            );
        }
    }
    x.push_str("      </PointData>\n      <Points>\n");
    let _ = writeln!(
        x,
        "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"{}\"/>",
        off.next(24 * n)
    );
    x.push_str("      </Points>\n      <Cells>\n");
    for (ty, name, bytes) in [
        ("Int64", "connectivity", 32 * nt),
        ("Int64", "offsets", 8 * nt),
        ("UInt8", "types", nt),
    ] {
        let _ = writeln!(
            x,
            "        <DataArray type=\"{ty}\" Name=\"{name}\" format=\"appended\" offset=\"{}\"/>",
            off.next(bytes)
        );
    }
    x.push_str("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _");

    crate::io::atomic_write(path, |w| {
        w.write_all(x.as_bytes())?;
        let f64s = |w: &mut dyn Write, v: &[f64]| -> std::io::Result<()> {
            w.write_all(&(8 * v.len() as u64).to_le_bytes())?;
            v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes()))
        };
        for v in mesh.field_data.values() {
            f64s(w, v)?;
        }
        for f in mesh.fields() {
            for s in &f.steps {
                f64s(w, s)?;
            }
        }
        w.write_all(&(24 * n).to_le_bytes())?;
        for p in mesh.positions() {
            for c in p.to_array() {
                w.write_all(&c.to_le_bytes())?;
            }
        }
        w.write_all(&(32 * nt).to_le_bytes())?;
        for t in mesh.tets() {
            for &v in t {
                w.write_all(&(v as i64).to_le_bytes())?;
            }
        }
        w.write_all(&(8 * nt).to_le_bytes())?;
        for i in 1..=nt as i64 {
            w.write_all(&(4 * i).to_le_bytes())?;
        }
        w.write_all(&nt.to_le_bytes())?;
        for _ in 0..nt {
            w.write_all(&[vtk_types::VTK_TETRA])?;
        }
        w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Offsets into the appended block are 64-bit: arrays of 2³² − 1, 2³² and 2³² + 1 bytes
    /// (a 278M-tet mesh's connectivity is 8.9 GB) place the next array exactly past them.
    #[test]
    fn appended_offsets_pass_two_to_the_32_exactly() {
        const B: u64 = 1 << 32;
        for bytes in [B - 1, B, B + 1] {
            let mut off = Offsets(0);
            assert_eq!(off.next(bytes), 0);
            assert_eq!(off.next(bytes), 8 + bytes);
            assert_eq!(off.next(0), 16 + 2 * bytes);
        }
        let nt = 278_000_000u64;
        let mut off = Offsets(0);
        off.next(32 * nt);
        assert_eq!(off.next(8 * nt), 8 + 32 * nt);
    }
}
