//! Loader throughput in MB/s from a warm page cache: a 1M-tet `brain` analogue written as
//! `.off`, `.vtu` and `.vtk`, and a 1M-point PLOT3D grid, each read back by `io::load_path`
//! (the file is read once before timing, so the page cache holds it). Run:
//! `cargo bench -p tetbench --bench loaders`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use algorithms::io::{self, LoadOptions};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// A whole single-grid PLOT3D pair (little-endian float64, no record markers) of `side`³
/// points, with a smooth q: `path` and the q file beside it.
fn write_plot3d(side: usize, path: &Path) {
    let n = side * side * side;
    let dims = [side as i32; 3];
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    dims.iter()
        .for_each(|d| w.write_all(&d.to_le_bytes()).unwrap());
    for c in 0..3 {
        for g in 0..n {
            let ijk = [g % side, (g / side) % side, g / (side * side)];
            w.write_all(&(ijk[c] as f64 * 0.01).to_le_bytes()).unwrap();
        }
    }
    w.flush().unwrap();
    let mut w =
        std::io::BufWriter::new(std::fs::File::create(io::plot3d::q_path(path).unwrap()).unwrap());
    dims.iter()
        .for_each(|d| w.write_all(&d.to_le_bytes()).unwrap());
    [0.5f64, 1.0, 1e6, 0.0]
        .iter()
        .for_each(|h| w.write_all(&h.to_le_bytes()).unwrap());
    for k in 0..5 {
        for g in 0..n {
            w.write_all(&(1.0 + (g % 97) as f64 * 0.01 + k as f64).to_le_bytes())
                .unwrap();
        }
    }
    w.flush().unwrap();
}

fn loaders(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("tetbench-bench-loaders-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = datasets_gen::generate("brain", Some(1_000_000), 1).unwrap();
    let mut files: Vec<(String, PathBuf, u64)> = Vec::new();
    for ext in ["off", "vtu", "vtk"] {
        let p = dir.join(format!("brain.{ext}"));
        io::write(&mesh, &p).unwrap();
        let len = std::fs::metadata(&p).unwrap().len();
        files.push((ext.to_string(), p, len));
    }
    drop(mesh);
    let xyz = dir.join("grid.xyz");
    write_plot3d(100, &xyz);
    let len = std::fs::metadata(&xyz).unwrap().len()
        + std::fs::metadata(io::plot3d::q_path(&xyz).unwrap())
            .unwrap()
            .len();
    files.push(("plot3d".into(), xyz, len));
    let mut g = c.benchmark_group("load");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (name, path, len) in &files {
        // Warm the page cache.
        io::load_path(path, &LoadOptions::default()).unwrap();
        g.throughput(Throughput::Bytes(*len));
        g.bench_function(name.as_str(), |b| {
            b.iter(|| io::load_path(path, &LoadOptions::default()).unwrap())
        });
    }
    g.finish();
    std::fs::remove_dir_all(&dir).ok();
}

criterion_group!(benches, loaders);
criterion_main!(benches);
