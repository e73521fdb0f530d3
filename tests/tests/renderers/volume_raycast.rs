//! `volume-raycast`: the regular volume a lattice mesh's vertices sample, ray cast with the BCC
//! paper's schemes, gives the same image as ray casting the volume sampled from the field
//! itself; it refuses meshes without a lattice, schemes of the other lattice and bad parameters
//! in one line.

use algorithms::bcc::recon::{self, BccVolume, CcVolume, Sampling, Scheme, Volume};
use algorithms::camera::{Camera, Projection, View};
use algorithms::glam::DVec3;
use algorithms::image::Image;
use algorithms::optics::integrator;
use algorithms::render::{self, RenderOptions};
use algorithms::{Mesh, TransferFunction};

fn field(p: DVec3) -> f64 {
    datasets_gen::fields::marschner_lobb(p)
}

fn with_field(p: Vec<DVec3>, t: Vec<[u32; 4]>, l: &datasets_gen::Lattice) -> Mesh {
    let s = p.iter().map(|&x| field(x)).collect();
    let mut m = Mesh::with_scalars("lattice", p, t, "ml", s).unwrap();
    m.field_data
        .insert(datasets_gen::LATTICE_KEY.into(), l.to_field_data());
    m
}

fn tf() -> TransferFunction {
    let mut t = TransferFunction::preset("default").unwrap();
    t.range = Some([0.0, 1.0]);
    t
}

fn render(mesh: &Mesh, scheme: &str, cam: &Camera) -> Image {
    let opts = RenderOptions {
        params: vec![("scheme".into(), scheme.into())],
        ..Default::default()
    };
    let mut r = render::make("volume-raycast", &opts).unwrap();
    r.prepare(mesh, &tf()).unwrap();
    r.render(mesh, cam).unwrap().image
}

#[test]
fn the_meshes_samples_cast_as_the_fields_own_volume() {
    let o = DVec3::splat(-1.0);
    let bbox = algorithms::mesh::Aabb {
        min: o,
        max: DVec3::ONE,
    };
    let t = tf();
    let exact = integrator("exact", &t).unwrap();
    let sampling = |step| Sampling {
        map: t.scalar_map((0.0, 1.0)),
        integ: exact.as_ref(),
        step,
        diag: bbox.diagonal(),
    };
    // CC: 6 cells per axis.
    let h = DVec3::splat(2.0 / 6.0);
    let (b, l) = datasets_gen::cc_lattice([6; 3], datasets_gen::Split::Five, o, h);
    let cc = with_field(b.positions, b.tets, &l);
    let vol = CcVolume::sample([7; 3], o, h, field);
    // BCC: 5 primary points per axis.
    let hb = DVec3::splat(0.5);
    let (p, tets, lb) = datasets_gen::bcc_lattice([5; 3], o, hb);
    let bcc = with_field(p, tets, &lb);
    let bvol = BccVolume::sample([5; 3], o, hb, field);
    for v in [
        View::new(30.0, 20.0),
        View::new(200.0, -50.0),
        View::new(0.0, 0.0),
    ] {
        let cam = Camera::new(&bbox, v, Projection::Ortho, 24, 24);
        let want = recon::raycast(
            Volume::Cc(&vol),
            Scheme::Trilinear,
            &cam,
            sampling(h.x / 2.0),
        )
        .unwrap();
        assert_eq!(render(&cc, "tril", &cam).pixels, want.pixels, "tril {v:?}");
        for s in [
            Scheme::Bilinear,
            Scheme::BilinearSpatial,
            Scheme::Barycentric,
            Scheme::ShearedTrilinear,
        ] {
            let step = hb.x / (2.0 * std::f64::consts::SQRT_2);
            let want = recon::raycast(Volume::Bcc(&bvol), s, &cam, sampling(step)).unwrap();
            let got = render(&bcc, s.name(), &cam);
            assert_eq!(got.pixels, want.pixels, "{} {v:?}", s.name());
            assert_eq!(got.non_finite_pixels(), 0);
        }
    }
}

#[test]
fn wrong_meshes_schemes_and_params_are_refused_in_one_line() {
    let plain = datasets_gen::generate("spx", Some(300), 1).unwrap();
    let cc = datasets_gen::generate("cc5", Some(300), 1).unwrap();
    let prep = |mesh: &Mesh, params: &[(&str, &str)]| {
        let opts = RenderOptions {
            params: params
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            ..Default::default()
        };
        render::make("volume-raycast", &opts).and_then(|mut r| r.prepare(mesh, &tf()))
    };
    for (mesh, params, want) in [
        (&plain, &[][..], "lattice"),
        (&cc, &[("scheme", "bary")][..], "scheme bary"),
        (&cc, &[("scheme", "cubic")][..], "scheme=cubic"),
        (&cc, &[("step", "-1")][..], "step=-1"),
    ] {
        let e = prep(mesh, params).unwrap_err().to_string();
        assert!(e.contains(want) && !e.contains('\n'), "{e}");
    }
    assert!(prep(&cc, &[("scheme", "auto"), ("step", "0.1")]).is_ok());
}
