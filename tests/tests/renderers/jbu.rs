//! The JBU wrapper: works around every registered renderer with every method, is the
//! identity at factor 1, beats linear upsampling at a sharp silhouette, finds exactly the front
//! and back faces of a convex box, and refuses bad names with one line.

use algorithms::camera::{Camera, Projection, View};
use algorithms::glam::DVec3;
use algorithms::image::Image;
use algorithms::io::split::{hex_corner, hex_split_pattern};
use algorithms::io::Split;
use algorithms::metrics::compare;
use algorithms::render::jbu::{cube_views, upsample, BoundaryRaster, DepthLayers, Method, Params};
use algorithms::render::{self, RenderOptions};
use algorithms::tf::{TfPoint, TransferFunction};
use algorithms::{Error, Mesh};

/// An n×n×n box of cubes split 6 per cube over [lo, hi]³, scalar from `f`.
fn kuhn_box(n: usize, lo: DVec3, hi: DVec3, f: impl Fn(DVec3) -> f64) -> Mesh {
    let idx = |i: usize, j: usize, k: usize| (i + (n + 1) * (j + (n + 1) * k)) as u32;
    let mut pos = Vec::new();
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                let t = DVec3::new(i as f64, j as f64, k as f64) / n as f64;
                pos.push(lo + (hi - lo) * t);
            }
        }
    }
    let mut tets = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c: [u32; 8] = std::array::from_fn(|q| {
                    let [x, y, z] = hex_corner(q);
                    idx(i + x, j + y, k + z)
                });
                for t in hex_split_pattern(Split::Six, false) {
                    tets.push(t.map(|v| c[v]));
                }
            }
        }
    }
    let s = pos.iter().map(|p| f(*p)).collect();
    Mesh::with_scalars("box", pos, tets, "s", s).unwrap()
}

fn opaque_tf() -> TransferFunction {
    TransferFunction {
        name: "opaque".into(),
        range: Some([0.0, 1.0]),
        points: vec![
            TfPoint {
                s: 0.0,
                rgb: [1.0, 0.6, 0.1],
                tau: 6.0,
            },
            TfPoint {
                s: 1.0,
                rgb: [0.2, 0.5, 1.0],
                tau: 12.0,
            },
        ],
    }
}

fn render(name: &str, mesh: &Mesh, tf: &TransferFunction, cam: &Camera) -> render::Frame {
    let mut r = render::make(name, &RenderOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    r.prepare(mesh, tf)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    r.render(mesh, cam)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn counter(f: &render::Frame, k: &str) -> f64 {
    f.counter(k).unwrap()
}

#[test]
fn wraps_every_renderer_with_every_method() {
    let mesh = datasets_gen::generate("spx", Some(1500), 1).unwrap();
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(30.0, 20.0),
        Projection::Persp,
        32,
        32,
    );
    for info in render::REGISTRY {
        // External peers (VTK) run in a helper process; the wrapper takes them like any other.
        // Regular-volume renderers need a lattice mesh.
        if render::is_wrapper(info.name)
            || render::is_external(info.name)
            || info.family == render::Family::Volume
        {
            continue;
        }
        for m in Method::ALL {
            let name = format!("jbu:{}@16,method={}", info.name, m.name());
            let f = render(&name, &mesh, &tf, &cam);
            assert_eq!((f.image.width, f.image.height), (32, 32), "{name}");
            assert_eq!(f.image.non_finite_pixels(), 0, "{name}");
            assert!(
                f.image.pixels.iter().flatten().any(|&c| c > 0.0),
                "{name}: empty"
            );
            let sum = counter(&f, "low_ms") + counter(&f, "depth_ms") + counter(&f, "filter_ms");
            assert!((f.times.total_ms - sum).abs() < 1e-9, "{name}");
            assert_eq!(counter(&f, "low_width"), 16.0);
        }
    }
}

#[test]
fn factor_one_returns_the_inner_image() {
    let mesh = datasets_gen::generate("spx", Some(1500), 1).unwrap();
    let tf = TransferFunction::preset("default").unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(10.0, 5.0),
        Projection::Ortho,
        24,
        20,
    );
    for inner in ["raycast", "cpu-pt"] {
        let full = render(inner, &mesh, &tf, &cam);
        for m in Method::ALL {
            let name = format!("jbu:{inner}@24x20,method={}", m.name());
            let up = render(&name, &mesh, &tf, &cam);
            assert_eq!(up.image, full.image, "{name}");
        }
        // `@N` keeps the aspect ratio: N is the longer side.
        let up = render(&format!("jbu:{inner}@24"), &mesh, &tf, &cam);
        assert_eq!(up.image, full.image, "jbu:{inner}@24");
    }
}

/// A box seen face-on, turned 30° in the image plane: its volume is 2 deep right up to the
/// silhouette, so the full image has a sharp diagonal edge that linear upsampling blurs and the
/// depth layers preserve. (A box seen obliquely is not such a case: its depth thins to zero at
/// the silhouette and the rendered opacity ramps down smoothly.)
#[test]
fn bilateral_beats_linear_at_a_sharp_silhouette() {
    let box_ = kuhn_box(4, DVec3::splat(-1.0), DVec3::splat(1.0), |p| {
        0.5 + 0.25 * (p.x + p.y * p.z)
    });
    let (s, c) = 30f64.to_radians().sin_cos();
    let pos = box_
        .positions()
        .iter()
        .map(|p| DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z))
        .collect();
    let mesh = Mesh::with_scalars(
        "turned",
        pos,
        box_.tets().to_vec(),
        "s",
        box_.scalars().to_vec(),
    )
    .unwrap();
    let tf = opaque_tf();
    let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, 64, 64);
    let full = render("raycast", &mesh, &tf, &cam).image;
    let err = |m: &str| {
        let up = render(&format!("jbu:raycast@16,method={m}"), &mesh, &tf, &cam).image;
        compare(&up, &full).unwrap().rmse
    };
    let (b, l, n) = (err("bilateral"), err("linear"), err("nearest"));
    assert!(b < 0.5 * l, "bilateral {b} vs linear {l}");
    assert!(l < n, "linear {l} vs nearest {n}");
}

#[test]
fn a_convex_box_has_two_layers_front_and_back() {
    let mesh = kuhn_box(3, DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.x);
    let raster = BoundaryRaster::new(&mesh);
    let r = 3f64.sqrt();
    // View (0, 0) ortho: the front face z = 1 is at depth 2R − 1, the back face at 2R + 1;
    // normalised over [R, 3R]. Pixel centres never fall on the box's outline here.
    let cam = Camera::new(&mesh.bbox(), View::new(0.0, 0.0), Projection::Ortho, 40, 40);
    let l = raster.layers(&cam, 3);
    let (front, back) = ((r - 1.0) / (2.0 * r), (r + 1.0) / (2.0 * r));
    let mut inside = 0;
    for j in 0..40 {
        for i in 0..40 {
            let ray = cam.pixel_ray(i, j);
            let hit = ray.origin.x.abs() < 1.0 && ray.origin.y.abs() < 1.0;
            let d = l.at(i, j);
            if hit {
                inside += 1;
                assert_eq!(l.count[(j * 40 + i) as usize], 2, "pixel {i},{j}");
                assert!((d[0] as f64 - front).abs() < 1e-6, "{i},{j}: {d:?}");
                assert!((d[1] as f64 - back).abs() < 1e-6, "{i},{j}: {d:?}");
                assert_eq!(d[2], 1.0);
            } else {
                assert_eq!(l.count[(j * 40 + i) as usize], 0, "pixel {i},{j}");
                assert_eq!(d, [1.0; 3]);
            }
        }
    }
    assert!(inside > 300);
    // Any view, either projection: every pixel sees the box 0 or 2 times (no crack, no double
    // count along the shared edges of the boundary triangles).
    for (v, p) in [
        (View::new(30.0, 20.0), Projection::Ortho),
        (View::new(-50.0, 35.0), Projection::Persp),
        (View::new(45.0, 35.264_389_682_754_654), Projection::Ortho),
    ] {
        let cam = Camera::new(&mesh.bbox(), v, p, 48, 40);
        let l = raster.layers(&cam, 2);
        assert!(l.count.iter().all(|&c| c == 0 || c == 2), "{v:?} {p:?}");
        assert!(l.count.iter().filter(|&&c| c == 2).count() > 400);
        for (px, &c) in l.depth.chunks(2).zip(&l.count) {
            if c == 2 {
                assert!(px[0] < px[1] && px[0] > 0.0 && px[1] < 1.0, "{px:?}");
            }
        }
    }
}

#[test]
fn bad_wrapper_names_are_one_line_input_errors() {
    for name in [
        "jbu:nope@128",
        "jbu:raycast@0",
        "jbu:raycast",
        "jbu:raycast@12x",
        "jbu:raycast@64,method=cubic",
        "jbu:raycast@64,k=5",
        "jbu:raycast@64,sigma=-1",
        "jbu:raycast@64,foo=1",
        "jbu:jbu:raycast@64@32",
        "jbu:@64",
    ] {
        for e in [
            render::make(name, &RenderOptions::default()).err(),
            render::info(name).err(),
        ] {
            match e {
                Some(Error::Input(m)) => {
                    assert!(!m.contains('\n') && m.contains(name), "{name}: {m}")
                }
                other => panic!("{name}: {other:?}"),
            }
        }
    }
    // The inner renderer's options are checked as for the renderer itself.
    let opts = RenderOptions {
        integrator: Some("nope".into()),
        ..Default::default()
    };
    assert!(matches!(
        render::make("jbu:raycast@64", &opts),
        Err(Error::Input(_))
    ));
    // A low size above the image is refused when rendering.
    let mesh = kuhn_box(1, DVec3::ZERO, DVec3::ONE, |p| p.x);
    let mut r = render::make("jbu:raycast@64", &RenderOptions::default()).unwrap();
    r.prepare(&mesh, &opaque_tf()).unwrap();
    let cam = Camera::new(&mesh.bbox(), View::default(), Projection::Ortho, 32, 32);
    assert!(matches!(r.render(&mesh, &cam), Err(Error::Input(_))));
    // info() answers with the inner renderer's entry (its sorts and integrators).
    assert_eq!(render::info("jbu:cpu-pt@128").unwrap().name, "cpu-pt");
}

/// Full 64² and low 16² cameras over the same square, and layers from `f(x, y)` (full-res pixel
/// coordinates of the point; two layers per pixel, `None` = background).
fn synthetic(
    f: impl Fn(f64, f64) -> Option<[f32; 2]>,
) -> (Camera, Camera, DepthLayers, DepthLayers) {
    let mesh = kuhn_box(1, DVec3::ZERO, DVec3::ONE, |p| p.x);
    let cam = |n| Camera::new(&mesh.bbox(), View::default(), Projection::Ortho, n, n);
    let layers = |n: u32, omega: f64| {
        let mut depth = Vec::new();
        let mut count = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = f((i as f64 + 0.5) * omega, (j as f64 + 0.5) * omega);
                depth.extend(v.unwrap_or([1.0; 2]));
                count.push(if v.is_some() { 2 } else { 0 });
            }
        }
        DepthLayers {
            width: n,
            height: n,
            k: 2,
            depth,
            count,
        }
    };
    (cam(64), cam(16), layers(64, 1.0), layers(16, 4.0))
}

fn bilateral() -> Params {
    Params {
        k: 2,
        ..Params::default()
    }
}

#[test]
fn bilateral_is_bilinear_where_the_guide_is_planar() {
    // A tilted slab: both layers planar, 0.002 and 0.001 normalised depth per full-res pixel
    // (over 4 low-res pixels the depth changes by many σ_r, so a plain range term would cut).
    let (full, low_cam, fl, ll) = synthetic(|x, y| {
        let d = 0.2 + 0.002 * x + 0.001 * y;
        Some([d as f32, (d + 0.1 + 0.0005 * x) as f32])
    });
    let mut low = Image::new(16, 16);
    for j in 0..16 {
        for i in 0..16 {
            let h = ((i * 7 + j * 13) % 11) as f32 / 11.0;
            low.set(i, j, [h, 1.0 - h, 0.5 * h, 0.8]);
        }
    }
    let lin = Params {
        method: Method::Linear,
        ..Params::default()
    };
    let a = upsample(&low, &low_cam, &full, &lin, None).unwrap();
    let b = upsample(&low, &low_cam, &full, &bilateral(), Some((&fl, &ll))).unwrap();
    let worst = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "bilateral differs from bilinear by {worst}");
}

#[test]
fn bilateral_does_not_mix_across_a_depth_edge() {
    // Two slabs, the near one left of x = 27.3 full-res pixels (between low-res centres).
    let near = |x: f64| x < 27.3;
    let (full, low_cam, fl, ll) =
        synthetic(|x, _| Some(if near(x) { [0.30, 0.40] } else { [0.60, 0.75] }));
    let (ca, cb) = ([0.8, 0.2, 0.1, 0.9], [0.1, 0.1, 0.6, 0.5]);
    let mut low = Image::new(16, 16);
    for j in 0..16 {
        for i in 0..16 {
            low.set(i, j, if near((i as f64 + 0.5) * 4.0) { ca } else { cb });
        }
    }
    let b = upsample(&low, &low_cam, &full, &bilateral(), Some((&fl, &ll))).unwrap();
    let lin = Params {
        method: Method::Linear,
        ..Params::default()
    };
    let a = upsample(&low, &low_cam, &full, &lin, None).unwrap();
    let mut mixed_linear = 0;
    for j in 0..64 {
        for i in 0..64 {
            let want = if near(i as f64 + 0.5) { ca } else { cb };
            let got = b.get(i, j);
            for c in 0..4 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-4,
                    "pixel {i},{j}: {got:?} vs {want:?}"
                );
            }
            mixed_linear += (a.get(i, j) != want) as usize;
        }
    }
    assert!(
        mixed_linear > 64,
        "linear should blur the edge: {mixed_linear}"
    );
}

#[test]
fn the_cube_views_are_the_8_corners_and_6_faces() {
    let v = cube_views();
    assert_eq!(v.len(), 14);
    let mut dirs: Vec<DVec3> = v.iter().map(|v| v.to_eye()).collect();
    let corners = dirs.drain(..8).collect::<Vec<_>>();
    for d in corners {
        let s = d * 3f64.sqrt();
        assert!((s.abs() - DVec3::ONE).length() < 1e-9, "{s}");
    }
    for d in &dirs {
        let a = d.abs();
        assert!(
            (a.max_element() - 1.0).abs() < 1e-9 && a.min_element() < 1e-9,
            "{d}"
        );
    }
    for (i, a) in dirs.iter().enumerate() {
        for b in &dirs[i + 1..] {
            assert!((*a - *b).length() > 0.5);
        }
    }
}

/// The fast paths equal their scalar definitions: the depth layers exactly, the bilateral filter
/// bit for bit, on a non-convex mesh (spx's cavity) from every cube view, k = 1..4, at two
/// factors and a non-square full size (border rows and columns, uneven bilinear weights).
#[test]
fn fast_paths_equal_their_scalar_definitions() {
    let mesh = datasets_gen::generate("spx", Some(3000), 1).unwrap();
    let tf = TransferFunction::preset("default").unwrap();
    let raster = BoundaryRaster::new(&mesh);
    let mut r = render::make("raycast", &RenderOptions::default()).unwrap();
    r.prepare(&mesh, &tf).unwrap();
    let mut compared = 0;
    for v in cube_views() {
        for (fw, fh, low) in [(96, 96, 12), (100, 80, 40)] {
            let full = Camera::new(&mesh.bbox(), v, Projection::Ortho, fw, fh);
            let lc = algorithms::render::jbu::low_camera(&mesh, &full, low, low * fh / fw);
            let img = r.render(&mesh, &lc).unwrap().image;
            for k in 1..=4 {
                let lf = raster.layers(&full, k);
                assert_eq!(
                    lf,
                    raster.layers_scalar(&full, k),
                    "full layers k={k} {v:?}"
                );
                let ll = raster.layers(&lc, k);
                assert_eq!(ll, raster.layers_scalar(&lc, k), "low layers k={k} {v:?}");
                let p = Params {
                    k,
                    ..Params::default()
                };
                let a = upsample(&img, &lc, &full, &p, Some((&lf, &ll))).unwrap();
                let b = algorithms::render::jbu::upsample_scalar(
                    &img,
                    &lc,
                    &full,
                    &p,
                    Some((&lf, &ll)),
                )
                .unwrap();
                let bits = |i: &Image| -> Vec<u32> {
                    i.pixels.iter().flatten().map(|x| x.to_bits()).collect()
                };
                assert!(bits(&a) == bits(&b), "bilateral k={k} view {v:?} {fw}x{fh}");
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 14 * 2 * 4);
    // Larger faces (many pixel centres inside for certain, a few within rounding of an edge),
    // and an axis-aligned view whose edges pass through rows of pixel centres.
    for v in [cube_views()[0], cube_views()[8], View::new(0.0, 0.0)] {
        let full = Camera::new(&mesh.bbox(), v, Projection::Ortho, 640, 480);
        assert_eq!(
            raster.layers(&full, 4),
            raster.layers_scalar(&full, 4),
            "{v:?}"
        );
    }
}

/// The documented defaults (`algorithms::render::jbu::PARAMS`, what `tetbench list` prints) are the
/// real ones: each parses, setting it changes nothing, and the wrapper's registry entry shows
/// that same table.
#[test]
fn the_documented_defaults_are_the_real_ones() {
    let d = Params::default();
    assert_eq!((d.method, d.k, d.sigma_r), (Method::Bilateral, 4, 0.02));
    for p in algorithms::render::jbu::PARAMS {
        let q = Params::read(&[(p.name.to_string(), p.default.to_string())])
            .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        assert_eq!(q, d, "{}", p.name);
    }
    let info = render::REGISTRY
        .iter()
        .find(|r| r.name == "jbu:<renderer>@<size>")
        .unwrap();
    let names: Vec<&str> = info.params.iter().map(|p| p.name).collect();
    assert_eq!(names, ["method", "k", "sigma", "c", "r"]);
    assert!(d.check().is_ok());
    let bad = |k: &str, v: &str| Params::read(&[(k.to_string(), v.to_string())]);
    assert!(matches!(bad("k", "x"), Err(Error::Input(_))));
    assert!(matches!(bad("nope", "1"), Err(Error::Input(_))));
}

#[test]
fn params_from_spec() {
    use algorithms::render::jbu::{Method, Params};
    let p = Params::from_spec("bilateral:k=2:s=0.01:c=0.2:r=3").unwrap();
    assert_eq!(
        (p.method, p.k, p.sigma_r, p.sigma_c, p.radius),
        (Method::Bilateral, 2, 0.01, 0.2, 3)
    );
    assert_eq!(Params::from_spec("linear").unwrap().method, Method::Linear);
    for bad in ["blur", "bilateral:k", "bilateral:k=9", "bilateral:q=1", ""] {
        assert!(Params::from_spec(bad).is_err(), "{bad}");
    }
}
