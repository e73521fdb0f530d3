//! Criterion benches of joint bilateral upsampling's two stages at 1024²: the depth
//! layers (k = 4) of the full-size and the 128² camera, and the filters (`bilateral`, `linear`)
//! from a 128² ray-cast image, each as the fast path and as its scalar definition, so the
//! speed-up is a ratio measured in one run. On blunt when the NASA data is found, else on its
//! generated analogue `blunt-like` (187K tets), view (45, 35).
//! Run: `cargo bench -p tetbench --bench jbu`.

use std::time::Duration;

use algorithms::camera::{Camera, Projection, View};
use algorithms::io::{self, LoadOptions};
use algorithms::render::jbu::{
    low_camera, upsample, upsample_scalar, BoundaryRaster, Method, Params,
};
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};
use criterion::{criterion_group, criterion_main, Criterion};

fn stages(c: &mut Criterion, label: &str, mesh: &Mesh) {
    let tf = TransferFunction::preset("default").unwrap();
    let full = Camera::new(
        &mesh.bbox(),
        View::new(45.0, 35.0),
        Projection::Ortho,
        1024,
        1024,
    );
    let low_cam = low_camera(mesh, &full, 128, 128);
    let mut rc = render::make("raycast", &RenderOptions::default()).unwrap();
    rc.prepare(mesh, &tf).unwrap();
    let low = rc.render(mesh, &low_cam).unwrap().image;
    let raster = BoundaryRaster::new(mesh);
    let p = Params::default();
    let lf = raster.layers(&full, p.k);
    let ll = raster.layers(&low_cam, p.k);
    let mut g = c.benchmark_group(format!("jbu/{label}"));
    g.sample_size(10).measurement_time(Duration::from_secs(4));
    g.bench_function("depth-1024-k4", |b| {
        b.iter(|| raster.layers(&full, p.k).depth.len())
    });
    g.bench_function("depth-1024-k4-scalar", |b| {
        b.iter(|| raster.layers_scalar(&full, p.k).depth.len())
    });
    g.bench_function("depth-128-k4", |b| {
        b.iter(|| raster.layers(&low_cam, p.k).depth.len())
    });
    for (name, params) in [
        ("bilateral", p),
        (
            "linear",
            Params {
                method: Method::Linear,
                ..p
            },
        ),
    ] {
        g.bench_function(format!("filter-{name}-128to1024"), |b| {
            b.iter(|| {
                upsample(&low, &low_cam, &full, &params, Some((&lf, &ll)))
                    .unwrap()
                    .pixels
                    .len()
            })
        });
    }
    g.bench_function("filter-bilateral-128to1024-scalar", |b| {
        b.iter(|| {
            upsample_scalar(&low, &low_cam, &full, &p, Some((&lf, &ll)))
                .unwrap()
                .pixels
                .len()
        })
    });
    g.finish();
}

fn jbu(c: &mut Criterion) {
    if let Some(Ok(_)) = io::resolve_short_name("blunt") {
        let blunt = io::load("blunt", &LoadOptions::default()).unwrap();
        stages(c, "blunt", &blunt);
    } else {
        let mesh = datasets_gen::generate("blunt-like", None, 1).unwrap();
        stages(c, "blunt-like", &mesh);
    }
}

criterion_group!(benches, jbu);
criterion_main!(benches);
