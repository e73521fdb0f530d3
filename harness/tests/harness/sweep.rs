//! Sweeps that outgrow one run: shards merged equal the unsharded run, a killed run
//! resumed ends with the same rows and remeasures none, a panicking renderer costs one row,
//! finished results are never destroyed silently, bad shard input gets one line.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::test_util::{command, err_lines, s, tetbench, tmpdir, write_exp, Csv};

const TINY: &str = r#"
name = "tiny-sweep"
datasets = ["spx:1500", { mesh = "torus", tets = 2000, label = "torus-2k" }]
renderers = [{ name = "raycast", integrators = ["partial", "average"] }, { name = "reference" }]
sizes = ["24x24", "40x40"]
repeats = 1
warmup = 0
[views]
named = ["0,0", "90,30", "45,10"]
"#;

/// key -> (rmse, whole record) of a results.csv.
fn rows(p: &Path) -> BTreeMap<String, (f64, Vec<String>)> {
    let t = Csv::read(p);
    let rmse = t.col("rmse");
    t.by_key()
        .into_iter()
        .map(|(key, rec)| (key, (rec[rmse].parse().unwrap_or(f64::NAN), rec)))
        .collect()
}

fn same_rows(a: &Path, b: &Path) {
    let (ra, rb) = (rows(a), rows(b));
    assert_eq!(
        ra.keys().collect::<Vec<_>>(),
        rb.keys().collect::<Vec<_>>(),
        "{} vs {}",
        a.display(),
        b.display()
    );
    for (k, (ea, _)) in &ra {
        let eb = rb[k].0;
        assert!(
            (ea - eb).abs() <= 1e-9 || (ea.is_nan() && eb.is_nan()),
            "{k}: rmse {ea} vs {eb}"
        );
    }
}

#[test]
fn shards_merged_equal_the_unsharded_run() {
    let d = tmpdir("shards");
    let exp = write_exp(&d, "exp.toml", TINY);
    let full = d.join("full");
    let o = tetbench(&["bench", s(&exp), "--out", s(&full), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let mut dirs = Vec::new();
    let mut counts = Vec::new();
    for i in 0..3 {
        let sd = d.join(format!("s{i}"));
        let o = tetbench(&[
            "bench",
            s(&exp),
            "--out",
            s(&sd),
            "--shard",
            &format!("{i}/3"),
        ]);
        assert!(o.status.success(), "{}", err_lines(&o));
        counts.push(rows(&sd.join("results.csv")).len());
        dirs.push(sd);
    }
    // 2 datasets x 3 variants x 2 sizes x 3 views, spread over the three shards.
    assert_eq!(counts.iter().sum::<usize>(), 36, "{counts:?}");
    assert!(counts.iter().all(|&c| c > 0), "{counts:?}");
    let merged = d.join("merged");
    let mut args = vec!["merge", "--out", s(&merged)];
    args.extend(dirs.iter().map(|p| s(p)));
    let o = tetbench(&args);
    assert!(o.status.success(), "{}", err_lines(&o));
    same_rows(&full.join("results.csv"), &merged.join("results.csv"));
    assert!(merged.join("speed_vs_error.svg").exists());
    // The merged sweep's figure (from the cells its shards kept) and its report.
    for f in ["results-images.png", "index.html"] {
        assert!(merged.join(f).is_file(), "{f} missing after merge");
    }

    // A missing shard, a doubled one, and a shard of another experiment file are refused.
    let o = tetbench(&["merge", "--out", s(&d.join("m2")), s(&dirs[0]), s(&dirs[1])]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("2/3 is missing"),
        "{}",
        err_lines(&o)
    );
    let o = tetbench(&[
        "merge",
        "--out",
        s(&d.join("m3")),
        s(&dirs[0]),
        s(&dirs[1]),
        s(&dirs[1]),
    ]);
    assert!(err_lines(&o).contains("given twice"), "{}", err_lines(&o));
    let other = write_exp(&d, "exp.toml", &TINY.replace("tiny-sweep", "tiny-other"));
    let odd = d.join("odd");
    let o = tetbench(&["bench", s(&other), "--out", s(&odd), "--shard", "2/3"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let o = tetbench(&[
        "merge",
        "--out",
        s(&d.join("m4")),
        s(&dirs[0]),
        s(&dirs[1]),
        s(&odd),
    ]);
    let e = err_lines(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains(s(&odd)) && e.contains("experiment file") && e.lines().count() == 1,
        "{e}"
    );
    // --resume against another experiment's results is refused.
    let o = tetbench(&["bench", s(&other), "--out", s(&full), "--resume"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("another experiment"),
        "{}",
        err_lines(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_shards_get_one_line() {
    let d = tmpdir("badshard");
    let exp = write_exp(&d, "exp.toml", TINY);
    for bad in ["3/3", "0/0", "a/b"] {
        let o = tetbench(&["bench", s(&exp), "--out", s(&d.join("x")), "--shard", bad]);
        let e = err_lines(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {e}");
        assert!(e.contains(bad) && e.lines().count() == 1, "{bad}: {e}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_panicking_renderer_costs_one_row() {
    let d = tmpdir("panic");
    let exp = write_exp(
        &d,
        "exp.toml",
        &TINY
            .replace(
                r#", { mesh = "torus", tets = 2000, label = "torus-2k" }"#,
                "",
            )
            .replace(r#"["24x24", "40x40"]"#, r#"["24x24"]"#),
    );
    let out = d.join("out");
    let o = command()
        .args(["bench", s(&exp), "--out", s(&out), "--no-plots"])
        .env("TETBENCH_TEST_PANIC", "raycast/average@named:1")
        .output()
        .unwrap();
    // Exit 3: the sweep finished, some rows failed.
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    assert!(
        err_lines(&o).contains("1 of 9 rows failed"),
        "{}",
        err_lines(&o)
    );
    let r = rows(&out.join("results.csv"));
    assert_eq!(r.len(), 9);
    let head = Csv::read(&out.join("results.csv"));
    let (note, total) = (head.col("note"), head.col("total_ms"));
    let failed: Vec<&Vec<String>> = r
        .values()
        .map(|x| &x.1)
        .filter(|x| x[total] == "NaN")
        .collect();
    assert_eq!(failed.len(), 1);
    assert!(failed[0][note].contains("panicked: test-only renderer panic"));
    assert!(r
        .values()
        .filter(|x| x.1[total] != "NaN")
        .all(|x| x.0.is_finite()));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn killed_run_resumes_to_the_same_rows_remeasuring_none() {
    let d = tmpdir("resume");
    // Bigger images so that the run is still going when it is killed.
    let exp = write_exp(
        &d,
        "exp.toml",
        &TINY.replace(r#"["24x24", "40x40"]"#, r#"["64x64", "96x96"]"#),
    );
    let full = d.join("full");
    let o = tetbench(&["bench", s(&exp), "--out", s(&full), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));

    let out = d.join("out");
    let mut child = command()
        .args(["bench", s(&exp), "--out", s(&out), "--no-plots"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let csv = out.join("results.csv");
    let t0 = Instant::now();
    loop {
        let n = std::fs::read_to_string(&csv)
            .map(|t| t.lines().count())
            .unwrap_or(0);
        if n >= 6 || t0.elapsed() > Duration::from_secs(300) {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // A torn last line, as a kill in the middle of a write leaves it.
    let mut text = std::fs::read_to_string(&csv).unwrap();
    let before: Vec<String> = text.lines().skip(1).map(String::from).collect();
    assert!(before.len() < 36, "the run finished before it was killed");
    text.push_str("spx:1500,1480,462,raycast");
    std::fs::write(&csv, &text).unwrap();

    // Into the same directory without --resume: refused, nothing destroyed.
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("--resume") && err_lines(&o).contains("--force"),
        "{}",
        err_lines(&o)
    );
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), text);

    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--resume"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    assert!(
        err_lines(&o).contains("torn last line"),
        "{}",
        err_lines(&o)
    );
    same_rows(&full.join("results.csv"), &csv);
    // The finished rows are the same lines, byte for byte: none was measured again.
    let after = std::fs::read_to_string(&csv).unwrap();
    let after: Vec<&str> = after.lines().skip(1).collect();
    assert_eq!(&after[..before.len()], &before[..]);
    // Resuming a finished run measures nothing.
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--resume"]);
    assert!(o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("reference_images: 0 rendered, 0 from cache")
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_second_run_into_one_out_is_refused_by_the_lock() {
    let d = tmpdir("lock");
    let exp = write_exp(&d, "exp.toml", TINY);
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    // A live run (this test, holding the lock) keeps others out.
    let lock = tetbench::sweep::Lock::take(&out).unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("another tetbench run"),
        "{}",
        err_lines(&o)
    );
    drop(lock);
    // A lock file left by a run that is gone, and its temporary files, are cleaned up.
    std::fs::write(out.join(".lock"), "999999999\n").unwrap();
    std::fs::create_dir_all(out.join(".cache")).unwrap();
    let tmp = out.join(format!(
        ".cache/.ref-x.exr.tmp999999999@{}",
        algorithms::io::files::host_name()
    ));
    std::fs::write(&tmp, b"half").unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--force"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    assert!(!out.join(".lock").exists());
    assert!(!tmp.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn plot_on_an_empty_or_header_only_csv_says_nothing_to_plot() {
    let d = tmpdir("emptyplot");
    std::fs::write(d.join("results.csv"), b"").unwrap();
    let o = tetbench(&["plot", s(&d)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("nothing to plot"),
        "{}",
        err_lines(&o)
    );
    std::fs::write(d.join("results.csv"), b"dataset,tets\n").unwrap();
    let o = tetbench(&["plot", s(&d)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err_lines(&o).contains("nothing to plot"),
        "{}",
        err_lines(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `reproduce --shard I/N` on every shard, then `reproduce --merge`, gives the unsharded run's
/// rows and table; a renderer that fails in every view of a table is a "failed" row of that
/// table with the message, listed in its notes, and the exit status is 3 — sharded or not.
#[test]
fn reproduce_shards_merge_to_the_unsharded_table_with_failed_rows_shown() {
    let d = tmpdir("reproduce");
    let run = |args: &[&str]| {
        command()
            .args(["reproduce", "--quick", "--only", "ptint-fig8"])
            .args(args)
            .env("TETBENCH_TEST_PANIC", "raycast/partial@*")
            .output()
            .unwrap()
    };
    let (whole, s0, s1, merged) = (
        d.join("whole"),
        d.join("s0"),
        d.join("s1"),
        d.join("merged"),
    );
    let o = run(&["--out", s(&whole)]);
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    for (i, dir) in [(0, &s0), (1, &s1)] {
        let shard = format!("{i}/2");
        let o = run(&["--shard", &shard, "--out", s(dir)]);
        // Shard 0 or 1 measures the raycast rows (and fails them): exit 3 there only.
        assert!(matches!(o.status.code(), Some(0 | 3)), "{}", err_lines(&o));
        assert!(
            !dir.join("ptint-fig8.md").exists(),
            "a shard writes raw rows, not tables"
        );
    }
    let o = run(&["--merge", s(&s0), s(&s1), "--out", s(&merged)]);
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    let raw = |dir: &Path| dir.join("raw/ptint-fig8/results.csv");
    same_rows(&raw(&whole), &raw(&merged));
    let table = |dir: &Path| std::fs::read_to_string(dir.join("ptint-fig8.md")).unwrap();
    let (tw, tm) = (table(&whole), table(&merged));
    for t in [&tw, &tm] {
        let failed: Vec<&str> = t
            .lines()
            .filter(|l| l.contains("| raycast/partial |"))
            .collect();
        assert!(!failed.is_empty(), "no raycast row:\n{t}");
        assert!(
            failed
                .iter()
                .all(|l| l.contains("| failed: ")
                    && l.contains("panicked: test-only renderer panic")),
            "{failed:?}"
        );
        assert!(t.contains("**Failed measurements**"), "{t}");
        assert!(
            t.contains("raycast/partial: 6 of 6 measurements failed"),
            "{t}"
        );
    }
    // The same rows in the same order; only the measured times differ.
    let cells = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.starts_with("| ") && !l.starts_with("| viewport"))
            .map(|l| l.split(" | ").take(3).collect::<Vec<_>>().join("|"))
            .collect()
    };
    assert_eq!(cells(&tw), cells(&tm));
    let _ = std::fs::remove_dir_all(&d);
}

/// `reproduce --slurm N` prints an N-task array and a merge job that depends on it, as valid
/// shell; a shard whose only trouble is failed rows (exit 3) does not stop the merge.
#[test]
fn reproduce_slurm_prints_an_array_and_its_merge() {
    let o = tetbench(&[
        "reproduce",
        "--slurm",
        "3",
        "--quick",
        "--out",
        "/shared/out",
    ]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("--array=0-2"), "{text}");
    assert!(text.contains("--shard $SLURM_ARRAY_TASK_ID/3"), "{text}");
    assert!(text.contains("--dependency=afterok:$array"), "{text}");
    assert!(
        text.contains("--merge /shared/out/shard-0 /shared/out/shard-1 /shared/out/shard-2"),
        "{text}"
    );
    assert_eq!(text.matches("[ $rc -eq 3 ] && rc=0").count(), 2, "{text}");
    let mut sh = std::process::Command::new("bash")
        .arg("-n")
        .stdin(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    sh.stdin.take().unwrap().write_all(text.as_bytes()).unwrap();
    assert!(sh.wait().unwrap().success(), "not valid shell:\n{text}");
    let o = tetbench(&["reproduce", "--slurm", "0"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(err_lines(&o).lines().count(), 1, "{}", err_lines(&o));
}
