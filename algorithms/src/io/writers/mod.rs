//! Mesh writers (CONVENTIONS §9): `.vtu` (VTK XML, appended raw), `.vtk` (VTK legacy 5.1,
//! binary) and `.off` ([`crate::io::off::write_off`]), chosen by extension.
//!
//! Every writer streams from the mesh into a buffered file: nothing is copied in memory, so a
//! mesh that fits once is written (the sizes the formats need up front are computed, not
//! measured). The file is written under a temporary name beside the target and renamed into
//! place ([`crate::io::atomic_write`]), so a failure leaves no half-written output.
//!
//! `.vtu` and `.vtk` hold every field (each time step as `name_tNNN`) with the active one
//! marked as the point data's scalars, and the mesh's field data; `.off` holds the active
//! field only.

use std::path::Path;

use crate::error::{Error, Result};
use crate::mesh::Mesh;

pub mod vtk;
pub mod vtu;

/// The formats a mesh can be written in, by extension.
pub const FORMATS: [&str; 3] = ["vtu", "vtk", "off"];

/// Writes `mesh` to `path`, the format chosen by its extension.
pub fn write(mesh: &Mesh, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "vtu" => vtu::write_vtu(mesh, path),
        "vtk" => vtk::write_vtk(mesh, path),
        "off" => crate::io::off::write_off(mesh, path),
        e => Err(Error::Input(format!(
            "{}: cannot write '.{e}' (known: .{})",
            path.display(),
            FORMATS.join(", .")
        ))),
    }
}

/// The active field's array name as the file names it (`name` or `name_tNNN`).
pub(crate) fn active_name(mesh: &Mesh) -> String {
    let (active, step) = mesh.active_field();
    let steps = mesh
        .fields()
        .iter()
        .find(|f| f.name == active)
        .map_or(1, |f| f.steps.len());
    crate::io::fields::step_name(active, step, steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::LoadOptions;
    use crate::mesh::Field;

    /// Every field's name and values, bit-exact.
    type FieldBits = Vec<(String, Vec<Vec<u64>>)>;
    /// The field data's names and values, bit-exact.
    type DataBits = Vec<(String, Vec<u64>)>;

    /// Bit-exact values of every field and of the field data.
    fn bits(m: &Mesh) -> (FieldBits, DataBits) {
        let fields = m
            .fields()
            .iter()
            .map(|f| {
                let steps = f
                    .steps
                    .iter()
                    .map(|s| s.iter().map(|v| v.to_bits()).collect())
                    .collect();
                (f.name.clone(), steps)
            })
            .collect();
        let data = m
            .field_data
            .iter()
            .map(|(k, v)| (k.clone(), v.iter().map(|x| x.to_bits()).collect()))
            .collect();
        (fields, data)
    }

    /// Every format reads back the same tets and positions bit for bit; .vtu and .vtk every
    /// field (time steps, names with spaces and markup, -0.0, extremes) with the active step
    /// marked, and the field data; .off the active field. A failed write leaves nothing.
    #[test]
    fn every_format_round_trips_losslessly() {
        let mut m = crate::io::vtu::tests::two_tets();
        m.add_field(Field {
            name: "T <&\"x\"> 50%".into(),
            steps: vec![
                vec![0.1, -0.0, 1e-300, f64::MAX, 3.0],
                vec![1.0 / 3.0; 5],
                vec![7.0, 6.0, 5.0, 4.0, 3.0],
            ],
        })
        .unwrap();
        m.select_field("T <&\"x\"> 50%", 2).unwrap();
        m.field_data.insert("empty".into(), vec![]);
        let dir = std::env::temp_dir().join(format!("tetbench-writers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for ext in FORMATS {
            let p = dir.join(format!("m.{ext}"));
            write(&m, &p).unwrap();
            let back = crate::io::load_path(&p, &LoadOptions::default()).unwrap();
            assert_eq!(back.tets(), m.tets(), "{ext}");
            let pos = |m: &Mesh| -> Vec<[u64; 3]> {
                m.positions()
                    .iter()
                    .map(|p| p.to_array().map(f64::to_bits))
                    .collect()
            };
            assert_eq!(pos(&back), pos(&m), "{ext}");
            let scal = |m: &Mesh| -> Vec<u64> { m.scalars().iter().map(|v| v.to_bits()).collect() };
            assert_eq!(scal(&back), scal(&m), "{ext}");
            if ext != "off" {
                assert_eq!(bits(&back), bits(&m), "{ext}");
                assert_eq!(back.active_field(), m.active_field(), "{ext}");
            }
            std::fs::remove_file(&p).unwrap();
        }
        assert!(write(&m, &dir.join("no/such/dir/x.vtk")).is_err());
        assert!(write(&m, &dir.join("x.obj")).is_err());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
