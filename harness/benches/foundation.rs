//! Loading and the reference ray caster on `post` (falls back to the `post-like` analogue when
//! the NASA files are absent), and the builds every run pays for once: generating `fighter`
//! (1.4M tets), the pre-integration table and the Ψ table. Run:
//! `cargo bench -p tetbench --bench foundation`.
//!
//! Besides criterion's timings it prints the counters that tell work from speed: cell steps per frame
//! (for cell-steps/s) and the ray caster's measured heap bytes per tet.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io::{self, LoadOptions};
use algorithms::optics::{PreintTable, PsiTable};
use algorithms::render::{self, RenderOptions};
use algorithms::util::alloc::{self, CountingAlloc};
use algorithms::{Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

fn post() -> (Mesh, &'static str) {
    match io::load("post", &LoadOptions::default()) {
        Ok(m) => (m, "post"),
        Err(e) => {
            eprintln!("{e}; using the post-like analogue");
            (
                datasets_gen::generate("post-like", None, 1).unwrap(),
                "post-like",
            )
        }
    }
}

fn load(c: &mut Criterion) {
    if io::resolve_short_name("post").is_some_and(|r| r.is_ok()) {
        let mut g = c.benchmark_group("load");
        g.sample_size(10).measurement_time(Duration::from_secs(10));
        g.bench_function("post+adjacency", |b| {
            b.iter(|| {
                let m = io::load("post", &LoadOptions::default()).unwrap();
                m.adjacency();
                m
            })
        });
        g.finish();
    }
}

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let m = datasets_gen::generate("fighter", None, 0).unwrap();
    println!(
        "fighter: {} tets, {} vertices ({} threads)",
        m.num_tets(),
        m.num_vertices(),
        rayon::current_num_threads()
    );
    drop(m);
    g.bench_function("generate-fighter", |b| {
        b.iter(|| datasets_gen::generate("fighter", None, 0).unwrap())
    });
    let tf = TransferFunction::preset("default").unwrap();
    g.bench_function("preint-table-default-tf", |b| {
        b.iter(|| PreintTable::new(&tf))
    });
    g.bench_function("psi-table-512", |b| b.iter(|| PsiTable::new(512)));
    g.finish();
}

fn raycast(c: &mut Criterion) {
    let (mesh, name) = post();
    let tf = TransferFunction::preset("default").unwrap();
    let (w, h) = (512u32, 512u32);
    let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), Projection::Ortho, w, h);
    let mut g = c.benchmark_group(format!("raycast-{name}-512"));
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for integ in ["partial", "exact"] {
        let opts = RenderOptions {
            integrator: Some(integ.into()),
            ..Default::default()
        };
        let mut r = render::make("raycast", &opts).unwrap();
        let fresh = mesh.clone(); // empty caches: adjacency is counted as the renderer's
        rayon::broadcast(|_| ());
        let (res, bytes, _) = alloc::measure(|| r.prepare(&fresh, &tf));
        res.unwrap();
        let frame = r.render(&fresh, &cam).unwrap();
        let steps = frame
            .counters
            .iter()
            .find(|(k, _)| *k == "cell_steps")
            .map(|c| c.1)
            .unwrap_or(0.0);
        println!(
            "raycast/{integ} on {name}: {} tets, cpu_bytes_per_tet {:.1}, cell_steps per frame {steps}, one frame {:.1} ms = {:.0} rays/s, {:.3e} cell-steps/s",
            fresh.num_tets(),
            bytes as f64 / fresh.num_tets() as f64,
            frame.times.total_ms,
            (w * h) as f64 / (frame.times.total_ms * 1e-3),
            steps / (frame.times.total_ms * 1e-3)
        );
        g.throughput(Throughput::Elements((w * h) as u64));
        // cell-steps/s = rays/s × cell_steps / rays (printed above).
        g.bench_function(integ, |b| b.iter(|| r.render(&fresh, &cam).unwrap()));
    }
    g.finish();
}

criterion_group!(benches, load, build, raycast);
criterion_main!(benches);
