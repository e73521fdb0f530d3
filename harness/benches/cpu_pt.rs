//! `cpu-pt` throughput at 512² on `post` (falls back to the `post-like` analogue when the NASA
//! files are absent), one group per visibility sort, with the default integrator `partial`.
//! Run: `cargo bench -p tetbench --bench cpu_pt`.
//!
//! Criterion reports tets/s (throughput = tets per frame); besides, for each sort the median
//! stage split of a few frames (project / sort / draw ms from the `Frame`, and `bin_ms` from
//! the counters) is printed.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io::{self, LoadOptions};
use algorithms::render::{self, Frame, RenderOptions};
use algorithms::{Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

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

fn counter(f: &Frame, name: &str) -> f64 {
    f.counters
        .iter()
        .find(|(k, _)| *k == name)
        .map_or(0.0, |c| c.1)
}

fn cpu_pt(c: &mut Criterion) {
    let (mesh, name) = post();
    let tf = TransferFunction::preset("default").unwrap();
    let (w, h) = (512u32, 512u32);
    let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), Projection::Ortho, w, h);
    let tets = mesh.num_tets() as u64;
    let mut g = c.benchmark_group(format!("cpu-pt-{name}-512"));
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.throughput(Throughput::Elements(tets));
    for sort in ["centroid", "centroid-radix", "bucket", "mpvonc"] {
        let opts = RenderOptions {
            sort: Some(sort.into()),
            integrator: Some("partial".into()),
            ..Default::default()
        };
        let mut r = render::make("cpu-pt", &opts).unwrap();
        r.prepare(&mesh, &tf).unwrap();
        // Stage split: the median (by total) of 5 frames after a warm-up frame.
        r.render(&mesh, &cam).unwrap();
        let mut frames: Vec<Frame> = (0..5).map(|_| r.render(&mesh, &cam).unwrap()).collect();
        frames.sort_by(|a, b| a.times.total_ms.total_cmp(&b.times.total_ms));
        let f = &frames[frames.len() / 2];
        let t = f.times;
        println!(
            "cpu-pt/{sort}/partial on {name}: {tets} tets, {} threads: total {:.1} ms = {:.2} M tet/s \
             (project {:.1}, sort {:.1}, draw {:.1} of which bin {:.1}); fragments {}",
            rayon::current_num_threads(),
            t.total_ms,
            tets as f64 / t.total_ms / 1e3,
            t.project_ms,
            t.sort_ms,
            t.draw_ms,
            counter(f, "bin_ms"),
            counter(f, "fragments"),
        );
        g.bench_function(sort, |b| b.iter(|| r.render(&mesh, &cam).unwrap()));
    }
    g.finish();
}

criterion_group!(benches, cpu_pt);
criterion_main!(benches);
