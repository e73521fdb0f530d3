//! The ray caster's images are pinned bit for bit: each case renders a small image in f64
//! ([`RayCaster::render_f64`]) and hashes every bit of it with the frame's cell-step and
//! missed-ray counts. A change to any pixel's last bit, or to the cells a ray visits, fails
//! here. The pins were re-taken, deliberately, each time the walk's or the optics' rounding
//! changed on purpose (for `partial`: the projected walk, the shared frame of orthographic
//! views, f32 segment optics, a queue's segments composited among themselves; for `exact`: the
//! projected walk and the pieces' Gauss–Legendre quadrature): the same cells and steps every
//! time, the values within last bits, and `projected_walk_matches_the_reference_walk` below
//! holds the projected walk to the reference walk within 1e-9 with both integrators (`exact`
//! itself is held to a 50-digit evaluation of the model by `exact_oracle.rs`). `git log` of
//! this file says when and why.

use algorithms::camera::{Camera, Projection, View};
use algorithms::render::raycast::RayCaster;
use algorithms::render::Renderer;
use algorithms::tf::TransferFunction;

/// FNV-1a over the bytes of every f64 of the image, then the two counters.
fn hash(px: &[[f64; 4]], steps: u64, missed: u64) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: u64| {
        for b in x.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for p in px {
        for c in p {
            eat(c.to_bits());
        }
    }
    eat(steps);
    eat(missed);
    h
}

/// (mesh, tets, view, projection, integrator, expected hash).
type Case = (
    &'static str,
    usize,
    (f64, f64),
    Projection,
    &'static str,
    u64,
);
const CASES: &[Case] = &[
    (
        "spx",
        13_000,
        (30.0, 20.0),
        Projection::Ortho,
        "exact",
        0x531e_9a8d_cba1_a4b1,
    ),
    (
        "spx",
        13_000,
        (157.57, -64.16),
        Projection::Persp,
        "exact",
        0xa66a_5a49_de9c_2422,
    ),
    (
        "spx",
        13_000,
        (30.0, 20.0),
        Projection::Ortho,
        "partial",
        0xc807_e3a5_e53b_e5e6,
    ),
    (
        "hard-zero-volume",
        24_000,
        (30.0, 20.0),
        Projection::Ortho,
        "exact",
        0x3c5a_297f_480a_581f,
    ),
    (
        "hard-negative",
        24_000,
        (45.0, 35.0),
        Projection::Persp,
        "exact",
        0x98ec_9426_7ba1_a318,
    ),
    (
        "hard-mpvonc",
        24_000,
        (10.0, 80.0),
        Projection::Ortho,
        "exact",
        0x69e4_8c37_9e2c_5408,
    ),
    (
        "hard-duplicates",
        24_000,
        (90.0, 0.0),
        Projection::Ortho,
        "partial",
        0xadd4_4854_775c_9cb0,
    ),
    (
        "torus",
        20_000,
        (30.0, 60.0),
        Projection::Persp,
        "partial",
        0x038a_f565_eedf_e617,
    ),
];

#[test]
fn ray_caster_images_are_bit_identical_to_the_pinned_ones() {
    let tf = TransferFunction::preset("default").unwrap();
    let mut bad = Vec::new();
    for &(name, tets, (az, el), proj, integrator, want) in CASES {
        let mesh = datasets_gen::generate(name, Some(tets), 1).unwrap();
        let mut rc = RayCaster::new(integrator, "raycast");
        rc.prepare(&mesh, &tf).unwrap();
        let cam = Camera::new(&mesh.bbox(), View::new(az, el), proj, 96, 80);
        let (px, stats) = rc.render_f64(&mesh, &cam).unwrap();
        assert_eq!(stats.missed, 0, "{name}: a hole");
        let got = hash(&px, stats.steps, stats.missed);
        println!("{name} {az},{el} {proj:?} {integrator}: {got:#018x}");
        if got != want {
            bad.push(format!(
                "{name} {az},{el} {proj:?} {integrator}: {got:#018x} != {want:#018x}"
            ));
        }
    }
    assert!(bad.is_empty(), "images changed:\n{}", bad.join("\n"));
}

/// The projected walk (the default) visits the same cells as the reference walk (its signs are
/// the exact predicate's), so it has the same cell steps and the same image up to the rounding
/// of the crossings (interpolated in the ray's frame instead of in 3-D), with `partial` and with
/// `exact` (`reference`), and its own image is pinned too: the same bits run after run.
#[test]
fn projected_walk_matches_the_reference_walk() {
    let tf = TransferFunction::preset("default").unwrap();
    let mut bad = Vec::new();
    let views = [
        ((30.0, 20.0), Projection::Ortho),
        ((157.57, -64.16), Projection::Persp),
        ((90.0, 0.0), Projection::Ortho),
        ((45.0, 35.0), Projection::Persp),
    ];
    for (name, tets) in [
        ("spx", 13_000),
        ("hard-zero-volume", 24_000),
        ("hard-negative", 24_000),
        ("hard-duplicates", 24_000),
        ("hard-mpvonc", 24_000),
        ("torus", 20_000),
    ] {
        let mesh = datasets_gen::generate(name, Some(tets), 1).unwrap();
        for integrator in ["partial", "exact"] {
            let mut rc = RayCaster::new(integrator, "raycast");
            rc.prepare(&mesh, &tf).unwrap();
            for &((az, el), proj) in &views {
                let cam = Camera::new(&mesh.bbox(), View::new(az, el), proj, 96, 80);
                rc.set_projected_walk(false);
                let (want, ws) = rc.render_f64(&mesh, &cam).unwrap();
                rc.set_projected_walk(true);
                let (got, gs) = rc.render_f64(&mesh, &cam).unwrap();
                let (again, _) = rc.render_f64(&mesh, &cam).unwrap();
                let case = format!("{name} {az},{el} {proj:?} {integrator}");
                assert_eq!(gs.missed, 0, "{case}: a hole");
                assert_eq!(gs.lost, 0, "{case}: a lost ray");
                assert_eq!(gs.steps, ws.steps, "{case}: other cells");
                assert_eq!(gs.reentries, ws.reentries, "{case}: other re-entries");
                assert!(
                    got.iter()
                        .zip(&again)
                        .all(|(a, b)| a.map(f64::to_bits) == b.map(f64::to_bits)),
                    "{case}: two runs differ"
                );
                let max = got
                    .iter()
                    .zip(&want)
                    .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs()))
                    .fold(0.0, f64::max);
                println!(
                    "{case}: {} steps, {} filter fallbacks, max |diff| {max:.3e}",
                    gs.steps, gs.filter_fallbacks
                );
                if max > 1e-9 {
                    bad.push(format!("{case}: max |diff| {max:.3e}"));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "projected walk differs:\n{}",
        bad.join("\n")
    );
}

/// The projected walk shades its segments a queue at a time; a ray that turns opaque part way
/// through a queue must stop where compositing segment by segment stops it, counting the same
/// cell steps. With a transfer function 10⁴ times as opaque as `default` most rays stop after a
/// few cells; the projected walk's step counts and images match the reference walk's (which
/// composites each segment as it goes).
#[test]
fn opaque_rays_stop_where_the_reference_walk_stops_them() {
    let mut tf = TransferFunction::preset("default").unwrap();
    for p in &mut tf.points {
        p.tau *= 1e4;
    }
    let clear = TransferFunction::preset("default").unwrap();
    for (name, tets) in [("spx", 13_000), ("torus", 20_000)] {
        let mesh = datasets_gen::generate(name, Some(tets), 1).unwrap();
        for ((az, el), proj) in [
            ((30.0, 20.0), Projection::Ortho),
            ((45.0, 35.0), Projection::Persp),
        ] {
            let case = format!("{name} {az},{el} {proj:?}");
            let cam = Camera::new(&mesh.bbox(), View::new(az, el), proj, 96, 80);
            let mut rc = RayCaster::new("partial", "raycast");
            rc.prepare(&mesh, &clear).unwrap();
            let (_, cs) = rc.render_f64(&mesh, &cam).unwrap();
            rc.prepare(&mesh, &tf).unwrap();
            rc.set_projected_walk(false);
            let (want, ws) = rc.render_f64(&mesh, &cam).unwrap();
            rc.set_projected_walk(true);
            let (got, gs) = rc.render_f64(&mesh, &cam).unwrap();
            assert!(
                2 * ws.steps < cs.steps,
                "{case}: the opaque TF should stop rays early ({} of {} steps)",
                ws.steps,
                cs.steps
            );
            assert_eq!(gs.steps, ws.steps, "{case}: other cell steps");
            assert_eq!(gs.reentries, ws.reentries, "{case}: other re-entries");
            assert_eq!(gs.missed, 0, "{case}: a hole");
            let max = got
                .iter()
                .zip(&want)
                .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs()))
                .fold(0.0, f64::max);
            assert!(max <= 1e-9, "{case}: max |diff| {max:.3e}");
            println!(
                "{case}: {} of {} steps, max |diff| {max:.3e}",
                gs.steps, cs.steps
            );
        }
    }
}
