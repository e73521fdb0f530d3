//! `tetbench convert` round trips: the NASA grids (with tetbench's 5-tet split) and a generated
//! mesh written as .vtu, .vtk and .off read back with the same tets, positions and scalars
//! (every field for .vtu and .vtk, the active one marked), the same `tetbench info`, and, when
//! the VTK venv is configured (`TETBENCH_VTK_PYTHON`), the same counts through VTK's readers.

use std::path::{Path, PathBuf};
use std::process::Command;

use tetbench::meshes::{load_mesh, MeshSpec};

use crate::test_util::{tetbench, tmpdir};

/// `tetbench info --json` of a mesh, without its timing.
fn info(mesh: &str) -> serde_json::Map<String, serde_json::Value> {
    let o = tetbench(&["info", mesh, "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut v: serde_json::Map<String, serde_json::Value> =
        serde_json::from_slice(&o.stdout).unwrap();
    v.remove("load_ms");
    v
}

/// The meshes to convert: a generated one always, the NASA grids when their files are here
/// (a failure instead when `TETBENCH_REQUIRE_DATA=1`).
fn meshes() -> Vec<&'static str> {
    let mut v = vec!["fighter:3000"];
    for n in ["blunt", "post", "comb"] {
        match algorithms::io::resolve_short_name(n) {
            Some(Ok(_)) => v.push(n),
            _ if std::env::var("TETBENCH_REQUIRE_DATA").is_ok_and(|x| x == "1") => {
                panic!("{n}: data not found and TETBENCH_REQUIRE_DATA=1")
            }
            _ => eprintln!("{n}: data not found, skipped"),
        }
    }
    v
}

/// What VTK's readers see in a file: cells, points and the active scalars' name.
fn vtk_sees(python: &Path, file: &Path) -> (usize, usize, String) {
    let script = r#"
import sys
from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
p = sys.argv[1]
r = vtkXMLUnstructuredGridReader() if p.endswith(".vtu") else vtkUnstructuredGridReader()
r.SetFileName(p)
r.Update()
g = r.GetOutput()
s = g.GetPointData().GetScalars()
print(g.GetNumberOfCells(), g.GetNumberOfPoints(), s.GetName() if s else "")
"#;
    let o = Command::new(python)
        .arg("-c")
        .arg(script)
        .arg(file)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let w: Vec<&str> = text.split_whitespace().collect();
    (
        w[0].parse().unwrap(),
        w[1].parse().unwrap(),
        w.get(2).unwrap_or(&"").to_string(),
    )
}

#[test]
fn converted_meshes_read_back_the_same() {
    let d = tmpdir("round");
    let vtk = std::env::var_os("TETBENCH_VTK_PYTHON").map(PathBuf::from);
    for name in meshes() {
        let want = load_mesh(&MeshSpec::named(name)).unwrap();
        let want_info = info(name);
        for ext in ["vtu", "vtk", "off"] {
            let out = d.join(format!("{}.{ext}", name.replace(':', "_")));
            let o = tetbench(&["convert", name, out.to_str().unwrap()]);
            assert!(
                o.status.success(),
                "{name} .{ext}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let stdout = String::from_utf8_lossy(&o.stdout);
            assert!(
                stdout.contains(&format!("tets: {}", want.num_tets())),
                "{stdout}"
            );
            let back = load_mesh(&MeshSpec::named(out.to_str().unwrap())).unwrap();
            assert_eq!(back.tets(), want.tets(), "{name} .{ext}");
            assert_eq!(back.positions(), want.positions(), "{name} .{ext}");
            assert_eq!(back.scalars(), want.scalars(), "{name} .{ext}");
            let mut got_info = info(out.to_str().unwrap());
            let mut expect = want_info.clone();
            if ext == "off" {
                // One field, unnamed in the format.
                for k in ["scalar_field", "fields"] {
                    got_info.remove(k);
                    expect.remove(k);
                }
            } else {
                assert_eq!(back.fields(), want.fields(), "{name} .{ext}");
                assert_eq!(back.active_field(), want.active_field(), "{name} .{ext}");
                assert_eq!(back.field_data, want.field_data, "{name} .{ext}");
            }
            assert_eq!(got_info, expect, "{name} .{ext}: tetbench info differs");
            if let (Some(py), true) = (&vtk, ext != "off") {
                let (cells, points, scalars) = vtk_sees(py, &out);
                assert_eq!((cells, points), (want.num_tets(), want.num_vertices()));
                let (field, step) = want.active_field();
                assert!(
                    scalars.starts_with(field),
                    "{name} .{ext}: VTK's scalars are {scalars}, want {field}[{step}]"
                );
            }
            std::fs::remove_file(&out).unwrap();
        }
    }
    // Nothing but the outputs was left in the folder (no temporary files).
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_outputs_are_one_line_and_leave_nothing() {
    let d = tmpdir("bad");
    let o = tetbench(&["convert", "spx", d.join("x.obj").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("x.obj: output must end in .vtu, .vtk, .off"),
        "{e}"
    );
    let o = tetbench(&[
        "convert",
        "spx",
        d.join("no/such/dir/x.vtu").to_str().unwrap(),
    ]);
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(String::from_utf8_lossy(&o.stderr).lines().count(), 1);
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&d);
}
