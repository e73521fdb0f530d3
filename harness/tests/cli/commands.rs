//! The `tetbench` command line end to end: outputs of CONVENTIONS §8 and exit codes for bad input.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::test_util::{command, tetbench, tmpdir, two_tets_in};

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The value of a `name: value` line.
fn field(out: &str, name: &str) -> String {
    out.lines()
        .find_map(|l| l.strip_prefix(&format!("{name}: ")))
        .unwrap_or_else(|| panic!("no '{name}:' line in\n{out}"))
        .to_string()
}

/// Asserts exit status 2 and one line on stderr containing `want`.
fn assert_user_error(o: &Output, want: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {err}");
    assert!(lines[0].contains(want), "{want:?} not in {err:?}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn info_prints_the_fields_of_the_conventions() {
    let d = tmpdir("info");
    let p = two_tets_in(&d);
    let o = tetbench(&["info", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert_eq!(field(&out, "vertices"), "5");
    assert_eq!(field(&out, "tets"), "2");
    assert_eq!(field(&out, "scalar_range"), "[0.5, 4]");
    assert_eq!(field(&out, "bbox"), "[0, 0, 0] [1, 1, 1]");
    assert_eq!(field(&out, "degenerate_tets"), "0");
    assert_eq!(field(&out, "boundary_faces"), "6");
    assert_eq!(field(&out, "convex"), "true");
    let j = tetbench(&["info", p.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&j.stdout).unwrap();
    assert_eq!(v["tets"], 2);
    assert_eq!(v["scalar_range"][1], 4.0);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn nasa_grids_have_the_papers_sizes() {
    // The data files are not committed; CI has them in ../shared/datasets.
    let Ok(dir) = std::env::var("TETBENCH_DATA")
        .map(PathBuf::from)
        .or_else(|_| {
            Ok::<_, ()>(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/datasets"))
        })
    else {
        return;
    };
    if !dir.join("postxyz.bin").exists() {
        eprintln!("NASA grids not found in {}: skipped", dir.display());
        return;
    }
    for (name, v, t, lo, hi) in [
        ("blunt", "40960", "187395", 0.193, 4.98),
        ("post", "109744", "513375", 0.0, 1.39),
        ("comb", "47025", "215040", 0.198, 0.710),
    ] {
        let o = tetbench(&["info", name, "--json"]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["vertices"].to_string(), v, "{name}");
        assert_eq!(j["tets"].to_string(), t, "{name}");
        let r = j["scalar_range"].as_array().unwrap();
        let (a, b) = (r[0].as_f64().unwrap(), r[1].as_f64().unwrap());
        assert!(
            (a - lo).abs() < 0.005 && (b - hi).abs() < 0.01,
            "{name}: range [{a}, {b}]"
        );
    }
}

#[test]
fn compare_an_image_with_itself_and_with_another() {
    let d = tmpdir("compare");
    let p = two_tets_in(&d);
    let a = d.join("a.exr");
    let o = tetbench(&[
        "render",
        p.to_str().unwrap(),
        "--renderer",
        "reference",
        "--size",
        "24x16",
        "--view",
        "20,10",
        "--out",
        a.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let same = tetbench(&["compare", a.to_str().unwrap(), a.to_str().unwrap()]);
    assert!(same.status.success());
    let out = stdout(&same);
    assert_eq!(field(&out, "rmse"), "0");
    assert_eq!(field(&out, "diff_pixels_pct"), "0");
    assert_eq!(field(&out, "psnr"), "inf");

    // Hand-checked: a 2×1 PNG pair, pixel 0 equal (0.2 grey), pixel 1 red 0 vs 1.
    let write_png = |path: &Path, px: [[u8; 4]; 2]| {
        let f = std::fs::File::create(path).unwrap();
        let mut e = png::Encoder::new(f, 2, 1);
        e.set_color(png::ColorType::Rgba);
        e.set_depth(png::BitDepth::Eight);
        e.write_header()
            .unwrap()
            .write_image_data(px.as_flattened())
            .unwrap();
    };
    let (x, y) = (d.join("x.png"), d.join("y.png"));
    write_png(&x, [[51, 51, 51, 255], [0, 0, 0, 255]]);
    write_png(&y, [[51, 51, 51, 255], [255, 0, 0, 255]]);
    let o = tetbench(&[
        "compare",
        x.to_str().unwrap(),
        y.to_str().unwrap(),
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // rmse = sqrt(1² / 6); both pixels non-background, one differs; one channel differs by 255.
    assert!((j["rmse"].as_f64().unwrap() - (1.0f64 / 6.0).sqrt()).abs() < 1e-12);
    assert_eq!(j["diff_pixels_pct"], 50.0);
    assert_eq!(j["max_err_pct"], 100.0);
    assert_eq!(j["avg_err_pct"], 100.0);
    assert_eq!(j["max_abs"], 1.0);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn render_prints_the_timing_split_and_memory() {
    let d = tmpdir("render");
    let p = two_tets_in(&d);
    let out = d.join("r.png");
    let o = tetbench(&[
        "render",
        p.to_str().unwrap(),
        "--renderer",
        "raycast",
        "--integrator",
        "partial",
        "--projection",
        "persp",
        "--size",
        "16x16",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    for k in [
        "setup_ms",
        "project_ms",
        "sort_ms",
        "draw_ms",
        "readback_ms",
        "total_ms",
        "tets_per_s",
    ] {
        let v: f64 = field(&s, k).parse().unwrap();
        assert!(v >= 0.0, "{k}");
    }
    let bytes: f64 = field(&s, "cpu_bytes_per_tet").parse().unwrap();
    assert!(bytes > 0.0, "memory measured: {bytes}");
    assert_eq!(field(&s, "non_finite_pixels"), "0");
    assert_eq!(field(&s, "lost_rays"), "0");
    assert!(out.exists());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_input_exits_2_with_one_line_and_no_output_file() {
    let d = tmpdir("bad");
    let good = two_tets_in(&d);
    let bad = d.join("bad.off");
    std::fs::write(
        &bad,
        "5 2\n0 0 0 0.5\n1 0 0 1\n0 1 0 2\n0 0 1 3\n1 1 1 4\n0 1 2 3\n1 2 3 9\n",
    )
    .unwrap();
    let tf = d.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points": [{"s": 0.5, "rgb": [1,1,1], "tau": -1}]}"#,
    )
    .unwrap();
    let out = d.join("o.exr");
    let (g, o) = (good.to_str().unwrap(), out.to_str().unwrap());
    assert_user_error(
        &tetbench(&["info", bad.to_str().unwrap()]),
        "bad.off: line 8: tet 1",
    );
    assert_user_error(&tetbench(&["info", "no/such/file.off"]), "no/such/file.off");
    assert_user_error(
        &tetbench(&["render", g, "--renderer", "nope", "--out", o]),
        "unknown renderer 'nope'",
    );
    assert_user_error(
        &tetbench(&[
            "render",
            g,
            "--renderer",
            "raycast",
            "--integrator",
            "magic",
            "--out",
            o,
        ]),
        "integrator 'magic'",
    );
    assert_user_error(
        &tetbench(&[
            "render",
            g,
            "--renderer",
            "raycast",
            "--tf",
            tf.to_str().unwrap(),
            "--out",
            o,
        ]),
        "tf.json: points[0].tau",
    );
    assert_user_error(
        &tetbench(&[
            "render",
            g,
            "--renderer",
            "raycast",
            "--size",
            "0x3",
            "--out",
            o,
        ]),
        "--size",
    );
    assert_user_error(
        &tetbench(&[
            "render",
            g,
            "--renderer",
            "raycast",
            "--view",
            "1",
            "--out",
            o,
        ]),
        "--view",
    );
    assert_user_error(
        &tetbench(&["render", g, "--renderer", "raycast", "--out", "x.tiff"]),
        "x.tiff",
    );
    assert_user_error(&tetbench(&["compare", o, o]), "o.exr");
    assert!(!out.exists(), "no output after a failed run");
    // clap's own usage errors also exit 2.
    let o = tetbench(&["render", g]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).ok();
}

/// Every registered renderer refuses a parameter it does not declare, and a repeated one, with
/// one line and exit 2 (the check is the registry's, before anything is made or loaded).
#[test]
fn unknown_and_repeated_params_exit_2_for_every_renderer() {
    let d = tmpdir("params");
    let o = d.join("x.png");
    let o = o.to_str().unwrap();
    for name in algorithms::render::names() {
        if algorithms::render::is_wrapper(name) {
            continue;
        }
        let r = tetbench(&[
            "render",
            "spx:200",
            "--renderer",
            name,
            "--param",
            "bogus=1",
            "--size",
            "8x8",
            "--out",
            o,
        ]);
        assert_user_error(&r, &format!("renderer '{name}': unknown parameter 'bogus'"));
        let info = algorithms::render::info(name).unwrap();
        if let Some(p) = info.params.first() {
            let kv = format!("{}={}", p.name, p.default);
            let r = tetbench(&[
                "render",
                "spx:200",
                "--renderer",
                name,
                "--param",
                &kv,
                "--param",
                &kv,
                "--size",
                "8x8",
                "--out",
                o,
            ]);
            assert_user_error(&r, "given twice");
        }
    }
    let r = tetbench(&["render", "spx:200", "--renderer", "raycats", "--out", o]);
    assert_user_error(&r, "did you mean 'raycast'");
    assert!(!Path::new(o).exists());
    std::fs::remove_dir_all(&d).ok();
}

/// An adapter that cannot blend `Rgba32Float` (wgpu's GL backend: llvmpipe without a Vulkan
/// driver) is refused by name: its `Rgba16Float` target put the GPU renderers ~25x further from
/// `cpu-pt`. Runs where the GL backend has an adapter (EGL installed, as on CI).
#[test]
fn an_adapter_without_f32_blending_is_refused_by_name() {
    let gl = |args: &[&str]| {
        command()
            .args(args)
            .env("WGPU_BACKEND", "gl")
            .env_remove("TETBENCH_ADAPTER")
            .output()
            .expect("run tetbench")
    };
    let list = stdout(&gl(&["list"]));
    if !list.lines().any(|l| l.contains("(Gl, ")) {
        eprintln!("an_adapter_without_f32_blending_is_refused_by_name: SKIPPED (no GL adapter)");
        return;
    }
    let d = tmpdir("gl");
    for renderer in ["ptint", "hapt"] {
        let out = d.join(format!("{renderer}.png"));
        let o = gl(&[
            "render",
            "spx:1500",
            "--renderer",
            renderer,
            "--size",
            "16x16",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_user_error(&o, "cannot blend Rgba32Float");
        assert!(stderr(&o).contains("(Gl, "), "{}", stderr(&o));
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&d);
}
