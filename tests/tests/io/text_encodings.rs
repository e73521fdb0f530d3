//! A UTF-8 byte-order mark is accepted by every text reader (`.off`, `.vtk`, `.vtu`, TF JSON),
//! and a `.vtk` file with CR-only line endings reads like its LF twin.

use algorithms::io::{self, LoadOptions};
use algorithms::{Mesh, TransferFunction};

const BOM: &str = "\u{feff}";

const OFF: &str = "5 2\n0 0 0 0\n1 0 0 1\n0 1 0 2\n0 0 1 3\n1 1 1 4\n0 1 2 3\n1 2 3 4\n";

const VTK: &str = "# vtk DataFile Version 3.0\ntwo tets\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\n\
CELL_TYPES 2\n10\n10\nPOINT_DATA 5\nSCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3 4\n";

const VTU: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="5" NumberOfCells="2">
      <PointData Scalars="s">
        <DataArray type="Float32" Name="s" format="ascii">0 1 2 3 4</DataArray>
      </PointData>
      <Points>
        <DataArray type="Float32" NumberOfComponents="3" format="ascii">
          0 0 0 1 0 0 0 1 0 0 0 1 1 1 1
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3 1 2 3 4</DataArray>
        <DataArray type="Int32" Name="offsets" format="ascii">4 8</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">10 10</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

fn load(dir: &std::path::Path, name: &str, text: &str) -> Mesh {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    io::load_path(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn same(a: &Mesh, b: &Mesh) {
    assert_eq!(a.tets(), b.tets());
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.scalars(), b.scalars());
}

#[test]
fn a_byte_order_mark_is_accepted_everywhere() {
    let d = tempfile::tempdir().unwrap();
    for (ext, text) in [("off", OFF), ("vtk", VTK), ("vtu", VTU)] {
        let plain = load(d.path(), &format!("plain.{ext}"), text);
        let bom = load(d.path(), &format!("bom.{ext}"), &format!("{BOM}{text}"));
        same(&plain, &bom);
        assert_eq!(plain.num_tets(), 2, "{ext}");
    }
    let json = r#"{"points":[{"s":0,"rgb":[0,0,0],"tau":1},{"s":1,"rgb":[1,1,1],"tau":2}]}"#;
    let a = TransferFunction::from_json(json, "t.json").unwrap();
    let b = TransferFunction::from_json(&format!("{BOM}{json}"), "t.json").unwrap();
    assert_eq!(a, b);
}

#[test]
fn vtk_with_cr_only_line_endings_reads() {
    let d = tempfile::tempdir().unwrap();
    let lf = load(d.path(), "lf.vtk", VTK);
    let cr = load(d.path(), "cr.vtk", &VTK.replace('\n', "\r"));
    same(&lf, &cr);
    let crlf = load(d.path(), "crlf.vtk", &VTK.replace('\n', "\r\n"));
    same(&lf, &crlf);
    // Messages still count lines: a bad cell type on line 12 of a CR-only file.
    let bad = VTK
        .replace("CELL_TYPES 2\n10\n10", "CELL_TYPES 2\n10\n77")
        .replace('\n', "\r");
    let p = d.path().join("bad.vtk");
    std::fs::write(&p, bad).unwrap();
    let e = io::load_path(&p, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("77"), "{e}");
}
