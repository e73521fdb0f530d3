//! Loaders stream: reading a mesh file peaks at no more than the mesh it makes plus 10 %,
//! measured by the counting allocator on a generated mesh written in each format.
//!
//! One test in this binary, so that nothing else allocates while it measures.

use algorithms::io::{self, LoadOptions, Split};
use algorithms::mesh::{Field, Mesh};
use algorithms::util::alloc::{measure, CountingAlloc};
use glam::DVec3;

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// A jittered lattice of `n`³ cells (6 tets each) with two fields, the second of two steps.
fn lattice(n: usize) -> Mesh {
    let p = n + 1;
    let mut positions = Vec::with_capacity(p * p * p);
    for k in 0..p {
        for j in 0..p {
            for i in 0..p {
                let h = ((i * 73 + j * 151 + k * 283) % 97) as f64 / 970.0;
                positions.push(DVec3::new(i as f64 + h, j as f64 - h, k as f64 + 0.5 * h));
            }
        }
    }
    let tets = io::split::split_structured("lattice", [p, p, p], &positions, Split::Six).unwrap();
    let f = |s: f64| -> Vec<f64> { positions.iter().map(|q| (q.x * s).sin() + q.z).collect() };
    let fields = vec![
        Field {
            name: "density".into(),
            steps: vec![f(0.3)],
        },
        Field {
            name: "pressure".into(),
            steps: vec![f(0.7), f(1.1)],
        },
    ];
    let mut m = Mesh::new("lattice", positions, tets, fields).unwrap();
    m.field_data.insert("mach".into(), vec![0.5]);
    m
}

/// The lattice's grid as a PLOT3D whole single-grid pair (little-endian float64, no record
/// markers): `path` (xyz) and the q file beside it.
fn write_plot3d(m: &Mesh, side: usize, path: &std::path::Path) {
    use std::io::Write;
    let dims = [side as i32; 3];
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for d in dims {
        w.write_all(&d.to_le_bytes()).unwrap();
    }
    for c in 0..3 {
        for p in m.positions() {
            w.write_all(&p[c].to_le_bytes()).unwrap();
        }
    }
    w.flush().unwrap();
    let q = io::plot3d::q_path(path).unwrap();
    let mut w = std::io::BufWriter::new(std::fs::File::create(q).unwrap());
    for d in dims {
        w.write_all(&d.to_le_bytes()).unwrap();
    }
    for h in [0.5f64, 1.0, 1e6, 0.0] {
        w.write_all(&h.to_le_bytes()).unwrap();
    }
    for k in 0..5 {
        for (i, s) in m.scalars().iter().enumerate() {
            let v = if k == 0 {
                1.0 + s.abs()
            } else {
                s * k as f64 + i as f64
            };
            w.write_all(&v.to_le_bytes()).unwrap();
        }
    }
    w.flush().unwrap();
}

/// Each format written from a 384K-tet mesh (9 MB) and read back: the same mesh, with a peak heap of
/// at most the mesh's bytes and 10 %.
#[test]
fn loaders_peak_at_the_mesh_and_a_tenth() {
    let side = 40;
    let mesh = lattice(side);
    let dir = std::env::temp_dir().join(format!("tetbench-loader-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["off", "vtu", "vtk", "xyz"] {
        let path = dir.join(format!("m.{ext}"));
        let mut opts = LoadOptions::default();
        if ext == "xyz" {
            write_plot3d(&mesh, side + 1, &path);
            opts.split = Some(Split::Six);
        } else {
            io::write(&mesh, &path).unwrap();
        }
        let (back, _, peak) = measure(|| io::load_path(&path, &opts).unwrap());
        assert_eq!(back.tets(), mesh.tets(), "{ext}");
        assert_eq!(back.positions(), mesh.positions(), "{ext}");
        let bytes = back.data_bytes() as f64;
        let ratio = peak as f64 / bytes;
        println!("{ext}: peak {peak} bytes for a mesh of {bytes} bytes ({ratio:.3}×)");
        assert!(
            ratio <= 1.10,
            "{ext}: peak {peak} bytes, {ratio:.3}× the mesh's {bytes}"
        );
        drop(back);
        std::fs::remove_file(&path).unwrap();
        if ext == "xyz" {
            std::fs::remove_file(io::plot3d::q_path(&path).unwrap()).unwrap();
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
