//! VTK legacy `.vtk` writer: version 5.1 (`OFFSETS`/`CONNECTIVITY`, read by VTK 9 and ParaView
//! 5.9 on), binary big-endian, lossless: double points and fields, 64-bit cell indices.
//!
//! The mesh's field data is a dataset `FIELD`. The point data holds every field in the mesh's
//! order (each time step as `name_tNNN`): the active one as `SCALARS` (what VTK and ParaView
//! colour by, and what tetbench's reader makes active), the others in `FIELD` blocks around it.
//! Array names are written with VTK's `%XX` escapes for spaces and other bytes a legacy name
//! cannot hold, which VTK's reader and tetbench's decode.

use std::io::Write;
use std::path::Path;

use crate::error::Result;
use crate::io::{fields, vtk_types};
use crate::mesh::Mesh;

/// A name as a legacy file holds it: bytes outside `!`..`~`, and `%`, as `%XX` (what VTK's
/// `vtkDataWriter::EncodeString` does).
pub fn encode_name(name: &str) -> String {
    let mut o = String::with_capacity(name.len());
    for b in name.bytes() {
        if b <= b' ' || b > b'~' || b == b'%' {
            o.push_str(&format!("%{b:02X}"));
        } else {
            o.push(b as char);
        }
    }
    if o.is_empty() {
        o.push_str("%00");
    }
    o
}

fn f64s(w: &mut dyn Write, v: &[f64]) -> std::io::Result<()> {
    v.iter().try_for_each(|x| w.write_all(&x.to_be_bytes()))?;
    w.write_all(b"\n")
}

/// Writes `mesh` as a legacy `.vtk` (see the module docs), through a temporary file.
pub fn write_vtk(mesh: &Mesh, path: &Path) -> Result<()> {
    let n = mesh.num_vertices();
    let nt = mesh.num_tets();
    // Every point array in the mesh's order, and which one is active.
    let active = super::active_name(mesh);
    let arrays: Vec<(String, &[f64])> = mesh
        .fields()
        .iter()
        .flat_map(|f| {
            f.steps
                .iter()
                .enumerate()
                .map(|(k, s)| (fields::step_name(&f.name, k, f.steps.len()), s.as_slice()))
        })
        .collect();
    let at = arrays.iter().position(|(name, _)| *name == active);
    crate::io::atomic_write(path, |w| {
        writeln!(w, "# vtk DataFile Version 5.1")?;
        writeln!(w, "tetbench mesh: {n} points, {nt} tetrahedra")?;
        writeln!(w, "BINARY\nDATASET UNSTRUCTURED_GRID")?;
        if !mesh.field_data.is_empty() {
            writeln!(w, "FIELD FieldData {}", mesh.field_data.len())?;
            for (name, v) in &mesh.field_data {
                writeln!(w, "{} 1 {} double", encode_name(name), v.len())?;
                f64s(w, v)?;
            }
        }
        writeln!(w, "POINTS {n} double")?;
        for p in mesh.positions() {
            for c in p.to_array() {
                w.write_all(&c.to_be_bytes())?;
            }
        }
        writeln!(w)?;
        writeln!(w, "CELLS {} {}", nt + 1, 4 * nt)?;
        writeln!(w, "OFFSETS vtktypeint64")?;
        for i in 0..=nt as i64 {
            w.write_all(&(4 * i).to_be_bytes())?;
        }
        writeln!(w)?;
        writeln!(w, "CONNECTIVITY vtktypeint64")?;
        for t in mesh.tets() {
            for &v in t {
                w.write_all(&(v as i64).to_be_bytes())?;
            }
        }
        writeln!(w)?;
        writeln!(w, "CELL_TYPES {nt}")?;
        for _ in 0..nt {
            w.write_all(&(vtk_types::VTK_TETRA as i32).to_be_bytes())?;
        }
        writeln!(w)?;
        writeln!(w, "POINT_DATA {n}")?;
        let (before, after) = match at {
            Some(i) => (&arrays[..i], &arrays[i + 1..]),
            None => (&arrays[..], &arrays[arrays.len()..]),
        };
        let field = |w: &mut dyn Write, block: &[(String, &[f64])]| -> std::io::Result<()> {
            if block.is_empty() {
                return Ok(());
            }
            writeln!(w, "FIELD FieldData {}", block.len())?;
            for (name, v) in block {
                writeln!(w, "{} 1 {n} double", encode_name(name))?;
                f64s(w, v)?;
            }
            Ok(())
        };
        field(w, before)?;
        if let Some(i) = at {
            writeln!(w, "SCALARS {} double 1", encode_name(&arrays[i].0))?;
            writeln!(w, "LOOKUP_TABLE default")?;
            f64s(w, arrays[i].1)?;
        }
        field(w, after)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_escaped_as_vtk_does() {
        assert_eq!(encode_name("density"), "density");
        assert_eq!(encode_name("T <&\"x\">"), "T%20<&\"x\">");
        assert_eq!(encode_name("50%"), "50%25");
        assert_eq!(encode_name("é"), "%C3%A9");
        assert_eq!(encode_name(""), "%00");
    }
}
