//! Criterion benches of the exact visibility order beside the one it extends: `xmpvo`
//! (MPVONC's interior-face DAG plus the per-pixel boundary order across empty space) against
//! `mpvonc`, per frame, on a non-convex mesh (a 200K-tet `post-like`, generated, no download) at
//! 128² and 512², ortho and persp. The difference is the price of exactness: rasterising the
//! boundary at the image's resolution and the exterior edges. Run:
//! `cargo bench -p tetbench --bench visibility`.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::sort;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn visibility(c: &mut Criterion) {
    let mesh = datasets_gen::generate("post-like", Some(200_000), 1).unwrap();
    let mut g = c.benchmark_group("visibility");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    g.throughput(Throughput::Elements(mesh.num_tets() as u64));
    for (size, proj) in [
        (128, Projection::Ortho),
        (512, Projection::Ortho),
        (512, Projection::Persp),
    ] {
        let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), proj, size, size);
        for name in ["mpvonc", "xmpvo"] {
            let mut s = sort::make(name).unwrap();
            s.prepare(&mesh).unwrap();
            let mut order = Vec::new();
            let id = format!("{name}/{size}/{}", proj.name());
            g.bench_function(BenchmarkId::new("sort", id), |b| {
                b.iter(|| s.sort(&mesh, &cam, &mut order).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, visibility);
criterion_main!(benches);
