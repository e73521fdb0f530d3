//! `bcc-implicit`: a visibility order read off the lattice on `bcc`, `cc5` and `cc6`
//! meshes — every face constraint honoured over many orthographic views, and `cpu-pt` images
//! identical in 8 bits to `mpvonc`'s; empty-space skipping leaves the image unchanged.

use algorithms::camera::{fibonacci_views, Camera, Projection, View};
use algorithms::glam::DVec3;
use algorithms::image::{quantize, Image};
use algorithms::render::{self, Frame, RenderOptions};
use algorithms::sort::{self, face_violations};
use algorithms::{Error, Mesh, TransferFunction};

fn views() -> Vec<View> {
    let mut v = fibonacci_views(40);
    // Axis-aligned views (direction components exactly 0 up to cos 90°) and views on the
    // chamber boundaries |f_a| = |f_b| (the within-step order changes there).
    for (a, e) in [
        (0.0, 0.0),
        (90.0, 0.0),
        (180.0, 0.0),
        (270.0, 0.0),
        (0.0, 90.0),
        (0.0, -90.0),
        (45.0, 0.0),
        (135.0, 0.0),
        (45.0, 35.264_389_682_754_654),
        (-45.0, -35.264_389_682_754_654),
        (0.0, 45.0),
        (90.0, -45.0),
    ] {
        v.push(View::new(a, e));
    }
    v
}

/// A BCC lattice of 6x5x5 primary points with equal spacing (the generated `bcc` of 1500 tets
/// is 9x9x2 points with a larger spacing along z).
fn isotropic_bcc() -> Mesh {
    let (p, t, l) = datasets_gen::bcc_lattice([6, 5, 5], DVec3::splat(-1.0), DVec3::splat(0.4));
    let s = p
        .iter()
        .map(|&x| datasets_gen::fields::marschner_lobb(x))
        .collect();
    let mut m = Mesh::with_scalars("bcc-iso", p, t, "ml", s).unwrap();
    m.field_data
        .insert(datasets_gen::LATTICE_KEY.into(), l.to_field_data());
    m
}

fn lattice_meshes() -> Vec<(&'static str, Mesh)> {
    let mut v: Vec<(&'static str, Mesh)> = ["bcc", "cc5", "cc6"]
        .into_iter()
        .map(|n| (n, datasets_gen::generate(n, Some(1500), 1).unwrap()))
        .collect();
    v.push(("bcc-iso", isotropic_bcc()));
    v
}

#[test]
fn every_face_constraint_holds_in_every_orthographic_view() {
    for (name, mesh) in lattice_meshes() {
        let mut s = sort::make("bcc-implicit").unwrap();
        s.prepare(&mesh).unwrap();
        let mut centroid = sort::make("centroid").unwrap();
        centroid.prepare(&mesh).unwrap();
        let mut centroid_bad = 0;
        for view in views() {
            let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 8, 8);
            let mut order = Vec::new();
            s.sort(&mesh, &cam, &mut order).unwrap();
            let mut seen = vec![false; mesh.num_tets()];
            for &t in &order {
                assert!(
                    !std::mem::replace(&mut seen[t as usize], true),
                    "{name}: {t} twice"
                );
            }
            assert_eq!(order.len(), mesh.num_tets(), "{name}");
            assert_eq!(
                face_violations(&mesh, &cam, &order, 1e-9),
                0,
                "{name} {view:?}"
            );
            centroid.sort(&mesh, &cam, &mut order).unwrap();
            centroid_bad += face_violations(&mesh, &cam, &order, 1e-9);
        }
        // The check has teeth on the CC lattices (centroid order breaks Kuhn/cc5 faces; on
        // BCC, where neighbours are mirror images, centroid order is exact).
        if !name.starts_with("bcc") {
            assert!(centroid_bad > 0, "{name}");
        }
    }
}

#[test]
fn a_fixed_nesting_or_octant_table_would_fail() {
    // The order must follow the view's chamber, not only its octant: two views in the same
    // octant on either side of |f_x| = |f_z| give different orders on BCC.
    let mesh = isotropic_bcc();
    let mut s = sort::make("bcc-implicit").unwrap();
    s.prepare(&mesh).unwrap();
    let mut order = |v: View| {
        let cam = Camera::new(&mesh.bbox(), v, Projection::Ortho, 8, 8);
        let mut o = Vec::new();
        s.sort(&mesh, &cam, &mut o).unwrap();
        (o, cam)
    };
    let (a, cam_a) = order(View::new(40.0, 10.0));
    let (b, cam_b) = order(View::new(50.0, 10.0));
    assert_ne!(a, b);
    // Each view's order is wrong for the other.
    assert!(face_violations(&mesh, &cam_b, &a, 1e-9) > 0);
    assert!(face_violations(&mesh, &cam_a, &b, 1e-9) > 0);
}

fn frame(mesh: &Mesh, tf: &TransferFunction, sort: &str, cam: &Camera) -> Frame {
    let opts = RenderOptions {
        sort: Some(sort.into()),
        integrator: Some("partial".into()),
        ..Default::default()
    };
    let mut r = render::make("cpu-pt", &opts).unwrap();
    r.prepare(mesh, tf).unwrap();
    r.render(mesh, cam).unwrap()
}

fn q8(im: &Image) -> Vec<u8> {
    im.pixels.iter().flatten().map(|&v| quantize(v)).collect()
}

#[test]
fn cpu_pt_images_match_mpvonc_in_8_bits() {
    let tf = TransferFunction::preset("default").unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (name, mesh) in lattice_meshes() {
        // Through a written and re-read file: the lattice description travels in the .vtu.
        let path = dir.path().join(format!("{name}.vtu"));
        algorithms::io::write(&mesh, &path).unwrap();
        let mesh = algorithms::io::load_path(&path, &Default::default()).unwrap();
        for view in views() {
            let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 64, 64);
            let a = frame(&mesh, &tf, "bcc-implicit", &cam);
            let b = frame(&mesh, &tf, "mpvonc", &cam);
            let (qa, qb) = (q8(&a.image), q8(&b.image));
            let differ = qa.iter().zip(&qb).filter(|(x, y)| x != y).count();
            assert_eq!(differ, 0, "{name} {view:?}");
            assert!(qa.iter().any(|&v| v > 0), "{name}: empty image");
        }
    }
}

#[test]
fn refuses_other_meshes_and_perspective() {
    let torus = datasets_gen::generate("torus", Some(1000), 1).unwrap();
    for name in ["bcc-implicit", "bcc-implicit-skip"] {
        let mut s = sort::make(name).unwrap();
        let e = s.prepare(&torus).unwrap_err();
        assert!(matches!(e, Error::Input(_)), "{e}");
        let msg = e.to_string();
        assert!(msg.contains("lattice") && !msg.contains('\n'), "{msg}");
    }
    // A lattice mesh whose description does not fit (vertices moved) is refused too.
    let mesh = datasets_gen::generate("cc6", Some(1000), 1).unwrap();
    let mut moved: Vec<_> = mesh.positions().to_vec();
    moved[0].x += 0.1;
    let mut m2 = Mesh::with_scalars(
        "moved",
        moved,
        mesh.tets().to_vec(),
        "s",
        mesh.scalars().to_vec(),
    )
    .unwrap();
    m2.field_data = mesh.field_data.clone();
    let mut s = sort::make("bcc-implicit").unwrap();
    assert!(s
        .prepare(&m2)
        .unwrap_err()
        .to_string()
        .contains("lattice position"));
    s.prepare(&mesh).unwrap();
    let cam = Camera::new(&mesh.bbox(), View::new(10.0, 20.0), Projection::Persp, 8, 8);
    let e = s.sort(&mesh, &cam, &mut Vec::new()).unwrap_err();
    assert!(e.to_string().contains("orthographic"), "{e}");
}

/// A transfer function that is transparent below s = 0.6: most of a Marschner–Lobb volume
/// maps to τ = 0.
fn sparse_tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"name": "sparse", "range": [0, 1], "points": [
            {"s": 0.0, "rgb": [0, 0, 0], "tau": 0},
            {"s": 0.6, "rgb": [0.2, 0.4, 1.0], "tau": 0},
            {"s": 0.8, "rgb": [1.0, 0.6, 0.1], "tau": 30},
            {"s": 1.0, "rgb": [1.0, 1.0, 1.0], "tau": 40}]}"#,
        "sparse.json",
    )
    .unwrap()
}

#[test]
fn empty_space_skipping_keeps_the_image() {
    let tf = sparse_tf();
    for (name, mesh) in lattice_meshes() {
        for view in fibonacci_views(12) {
            let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 48, 48);
            let a = frame(&mesh, &tf, "bcc-implicit", &cam);
            let b = frame(&mesh, &tf, "bcc-implicit-skip", &cam);
            assert_eq!(a.image.pixels, b.image.pixels, "{name} {view:?}");
            let skipped = b.counter("tets_skipped").unwrap();
            assert!(
                skipped > 0.2 * mesh.num_tets() as f64,
                "{name}: {skipped} skipped"
            );
            assert_eq!(a.counter("tets_skipped"), Some(0.0));
        }
    }
}

#[test]
fn skipping_structure_is_rebuilt_when_the_tf_changes() {
    let mesh = isotropic_bcc();
    let mut s = sort::LatticeSort::new(true);
    use algorithms::sort::Sort;
    s.prepare(&mesh).unwrap();
    let cam = Camera::new(&mesh.bbox(), View::new(20.0, 30.0), Projection::Ortho, 8, 8);
    let mut order = Vec::new();
    // Before a TF: every tet.
    s.sort(&mesh, &cam, &mut order).unwrap();
    assert_eq!(order.len(), mesh.num_tets());
    s.set_transfer_function(&mesh, &sparse_tf()).unwrap();
    s.sort(&mesh, &cam, &mut order).unwrap();
    let sparse = order.len();
    assert_eq!(Some(sparse), s.visible_tets());
    assert!(sparse < mesh.num_tets() * 4 / 5, "{sparse}");
    s.set_transfer_function(&mesh, &TransferFunction::preset("cool-warm").unwrap())
        .unwrap();
    s.sort(&mesh, &cam, &mut order).unwrap();
    assert_eq!(order.len(), mesh.num_tets());
}
