//! Criterion benches of the ray caster's stages, each on its own: `prepare` (cell
//! links, boundary orientation, BVH), one frame of `raycast` (partial) and one of `reference`
//! (exact), at 256² on a 200K-tet `spx2` analogue (generated, no download), and the same frames
//! on blunt when the NASA data is found. The frame's counters (cell steps, filter fallbacks)
//! are printed once so a change in work is told apart from a change in speed.
//! Run: `cargo bench -p tetbench --bench raycast`.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io::{self, LoadOptions};
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn frames(c: &mut Criterion, label: &str, mesh: &Mesh) {
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        256,
        256,
    );
    let mut g = c.benchmark_group(format!("raycast/{label}"));
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    g.throughput(Throughput::Elements(mesh.num_tets() as u64));
    g.bench_function("prepare", |b| {
        let mut rc = render::make("raycast", &RenderOptions::default()).unwrap();
        b.iter(|| rc.prepare(mesh, &tf).unwrap())
    });
    for name in ["raycast", "reference"] {
        let mut rc = render::make(name, &RenderOptions::default()).unwrap();
        rc.prepare(mesh, &tf).unwrap();
        let counters = rc.render(mesh, &cam).unwrap().counters;
        eprintln!("{label} {name}: {counters:?}");
        g.bench_function(format!("{name}-frame-256"), |b| {
            b.iter(|| rc.render(mesh, &cam).unwrap().image.pixels.len())
        });
    }
    g.finish();
}

fn raycast(c: &mut Criterion) {
    let spx = datasets_gen::generate("spx2", Some(200_000), 1).unwrap();
    frames(c, "spx2-200k", &spx);
    if let Some(Ok(_)) = io::resolve_short_name("blunt") {
        let blunt = io::load("blunt", &LoadOptions::default()).unwrap();
        frames(c, "blunt", &blunt);
    }
}

criterion_group!(benches, raycast);
criterion_main!(benches);
