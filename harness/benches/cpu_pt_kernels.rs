//! Criterion benches of `cpu-pt`'s per-frame kernels, each on its own, on `post` at 512² (view
//! 30,20, ortho; the `post-like` analogue when the NASA files are absent):
//! - `tet` / `rows` / `per-pixel`: the whole-tet rasteriser of the fast path ([`TetRaster`]),
//!   the per-triangle rows it replaced ([`raster_fan_rows`] with their exact per-pixel tests)
//!   and the general path's [`raster_fan`], counting fragments;
//! - `shade-batch` / `shade-scalar`: `partial` on batches of real fragments' `(s_f, s_b, l)`,
//!   the dispatched lane kernel against the scalar definition;
//! - `frame`: one whole `cpu-pt` frame (centroid-radix, partial), whose stage split is printed.
//!
//! Throughput is per tet (rasteriser, frame) or per fragment (shading).
//! Run: `cargo bench -p tetbench --bench cpu_pt_kernels`.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io::{self, LoadOptions};
use algorithms::optics::fast::{FastIntegrator, ShadeBatch, BATCH};
use algorithms::render::pt::{
    classify, fan_bits, raster_fan, raster_fan_rows, wedge, FanGeometry, ProjVertex, TetRaster,
    Thick,
};
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn post() -> Mesh {
    io::load("post", &LoadOptions::default()).unwrap_or_else(|e| {
        eprintln!("{e}; using the post-like analogue");
        datasets_gen::generate("post-like", None, 1).unwrap()
    })
}

/// Every tet classified at the camera, with its fan geometry (ortho, the tf coordinate as in
/// the renderer).
fn classified(
    mesh: &Mesh,
    cam: &Camera,
    tf: &TransferFunction,
) -> Vec<(FanGeometry, Thick, [f64; 4])> {
    let c = mesh.bbox().center();
    let map = tf.scalar_map(mesh.scalar_range());
    let inv_l = 1.0 / mesh.diagonal();
    mesh.tets()
        .iter()
        .map(|t| {
            let v = t.map(|v| {
                let p = mesh.positions()[v as usize] - c;
                ProjVertex::project(cam, p, map.s(mesh.scalars()[v as usize]))
            });
            let th = classify(&v, false, inv_l);
            (FanGeometry::new(v.map(|p| p.q), &th), th, v.map(|p| p.s))
        })
        .collect()
}

fn cpu_pt_kernels(c: &mut Criterion) {
    let mesh = post();
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        512,
        512,
    );
    let tets = classified(&mesh, &cam, &tf);
    let clip = [0, 0, 511, 511];
    let mut g = c.benchmark_group("cpu-pt-kernels");
    g.sample_size(10).measurement_time(Duration::from_secs(5));

    g.throughput(Throughput::Elements(tets.len() as u64));
    g.bench_function("raster/rows", |b| {
        b.iter(|| {
            let mut frags = 0u64;
            for (f, _, _) in &tets {
                raster_fan_rows(f.case, &f.q, clip, |r| {
                    for k in 0..=(r.i1 - r.i0) {
                        frags += r.covers(k) as u64;
                    }
                });
            }
            frags
        })
    });
    g.bench_function("raster/tet", |b| {
        b.iter(|| {
            let mut frags = 0u64;
            for (f, _, _) in &tets {
                if let Some(mut t) = TetRaster::new(f.case, &f.q, clip) {
                    let (gst, valid) = (t.gst, t.valid);
                    t.rows(|r| {
                        let mut g = r.g;
                        for _ in r.i0..=r.i1 {
                            frags += (wedge(fan_bits(&g), valid) != 0) as u64;
                            for (v, s) in g.iter_mut().zip(&gst) {
                                *v += s;
                            }
                        }
                    });
                }
            }
            frags
        })
    });
    g.bench_function("raster/per-pixel", |b| {
        b.iter(|| {
            let mut frags = 0u64;
            for (f, _, _) in &tets {
                raster_fan(f, clip, |_| frags += 1);
            }
            frags
        })
    });

    // Real fragments' segments, in batches.
    let mut segs: Vec<[f32; 3]> = Vec::new();
    for (f, th, s) in tets.iter().take(200_000) {
        raster_fan(f, clip, |fr| {
            let (x, y) = (f.case.fan[fr.tri] as usize, f.case.fan[fr.tri + 1] as usize);
            let a = |t: f64, sx: f64, sy: f64| t + fr.lx * (sx - t) + fr.ly * (sy - t);
            segs.push([
                a(th.sf, s[x], s[y]) as f32,
                a(th.sb, s[x], s[y]) as f32,
                (th.l * (1.0 - fr.lx - fr.ly)) as f32,
            ]);
        });
    }
    let batches: Vec<ShadeBatch> = segs
        .chunks(BATCH)
        .map(|c| {
            let mut b = ShadeBatch::default();
            for (k, s) in c.iter().enumerate() {
                (b.sf[k], b.sb[k], b.l[k]) = (s[0], s[1], s[2]);
            }
            b.len = c.len();
            b
        })
        .collect();
    let integ = FastIntegrator::new("partial", &tf).unwrap();
    g.throughput(Throughput::Elements(segs.len() as u64));
    let mut work = batches.clone();
    g.bench_function("shade/batch", |b| {
        b.iter(|| {
            for bt in work.iter_mut() {
                integ.shade_batch(bt);
            }
        })
    });
    g.bench_function("shade/scalar", |b| {
        b.iter(|| {
            for bt in work.iter_mut() {
                integ.shade_batch_scalar(bt);
            }
        })
    });

    let opts = RenderOptions {
        sort: Some("centroid-radix".into()),
        integrator: Some("partial".into()),
        ..Default::default()
    };
    let mut r = render::make("cpu-pt", &opts).unwrap();
    r.prepare(&mesh, &tf).unwrap();
    let f = r.render(&mesh, &cam).unwrap();
    let t = f.times;
    println!(
        "cpu-pt frame: project {:.1} ms, sort {:.1} ms, draw {:.1} ms, total {:.1} ms; counters {:?}",
        t.project_ms, t.sort_ms, t.draw_ms, t.total_ms, f.counters
    );
    g.throughput(Throughput::Elements(mesh.num_tets() as u64));
    g.bench_function("frame", |b| b.iter(|| r.render(&mesh, &cam).unwrap()));
    g.finish();
}

criterion_group!(benches, cpu_pt_kernels);
criterion_main!(benches);
