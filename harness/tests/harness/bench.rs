//! `tetbench bench` and `plot` end to end on tiny experiments, and the reproduce table writer.

use std::path::Path;
use std::process::Output;

use crate::test_util::{command, tetbench, tmpdir, Csv};

/// `tetbench bench CFG --out OUT --no-plots` with no VTK Python configured (VTK variants are
/// then unavailable).
fn bench_without_vtk(cfg: &Path, out: &Path) -> Output {
    command()
        .args([
            "bench",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .arg("--no-plots")
        .env_remove("TETBENCH_VTK_PYTHON")
        .output()
        .expect("run tetbench")
}

fn stderr_lines(o: &Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .map(String::from)
        .collect()
}

const TINY: &str = r#"
name = "tiny"
datasets = ["spx:1500", { mesh = "torus", tets = 2000, label = "torus-2k" }]
renderers = [{ name = "raycast", integrators = ["partial"] }, { name = "reference" }]
sizes = ["32x32"]
repeats = 2
warmup = 1
[views]
named = ["0,0", "90,30"]
"#;

const COLUMNS: [&str; 30] = [
    "dataset",
    "tets",
    "vertices",
    "renderer",
    "sort",
    "integrator",
    "width",
    "height",
    "view_id",
    "azimuth",
    "elevation",
    "projection",
    "repeats",
    "threads",
    "device",
    "setup_ms",
    "project_ms",
    "sort_ms",
    "draw_ms",
    "readback_ms",
    "total_ms",
    "tets_per_s",
    "cpu_bytes_per_tet",
    "gpu_bytes_per_tet",
    "rmse",
    "psnr",
    "max_abs",
    "diff_pixels_pct",
    "max_err_pct",
    "avg_err_pct",
];

/// The images in the reference cache (each has its checksum file beside it).
fn count_cache(dir: &Path) -> usize {
    std::fs::read_dir(dir.join(".cache"))
        .map(|d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "exr"))
            })
            .count()
        })
        .unwrap_or(0)
}

#[test]
fn tiny_bench_writes_rows_caches_references_and_plots() {
    let d = tmpdir("tiny");
    let cfg = d.join("tiny.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let out = d.join("out");
    let o = tetbench(&[
        "bench",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        stdout.contains("reference_images: 4 rendered, 0 from cache"),
        "{stdout}"
    );

    let Csv { head, rows } = Csv::read(&out.join("results.csv"));
    for c in COLUMNS {
        assert!(
            head.iter().any(|h| h == c),
            "column {c} missing in {head:?}"
        );
    }
    // 2 datasets × 2 variants × 1 size × 2 views.
    assert_eq!(rows.len(), 8);
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    for r in &rows {
        let num = |c: &str| r[col(c)].parse::<f64>().unwrap_or(f64::NAN);
        assert_eq!(r[col("width")], "32");
        assert_eq!(r[col("repeats")], "2");
        assert!(num("tets") > 1000.0);
        assert!(num("total_ms") > 0.0 && num("tets_per_s") > 0.0, "{r:?}");
        assert!(num("cpu_bytes_per_tet") > 0.0, "{r:?}");
        assert_eq!(num("gpu_bytes_per_tet"), 0.0);
        assert!(num("rmse") >= 0.0 && num("rmse") < 0.5, "{r:?}");
        if r[col("renderer")] == "reference" {
            assert_eq!(num("rmse"), 0.0, "reference against itself: {r:?}");
            assert_eq!(num("max_err_pct"), 0.0);
            assert_eq!(r[col("psnr")], "inf");
        }
    }
    assert_eq!(count_cache(&out), 4);

    // Plots: PNG and SVG, non-empty.
    for p in ["speed_vs_error", "stages"] {
        for ext in ["png", "svg"] {
            let f = out.join(format!("{p}.{ext}"));
            let len = std::fs::metadata(&f).map(|m| m.len()).unwrap_or(0);
            assert!(len > 1000, "{} is {len} bytes", f.display());
        }
    }
    // Two mesh sizes: the throughput plot is drawn.
    assert!(out.join("tets_per_s_vs_size.png").exists());
    // The image figure of the sweep and the report beside the results.
    for f in ["results-images.png", "results-images.svg", "index.html"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(stdout.contains("report: "), "{stdout}");

    // Second run (forced: the directory holds results): every reference image from the cache.
    let o = tetbench(&[
        "bench",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
        "--force",
    ]);
    assert!(o.status.success());
    let stdout = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        stdout.contains("reference_images: 0 rendered, 4 from cache"),
        "{stdout}"
    );
    assert_eq!(count_cache(&out), 4);

    // `plot` redraws from the CSV.
    std::fs::remove_file(out.join("stages.png")).unwrap();
    let o = tetbench(&["plot", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::metadata(out.join("stages.png")).unwrap().len() > 1000);
}

#[test]
fn rotation_views_and_saved_images() {
    let d = tmpdir("rot");
    let cfg = d.join("rot.toml");
    std::fs::write(
        &cfg,
        r#"
datasets = ["spx:800"]
renderers = [{ name = "raycast" }]
sizes = ["16x16"]
repeats = 1
warmup = 0
error = false
save_images = true
views = { rotate = { frames = 3, axis = "y" } }
"#,
    )
    .unwrap();
    let out = d.join("out");
    let o = tetbench(&[
        "bench",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Csv { head, rows } = Csv::read(&out.join("results.csv"));
    assert_eq!(rows.len(), 3);
    let az = head.iter().position(|h| h == "azimuth").unwrap();
    let az: Vec<f64> = rows.iter().map(|r| r[az].parse().unwrap()).collect();
    assert_eq!(az, vec![0.0, 240.0, 120.0]);
    let rmse = head.iter().position(|h| h == "rmse").unwrap();
    assert!(
        rows.iter().all(|r| r[rmse].is_empty()),
        "error = false leaves it empty"
    );
    let imgs = std::fs::read_dir(out.join("images").join("spx_800"))
        .unwrap()
        .count();
    assert_eq!(imgs, 6, "EXR + PNG per view");
}

/// An `optional` renderer that cannot run here (VTK's peer with `TETBENCH_VTK_PYTHON` unset)
/// gives failed rows whose note says why, and the other renderer's rows are measured; the same
/// entry without `optional` refuses the experiment (exit 2, one line).
#[test]
fn optional_renderer_not_enabled_gives_a_failed_row_not_an_abort() {
    let d = tmpdir("optional");
    let run = |optional: bool| {
        let cfg = d.join(format!("opt{optional}.toml"));
        std::fs::write(
            &cfg,
            format!(
                r#"
datasets = ["spx:800"]
renderers = [{{ name = "vtk-pt", optional = {optional} }}, {{ name = "cpu-pt" }}]
sizes = ["16x16"]
repeats = 1
warmup = 0
error = false
[views]
named = ["0,0"]
"#
            ),
        )
        .unwrap();
        let out = d.join(format!("out{optional}"));
        let o = bench_without_vtk(&cfg, &out);
        (o, out)
    };
    let (o, out) = run(true);
    let Csv { head, rows } = Csv::read(&out.join("results.csv"));
    assert_eq!(rows.len(), 2, "{}", String::from_utf8_lossy(&o.stderr));
    let col = |n: &str| head.iter().position(|h| h == n).unwrap();
    let vtk = rows
        .iter()
        .find(|r| r[col("renderer")] == "vtk-pt")
        .unwrap();
    assert_eq!(vtk[col("total_ms")], "NaN");
    assert!(vtk[col("note")].contains("TETBENCH_VTK_PYTHON"), "{vtk:?}");
    let cpu = rows
        .iter()
        .find(|r| r[col("renderer")] == "cpu-pt")
        .unwrap();
    assert!(cpu[col("total_ms")].parse::<f64>().unwrap() > 0.0);
    assert!(cpu[col("note")].is_empty());
    let (o, out) = run(false);
    assert_one_line_exit2(&o, &["vtk-pt", "TETBENCH_VTK_PYTHON"]);
    assert!(!out.join("results.csv").exists());
}

fn assert_one_line_exit2(o: &Output, want: &[&str]) {
    let lines = stderr_lines(o);
    assert_eq!(o.status.code(), Some(2), "{lines:?}");
    assert_eq!(lines.len(), 1, "{lines:?}");
    for w in want {
        assert!(lines[0].contains(w), "{w:?} not in {lines:?}");
    }
}

#[test]
fn bad_experiment_files_exit_2_naming_the_key() {
    let d = tmpdir("bad");
    let out = d.join("out");
    let cases: [(&str, &[&str]); 6] = [
        ("datasets = [\"spx\"]\nrenderers = [{ name = \"raycast\", integrator = [\"partial\"] }]\n", &["renderers[0]", "integrator"]),
        ("datasets = [\"spx\"]\nrenderers = [{ name = \"raycats\" }]\n", &["renderers[0].name", "raycats"]),
        ("datasets = [\"spx\"]\nrenderers = [{ name = \"raycast\" }]\nsizes = [\"32x\"]\n", &["sizes[0]"]),
        ("datasets = [\"spx\"]\nrenderers = [{ name = \"raycast\" }]\nrepeats = \"three\"\n", &["repeats"]),
        ("datasets = [\"nosuchmesh\"]\nrenderers = [{ name = \"raycast\" }]\n", &["datasets[0]", "nosuchmesh"]),
        ("datasets = [\"spx\"]\nrenderers = [{ name = \"raycast\" }]\n[views]\nrotate = { frames = 4, axis = \"w\" }\n", &["views.rotate.axis"]),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let cfg = d.join(format!("bad{i}.toml"));
        std::fs::write(&cfg, text).unwrap();
        let o = tetbench(&[
            "bench",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_one_line_exit2(&o, want);
        assert!(
            !out.join("results.csv").exists(),
            "no output for a bad config"
        );
    }
    // Not TOML at all.
    let cfg = d.join("garbage.toml");
    std::fs::write(&cfg, "datasets = [\n").unwrap();
    let o = tetbench(&[
        "bench",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_one_line_exit2(&o, &["garbage.toml"]);
}

#[test]
fn table_writer_writes_csv_and_markdown() {
    use tetbench::table::{write_table, Table};
    let d = tmpdir("table");
    let t = Table {
        id: "tiny-table".into(),
        title: "Tiny table".into(),
        columns: vec!["Dataset".into(), "paper fps".into(), "fps".into()],
        hardware: vec![false, true, true],
        rows: vec![vec!["spx".into(), "95.32".into(), "12.5".into()]],
        notes: vec!["a note".into()],
    };
    write_table(&t, &d, "Test CPU, 2 cores", "2026-01-01 00:00 UTC").unwrap();
    let md = std::fs::read_to_string(d.join("tiny-table.md")).unwrap();
    assert!(md.contains("# Tiny table"));
    assert!(md.contains("Test CPU, 2 cores") && md.contains("2026-01-01"));
    assert!(md.contains("| Dataset | paper fps † | fps † |"), "{md}");
    assert!(md.contains("| spx | 95.32 | 12.5 |"));
    assert!(md.contains("- a note"));
    let csv = std::fs::read_to_string(d.join("tiny-table.csv")).unwrap();
    assert_eq!(csv, "Dataset,paper fps,fps\nspx,95.32,12.5\n");
}

#[test]
fn reproduce_specs_cover_the_papers_tables() {
    let ids = tetbench::papers::ids();
    for want in [
        "ptint-table1",
        "ptint-table2",
        "ptint-fig8",
        "hapt-table1",
        "hapt-table2",
        "hapt-table3",
        "hapt-table4",
    ] {
        assert!(ids.contains(&want), "{want} missing");
    }
    let o = tetbench(&["reproduce", "--only", "nosuch", "--out", "/nonexistent/x"]);
    assert_one_line_exit2(&o, &["nosuch"]);
}

/// The worked example of docs/adding-a-renderer.md runs through `bench` like any renderer.
#[test]
fn the_added_variant_runs_through_bench() {
    let d = tmpdir("slab16");
    let cfg = d.join("slab16.toml");
    std::fs::write(
        &cfg,
        r#"
datasets = ["cc5:3000"]
renderers = [{ name = "cpu-pt-slab16" }, { name = "cpu-pt", sorts = ["mpvonc"] }]
sizes = ["32x32"]
repeats = 1
warmup = 0
[views]
named = ["30,20"]
"#,
    )
    .unwrap();
    let out = d.join("out");
    let o = tetbench(&[
        "bench",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Csv { head, rows } = Csv::read(&out.join("results.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let slab = rows
        .iter()
        .find(|r| r[col("renderer")] == "cpu-pt-slab16")
        .expect("a cpu-pt-slab16 row");
    assert_eq!(slab[col("sort")], "bucket:16");
    let rmse: f64 = slab[col("rmse")].parse().unwrap();
    assert!(rmse.is_finite() && rmse < 0.05, "rmse {rmse}");
    assert!(slab[col("tets_per_s")].parse::<f64>().unwrap() > 0.0);
    std::fs::remove_dir_all(&d).ok();
}

/// `interleave = true`: per view, the warm-up round and then the measured rounds render each
/// variant once in turn (A B C A B C …), as `order.csv` records; an optional variant that
/// cannot run is a failed row and takes no turns; the rows are the same set as without it.
#[test]
fn interleave_measures_variants_in_rounds() {
    let d = tmpdir("interleave");
    let cfg = d.join("i.toml");
    std::fs::write(
        &cfg,
        r#"
datasets = ["spx:800"]
renderers = [
  { name = "cpu-pt", integrators = ["partial"] },
  { name = "vtk-pt", optional = true },
  { name = "raycast", integrators = ["partial"] },
]
sizes = ["16x16"]
repeats = 3
warmup = 1
error = false
interleave = true
[views]
named = ["0,0", "90,30"]
"#,
    )
    .unwrap();
    let out = d.join("out");
    let o = bench_without_vtk(&cfg, &out);
    // (The exit status says that rows failed: vtk-pt's, below.)
    let Csv { head, rows } = Csv::read(&out.join("results.csv"));
    assert_eq!(rows.len(), 6, "{}", String::from_utf8_lossy(&o.stderr));
    let col = |n: &str| head.iter().position(|h| h == n).unwrap();
    for r in &rows {
        let failed = r[col("renderer")] == "vtk-pt";
        assert_eq!(r[col("total_ms")] == "NaN", failed, "{r:?}");
    }
    let Csv {
        head: ohead,
        rows: order,
    } = Csv::read(&out.join("order.csv"));
    assert_eq!(
        ohead,
        [
            "dataset",
            "variant",
            "projection",
            "size",
            "view",
            "warmup",
            "round"
        ]
    );
    let got: Vec<(String, String, String, String)> = order
        .iter()
        .map(|r| (r[4].clone(), r[1].clone(), r[5].clone(), r[6].clone()))
        .collect();
    let mut want = Vec::new();
    for view in ["named:0", "named:1"] {
        for (warm, round) in [(true, 0), (false, 0), (false, 1), (false, 2)] {
            for v in ["cpu-pt/centroid/partial", "raycast/partial"] {
                want.push((
                    view.to_string(),
                    v.to_string(),
                    warm.to_string(),
                    round.to_string(),
                ));
            }
        }
    }
    assert_eq!(got, want);
}

/// A variant's bytes per tet are its own: the same whichever variant is prepared first. The
/// process-wide Ψ table (1 MiB, ~500 B a tet here) was counted in the first variant that built
/// it; it is now kept out of every variant and reported apart in `meta.txt`.
#[test]
fn bytes_per_tet_do_not_depend_on_the_order_of_the_variants() {
    let d = tmpdir("order-bytes");
    let cpu = r#"{ name = "cpu-pt", integrators = ["partial"] }"#;
    let ray = r#"{ name = "raycast", integrators = ["partial"] }"#;
    let mut got = Vec::new();
    for (tag, list) in [("a", [cpu, ray]), ("b", [ray, cpu])] {
        let cfg = d.join(format!("{tag}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "datasets = [\"spx:20000\"]\nrenderers = [{}]\nsizes = [\"16x16\"]\nrepeats = 1\n\
                 warmup = 0\nerror = false\n[views]\nnamed = [\"0,0\"]\n",
                list.join(", ")
            ),
        )
        .unwrap();
        let out = d.join(tag);
        let o = bench_without_vtk(&cfg, &out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let Csv { head, rows } = Csv::read(&out.join("results.csv"));
        let col = |n: &str| head.iter().position(|h| h == n).unwrap();
        let mut bytes: Vec<(String, f64)> = rows
            .iter()
            .map(|r| {
                let b = r[col("cpu_bytes_per_tet")].parse::<f64>().unwrap();
                (r[col("renderer")].clone(), b)
            })
            .collect();
        bytes.sort_by(|x, y| x.0.cmp(&y.0));
        let meta = std::fs::read_to_string(out.join("meta.txt")).unwrap();
        assert!(
            meta.lines()
                .any(|l| l.starts_with("shared_fixed_bytes: 1048576 ")),
            "{meta}"
        );
        got.push(bytes);
    }
    assert_eq!(got[0].len(), 2);
    for (a, b) in got[0].iter().zip(&got[1]) {
        assert_eq!(a.0, b.0);
        // A shared table charged to the first would be ~50 B/tet here (1 MiB over 20K tets);
        // the few KB by which two runs' peaks differ with the threads' scheduling stay well
        // under one.
        assert!(
            (a.1 - b.1).abs() < 1.0,
            "{}: {} B/tet first, {} B/tet second",
            a.0,
            a.1,
            b.1
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}
