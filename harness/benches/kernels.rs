//! Criterion benches of the hot kernels, each on its own: PT classification, every visibility
//! sort, the fan rasterizer, the ray walk (one frame of the reference ray caster's walk with
//! the cheapest integrator) and the Ψ lookup. Mesh: a 200K-tet `spx2` analogue (generated, no
//! download). Run: `cargo bench -p tetbench --bench kernels`.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::optics::{psi, PsiTable};
use algorithms::render::pt::{classify, raster_fan, FanGeometry, ProjVertex};
use algorithms::render::{self, RenderOptions};
use algorithms::{sort, Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn mesh() -> Mesh {
    datasets_gen::generate("spx2", Some(200_000), 1).unwrap()
}

/// Every tet's projected vertices at a 512² view.
fn projected(mesh: &Mesh, cam: &Camera) -> Vec<[ProjVertex; 4]> {
    let c = mesh.bbox().center();
    let (lo, hi) = mesh.scalar_range();
    mesh.tets()
        .iter()
        .map(|t| {
            t.map(|v| {
                let p = mesh.positions()[v as usize] - c;
                ProjVertex::project(cam, p, (mesh.scalars()[v as usize] - lo) / (hi - lo))
            })
        })
        .collect()
}

fn kernels(c: &mut Criterion) {
    let mesh = mesh();
    let n = mesh.num_tets() as u64;
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        512,
        512,
    );
    let inv_l = 1.0 / mesh.diagonal();
    let proj = projected(&mesh, &cam);

    let mut g = c.benchmark_group("kernels");
    g.sample_size(10).measurement_time(Duration::from_secs(5));

    g.throughput(Throughput::Elements(n));
    g.bench_function("classify", |b| {
        b.iter(|| {
            proj.iter()
                .map(|v| classify(v, false, inv_l).l)
                .sum::<f64>()
        })
    });

    for name in [
        "centroid",
        "centroid-par",
        "centroid-radix",
        "bucket",
        "mpvonc",
    ] {
        let mut s = sort::make(name).unwrap();
        s.prepare(&mesh).unwrap();
        let mut order = Vec::new();
        g.bench_function(BenchmarkId::new("sort", name), |b| {
            b.iter(|| s.sort(&mesh, &cam, &mut order).unwrap())
        });
    }

    let fans: Vec<FanGeometry> = proj
        .iter()
        .map(|v| FanGeometry::new(v.map(|p| p.q), &classify(v, false, inv_l)))
        .collect();
    let clip = [0, 0, 512, 512];
    g.bench_function("rasterize-fans", |b| {
        b.iter(|| {
            let mut frags = 0u64;
            for f in &fans {
                raster_fan(f, clip, |_| frags += 1);
            }
            frags
        })
    });

    let tf = TransferFunction::preset("default").unwrap();
    let opts = RenderOptions {
        integrator: Some("average".into()),
        ..Default::default()
    };
    let mut rc = render::make("raycast", &opts).unwrap();
    rc.prepare(&mesh, &tf).unwrap();
    let small = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        128,
        128,
    );
    g.throughput(Throughput::Elements(128 * 128));
    g.bench_function("ray-walk-128x128", |b| {
        b.iter(|| rc.render(&mesh, &small).unwrap())
    });

    let table = PsiTable::shared();
    let args: Vec<(f64, f64)> = (0..4096)
        .map(|i| ((i % 64) as f64 * 0.13, (i / 64) as f64 * 0.07))
        .collect();
    g.throughput(Throughput::Elements(args.len() as u64));
    g.bench_function("psi-table-lookup", |b| {
        b.iter(|| args.iter().map(|&(f, k)| table.lookup(f, k)).sum::<f64>())
    });
    g.bench_function("psi-exact", |b| {
        b.iter(|| {
            args.iter()
                .map(|&(a, k)| psi(std::hint::black_box(a), k - a / 2.0))
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
