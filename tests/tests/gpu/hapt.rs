//! `hapt` on the GPU (lavapipe in CI): images equal to `cpu-pt` with the same order and
//! integrator, gpu-radix close to cpu-pt's centroid-radix, finite on the degenerate cases,
//! iso-surfaces closed on a sphere field, streaming with mesh-independent GPU memory and the
//! same image, time-varying frames equal to renders of each step. Small meshes, 128².

use algorithms::camera::{Camera, Projection, View};
use algorithms::metrics::compare;
use algorithms::render::{self, Frame, RenderOptions};
use algorithms::{Mesh, TransferFunction};

fn frame(
    mesh: &Mesh,
    tf: &TransferFunction,
    renderer: &str,
    sort: &str,
    integ: &str,
    params: &[(&str, &str)],
    cam: &Camera,
) -> (Frame, u64) {
    let opts = RenderOptions {
        sort: Some(sort.into()),
        integrator: Some(integ.into()),
        params: params
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..Default::default()
    };
    let mut r = render::make(renderer, &opts).unwrap();
    r.prepare(mesh, tf).unwrap();
    let f = r.render(mesh, cam).unwrap();
    assert_eq!(f.image.non_finite_pixels(), 0, "{renderer} {sort} {integ}");
    (f, r.memory().gpu_bytes)
}

fn rmse(a: &Frame, b: &Frame) -> f64 {
    compare(&a.image, &b.image).unwrap().rmse
}

fn counter(f: &Frame, name: &str) -> f64 {
    f.counters
        .iter()
        .find(|c| c.0 == name)
        .unwrap_or_else(|| panic!("no counter {name}"))
        .1
}

/// hapt with a CPU sort uploaded against cpu-pt with that sort: RMSE ≤ 1e-3 at 128².
fn check_equal(name: &str, mesh: &Mesh, integ: &str, proj: Projection, view: View) -> f64 {
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(&mesh.bbox(), view, proj, 128, 128);
    let (g, _) = frame(mesh, &tf, "hapt", "centroid-radix", integ, &[], &cam);
    let (c, _) = frame(mesh, &tf, "cpu-pt", "centroid-radix", integ, &[], &cam);
    let e = rmse(&g, &c);
    eprintln!("{name} {integ} {proj:?}: rmse {e:.2e}");
    assert!(e <= 1e-3, "{name} {integ} {proj:?}: rmse {e}");
    assert!(
        c.image.pixels.iter().any(|p| p[3] > 0.05),
        "{name}: empty image"
    );
    e
}

#[test]
fn hapt_equals_cpu_pt_on_hard_cases() {
    let Some(_gpu) = algorithms::gpu::test_gpu("hapt_equals_cpu_pt_on_hard_cases") else {
        return;
    };
    let v = View::new(30.0, 20.0);
    for name in ["hard-caps", "hard-zero-volume", "hard-axis-aligned"] {
        let mesh = datasets_gen::generate(name, Some(6000), 1).unwrap();
        check_equal(name, &mesh, "partial", Projection::Ortho, v);
        check_equal(
            name,
            &mesh,
            "partial",
            Projection::Ortho,
            View::new(0.0, 0.0),
        );
    }
    let mesh = datasets_gen::generate("hard-caps", Some(6000), 1).unwrap();
    check_equal("hard-caps", &mesh, "average", Projection::Ortho, v);
    check_equal("hard-caps", &mesh, "preint", Projection::Ortho, v);
    check_equal("hard-caps", &mesh, "partial", Projection::Persp, v);
}

#[test]
fn hapt_equals_cpu_pt_on_blunt() {
    let Some(_gpu) = algorithms::gpu::test_gpu("hapt_equals_cpu_pt_on_blunt") else {
        return;
    };
    let Some(mesh) = tetbench_tests::test_util::nasa("blunt") else {
        return;
    };
    check_equal(
        "blunt",
        &mesh,
        "partial",
        Projection::Ortho,
        View::new(30.0, 20.0),
    );
    check_equal(
        "blunt",
        &mesh,
        "partial",
        Projection::Persp,
        View::new(-40.0, 10.0),
    );
}

#[test]
fn gpu_sorts_close_to_centroid_radix_and_degenerate_cases_finite() {
    let Some(_gpu) = algorithms::gpu::test_gpu("gpu_sorts_close_to_centroid_radix") else {
        return;
    };
    let tf = TransferFunction::preset("default").unwrap();
    let mesh = datasets_gen::generate("cc6", Some(6000), 1).unwrap();
    for proj in [Projection::Ortho, Projection::Persp] {
        let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), proj, 128, 128);
        let (c, _) = frame(&mesh, &tf, "cpu-pt", "centroid-radix", "partial", &[], &cam);
        for s in ["gpu-radix", "gpu-bitonic"] {
            let (g, _) = frame(&mesh, &tf, "hapt", s, "partial", &[], &cam);
            let e = rmse(&g, &c);
            eprintln!("cc6 {s} {proj:?}: rmse {e:.2e}");
            // Keys may differ by an ulp (fused multiply-add): tets of equal depth can swap.
            assert!(e <= 5e-3, "{s} {proj:?}: rmse {e}");
            assert_eq!(
                counter(&g, "tets_drawn") + counter(&g, "tets_discarded_empty"),
                6000.0
            );
        }
    }
    for name in [
        "hard-zero-volume",
        "hard-needles",
        "hard-slivers",
        "hard-duplicates",
        "hard-negative",
        "hard-scalar-range",
        "hard-translated",
        "hard-constant",
        "hard-saturate",
    ] {
        let mesh = datasets_gen::generate(name, Some(3000), 2).unwrap();
        let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Persp, 64, 64);
        let (f, _) = frame(&mesh, &tf, "hapt", "gpu-radix", "partial", &[], &cam);
        assert!(
            f.image
                .pixels
                .iter()
                .flatten()
                .all(|&c| (0.0..=1.0001).contains(&c)),
            "{name}: pixel out of range"
        );
    }
}

#[test]
fn iso_mode_draws_a_closed_sphere() {
    let Some(_gpu) = algorithms::gpu::test_gpu("iso_mode_draws_a_closed_sphere") else {
        return;
    };
    let grid = datasets_gen::generate("cc6", Some(24000), 1).unwrap();
    let c = grid.bbox().center();
    let d: Vec<f64> = grid.positions().iter().map(|p| (*p - c).length()).collect();
    let mesh = Mesh::with_scalars(
        "sphere",
        grid.positions().to_vec(),
        grid.tets().to_vec(),
        "r",
        d,
    )
    .unwrap();
    let tf = TransferFunction::preset("default").unwrap();
    let radius = 0.6 * (grid.bbox().max.x - grid.bbox().min.x) / 2.0;
    for (mode, proj) in [("iso", Projection::Ortho), ("dvr+iso", Projection::Ortho)] {
        let cam = Camera::new(&mesh.bbox(), View::new(30.0, 20.0), proj, 128, 128);
        let iso = format!("{radius}");
        let (f, _) = frame(
            &mesh,
            &tf,
            "hapt",
            "centroid-radix",
            "partial",
            &[("mode", mode), ("iso", &iso)],
            &cam,
        );
        let r_px = radius / cam.pixel;
        let (mut inside, mut outside) = (0, 0);
        for j in 0..128u32 {
            for i in 0..128u32 {
                let dx = i as f64 + 0.5 - 64.0;
                let dy = j as f64 + 0.5 - 64.0;
                let dist = (dx * dx + dy * dy).sqrt();
                let a = f.image.get(i, j)[3];
                if dist < r_px - 1.5 {
                    inside += 1;
                    assert!(a > 0.99, "{mode}: hole at ({i}, {j}), alpha {a}");
                } else if dist > r_px + 1.5 && mode == "iso" {
                    outside += 1;
                    assert_eq!(a, 0.0, "{mode}: coverage outside the sphere at ({i}, {j})");
                }
            }
        }
        assert!(inside > 1000 && (mode != "iso" || outside > 5000));
        // Flat shading: not one colour everywhere.
        let lum: Vec<f32> = f
            .image
            .pixels
            .iter()
            .filter(|p| p[3] > 0.99)
            .map(|p| p[0] + p[1] + p[2])
            .collect();
        let (lo, hi) = lum
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(hi - lo > 0.05, "{mode}: no shading ({lo}..{hi})");
    }
}

#[test]
fn streaming_memory_does_not_grow_and_image_is_the_same() {
    let Some(_gpu) = algorithms::gpu::test_gpu("streaming_memory_does_not_grow") else {
        return;
    };
    let tf = TransferFunction::preset("default").unwrap();
    let mut bytes = Vec::new();
    for tets in [3000, 12000] {
        let mesh = datasets_gen::generate("cc6", Some(tets), 1).unwrap();
        let cam = Camera::new(
            &mesh.bbox(),
            View::new(30.0, 20.0),
            Projection::Persp,
            128,
            128,
        );
        let p = [("stream", "1000")];
        let (s, b) = frame(&mesh, &tf, "hapt", "centroid-radix", "partial", &p, &cam);
        let (r, rb) = frame(&mesh, &tf, "hapt", "centroid-radix", "partial", &[], &cam);
        let e = rmse(&s, &r);
        assert!(e <= 1e-5, "{tets}: streamed vs resident rmse {e}");
        assert!(counter(&s, "chunks") >= (tets / 1000) as f64);
        assert!(rb > b, "resident {rb} should exceed streamed {b}");
        bytes.push(b);
    }
    assert_eq!(bytes[0], bytes[1], "streamed GPU bytes grew with the mesh");
}

#[test]
fn time_varying_frames_equal_renders_of_each_step() {
    let Some(_gpu) = algorithms::gpu::test_gpu("time_varying_frames") else {
        return;
    };
    let tf = TransferFunction::preset("default").unwrap();
    let mesh = datasets_gen::generate("tv-gaussian", Some(6000), 1).unwrap();
    let (name, _) = mesh.active_field();
    let name = name.to_string();
    let nsteps = mesh
        .fields()
        .iter()
        .find(|f| f.name == name)
        .unwrap()
        .steps
        .len();
    assert!(nsteps > 2);
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Ortho,
        96,
        96,
    );
    let opts = RenderOptions {
        sort: Some("centroid-radix".into()),
        integrator: Some("partial".into()),
        params: vec![("timevarying".into(), "1".into())],
        ..Default::default()
    };
    let mut r = render::make("hapt", &opts).unwrap();
    r.prepare(&mesh, &tf).unwrap();
    let mut prev: Option<Frame> = None;
    for k in 0..3 {
        let f = r.render(&mesh, &cam).unwrap();
        assert_eq!(counter(&f, "time_step"), k as f64);
        assert!(counter(&f, "upload_ms") >= 0.0);
        let mut m = mesh.clone();
        m.select_field(&name, k).unwrap();
        let (want, _) = frame(&m, &tf, "hapt", "centroid-radix", "partial", &[], &cam);
        let e = rmse(&f, &want);
        assert!(e <= 1e-6, "step {k}: rmse {e}");
        if let Some(p) = &prev {
            assert!(rmse(&f, p) > 1e-4, "step {k} looks like the previous step");
        }
        prev = Some(f);
    }
}
