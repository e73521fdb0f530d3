//! Hostile transfer functions: each is either refused with one line naming the point,
//! or renders finite pixels in [0, 1] with every renderer and integrator — never a panic, never a
//! NaN. Small mesh, 32²; the GPU renderers run where a GPU is (lavapipe in CI).

use algorithms::camera::{Camera, Projection, View};
use algorithms::render::{self, RenderOptions};
use algorithms::TransferFunction;

/// Renderer × integrator pairs to try (GPU ones only with a GPU).
fn variants() -> Vec<(&'static str, &'static str)> {
    let mut v = Vec::new();
    for r in ["cpu-pt", "raycast"] {
        for i in ["average", "partial", "preint", "exact"] {
            v.push((r, i));
        }
    }
    v.push(("reference", "exact"));
    if algorithms::gpu::test_gpu("hostile_tf").is_some() {
        for r in ["ptint", "hapt"] {
            for i in ["average", "partial", "preint"] {
                v.push((r, i));
            }
        }
    }
    v
}

fn render_all(what: &str, tf: &TransferFunction) {
    let mesh = datasets_gen::generate("spx", Some(2000), 1).unwrap();
    let cam = Camera::new(
        &mesh.bbox(),
        View::new(20.0, 10.0),
        Projection::Ortho,
        32,
        32,
    );
    for (r, i) in variants() {
        let opts = RenderOptions {
            integrator: Some(i.into()),
            ..Default::default()
        };
        let mut ren = render::make(r, &opts).unwrap();
        ren.prepare(&mesh, tf)
            .unwrap_or_else(|e| panic!("{what} {r} {i}: {e}"));
        let f = ren
            .render(&mesh, &cam)
            .unwrap_or_else(|e| panic!("{what} {r} {i}: {e}"));
        assert_eq!(f.image.non_finite_pixels(), 0, "{what} {r} {i}");
        assert!(
            f.image
                .pixels
                .iter()
                .flatten()
                .all(|&c| (0.0..=1.0001).contains(&c)),
            "{what} {r} {i}: pixel out of [0, 1]"
        );
    }
}

#[test]
fn huge_scalar_range_renders_finite() {
    // The table step (s_hi − s_lo)/127 overflowed to inf and `eval` met NaN (index out of bounds).
    let tf = TransferFunction::from_json(
        r#"{"points":[{"s":-1e308,"rgb":[0,0,0],"tau":1},{"s":1e308,"rgb":[1,1,1],"tau":1}]}"#,
        "huge.json",
    )
    .unwrap();
    render_all("s = ±1e308", &tf);
}

#[test]
fn subnormal_and_huge_extinction_render_finite() {
    for (what, json) in [
        (
            "tau 5e-309",
            r#"{"points":[{"s":0,"rgb":[1,0.5,0],"tau":5e-309},{"s":1,"rgb":[0,1,1],"tau":5e-309}]}"#,
        ),
        (
            "tau 1e300",
            r#"{"points":[{"s":0,"rgb":[1,0.5,0],"tau":1e300},{"s":1,"rgb":[0,1,1],"tau":1e-300}]}"#,
        ),
    ] {
        let tf = TransferFunction::from_json(json, "t.json").unwrap();
        render_all(what, &tf);
    }
}

#[test]
fn colours_outside_unit_range_are_refused_naming_the_point() {
    for json in [
        r#"{"points":[{"s":0,"rgb":[0,0,0],"tau":1},{"s":1,"rgb":[1e39,1,1],"tau":1}]}"#,
        r#"{"points":[{"s":0,"rgb":[0,0,0],"tau":1},{"s":1,"rgb":[1,1,1e308],"tau":0}]}"#,
        r#"{"points":[{"s":0,"rgb":[0,0,0],"tau":1},{"s":1,"rgb":[1,1.5,1],"tau":1}]}"#,
    ] {
        let e = TransferFunction::from_json(json, "c.json")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("c.json: points[1].rgb") && e.contains("[0, 1]"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn a_million_points_are_refused_with_the_bound() {
    let mut s = String::from(r#"{"points":["#);
    for i in 0..1_000_000 {
        if i > 0 {
            s.push(',');
        }
        s.push_str(&format!(
            r#"{{"s":{},"rgb":[0.5,0.5,0.5],"tau":{}}}"#,
            i as f64 / 999_999.0,
            i % 7
        ));
    }
    s.push_str("]}");
    let e = TransferFunction::from_json(&s, "m.json")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.json: ") && e.contains("1000000 points") && e.contains("at most"),
        "{e}"
    );
}

#[test]
fn the_largest_accepted_tf_renders_with_every_integrator() {
    let n = TransferFunction::MAX_POINTS;
    let points: Vec<String> = (0..n)
        .map(|i| {
            let x = i as f64 / (n - 1) as f64;
            format!(
                r#"{{"s":{x},"rgb":[{},{},0.5],"tau":{}}}"#,
                (i % 2) as f64,
                (i % 3) as f64 / 2.0,
                ((i * 7) % 11) as f64
            )
        })
        .collect();
    let json = format!(r#"{{"points":[{}]}}"#, points.join(","));
    let tf = TransferFunction::from_json(&json, "max.json").unwrap();
    render_all("MAX_POINTS points", &tf);
}
