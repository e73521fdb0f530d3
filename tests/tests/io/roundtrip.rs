//! Lossless round trips between the mesh formats.

use algorithms::io::{self, LoadOptions};
use algorithms::Mesh;

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("tetbench-rt-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn same(a: &Mesh, b: &Mesh) {
    assert_eq!(a.num_vertices(), b.num_vertices());
    assert_eq!(a.tets(), b.tets());
    for (p, q) in a.positions().iter().zip(b.positions()) {
        assert_eq!(
            p.to_array().map(f64::to_bits),
            q.to_array().map(f64::to_bits)
        );
    }
    for (p, q) in a.scalars().iter().zip(b.scalars()) {
        assert_eq!(p.to_bits(), q.to_bits());
    }
}

/// Awkward numbers: thirds, tiny and huge magnitudes, negative zero, a 1e6 offset.
const OFF: &str = "6 3\n\
0.1 0.2 0.30000000000000004 0.3333333333333333\n\
1e6 -0 2.5e-300 -7.25\n\
0 1 0 1e30\n\
0 0 1 -1e-30\n\
1.0000000000000002 1 1 4\n\
-3 0.5 2 5\n\
0 1 2 3\n1 2 3 4\n0 2 5 3\n";

#[test]
fn off_to_vtu_to_off_is_lossless() {
    let d = tmp("off-vtu");
    let src = d.join("a.off");
    std::fs::write(&src, OFF).unwrap();
    let a = io::load_path(&src, &LoadOptions::default()).unwrap();
    io::write(&a, &d.join("b.vtu")).unwrap();
    let b = io::load_path(&d.join("b.vtu"), &LoadOptions::default()).unwrap();
    same(&a, &b);
    io::write(&b, &d.join("c.off")).unwrap();
    let c = io::load_path(&d.join("c.off"), &LoadOptions::default()).unwrap();
    same(&a, &c);
    // Written again, the .off text is byte-identical.
    io::write(&c, &d.join("d.off")).unwrap();
    assert_eq!(
        std::fs::read(d.join("c.off")).unwrap(),
        std::fs::read(d.join("d.off")).unwrap()
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn vtk_to_off_is_lossless() {
    let d = tmp("vtk-off");
    let vtk = "# vtk DataFile Version 4.2\nround trip\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 5 double\n0 0 0  1 0 0  0 1 0\n0 0 1  0.1 0.2 0.30000000000000004\n\
CELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\nCELL_TYPES 2\n10\n10\n\
POINT_DATA 5\nSCALARS temperature double 1\nLOOKUP_TABLE default\n0.5 1e-300 -2 3.3333333333333335 4\n";
    std::fs::write(d.join("a.vtk"), vtk).unwrap();
    let a = io::load_path(&d.join("a.vtk"), &LoadOptions::default()).unwrap();
    assert_eq!(a.active_field().0, "temperature");
    io::write(&a, &d.join("a.off")).unwrap();
    let b = io::load_path(&d.join("a.off"), &LoadOptions::default()).unwrap();
    same(&a, &b);
    std::fs::remove_dir_all(&d).ok();
}
