//! Sweeps whose rows must stay exactly the experiment's: no two rows (or saved images) share a
//! key, the lock holds against racing runs and merges, a merge checks the keys it joins, and
//! the reference cache is used only where an entry is what it claims to be.

use std::path::{Path, PathBuf};

use crate::test_util::{command, err_lines, one_line_error, s, tetbench, tmpdir, write_exp, Csv};

const SMALL: &str = r#"
name = "small"
datasets = ["spx:1500", { mesh = "torus", tets = 2000, label = "torus-2k" }]
renderers = [{ name = "raycast", integrators = ["partial"] }]
sizes = ["24x24"]
repeats = 1
warmup = 0
[views]
named = ["0,0", "90,30"]
"#;

/// (dataset, view_id) -> rmse of a results.csv.
fn rmse_by_cell(csv: &Path) -> Vec<(String, String, String)> {
    let t = Csv::read(csv);
    let col = |n: &str| t.col(n);
    let mut v: Vec<(String, String, String)> = t
        .rows
        .iter()
        .map(|x| {
            (
                x[col("dataset")].to_string(),
                x[col("view_id")].to_string(),
                x[col("rmse")].to_string(),
            )
        })
        .collect();
    v.sort();
    v
}

/// Two entries that would give rows one key (a dataset listed twice, two meshes with one
/// label, one size spelled twice, a projection repeated), two labels that would save their
/// images in one directory, and an empty label are refused up front, naming both entries.
#[test]
fn duplicate_row_keys_are_refused_up_front() {
    let d = tmpdir("dups");
    let base = |datasets: &str, sizes: &str, projection: &str| {
        format!(
            "datasets = {datasets}\nrenderers = [{{ name = \"raycast\" }}]\nsizes = {sizes}\nprojection = {projection}\nrepeats = 1\nwarmup = 0\n"
        )
    };
    let cases = [
        (
            base(r#"["spx:1500", "spx:1500"]"#, r#"["16x16"]"#, r#""ortho""#),
            vec!["datasets[0]", "datasets[1]", "spx:1500"],
        ),
        (
            base(
                r#"[{ mesh = "spx", tets = 1500, label = "m" }, { mesh = "torus", tets = 2000, label = "m" }]"#,
                r#"["16x16"]"#,
                r#""ortho""#,
            ),
            vec!["datasets[0]", "datasets[1]", "'m'"],
        ),
        (
            base(r#"["spx:1500"]"#, r#"["16x16", "16X16"]"#, r#""ortho""#),
            vec!["sizes[0]", "sizes[1]", "16x16", "16X16"],
        ),
        (
            base(r#"["spx:1500"]"#, r#"["16x16"]"#, r#"["ortho", "ortho"]"#),
            vec!["projection[0]", "projection[1]"],
        ),
        (
            base(
                r#"[{ mesh = "spx", tets = 1500, label = "x/y" }, { mesh = "torus", tets = 2000, label = "x_y" }]"#,
                r#"["16x16"]"#,
                r#""ortho""#,
            ),
            vec!["datasets[0]", "datasets[1]", "x/y", "x_y"],
        ),
        (
            base(
                r#"[{ mesh = "spx", tets = 1500, label = "" }]"#,
                r#"["16x16"]"#,
                r#""ortho""#,
            ),
            vec!["datasets[0]", "empty"],
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let exp = write_exp(&d, &format!("dup{i}.toml"), text);
        let out = d.join(format!("out{i}"));
        let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
        one_line_error(&o, want);
        assert!(!out.join("results.csv").exists(), "case {i}");
    }
    // The same renderer listed twice with another reference gives one label for two variants.
    let exp = write_exp(
        &d,
        "dupvar.toml",
        "datasets = [\"spx:1500\"]\nrenderers = [{ name = \"raycast\" }, { name = \"raycast\", reference = \"cpu-pt\" }]\nsizes = [\"16x16\"]\n",
    );
    one_line_error(
        &tetbench(&["bench", s(&exp), "--out", s(&d.join("ov"))]),
        &["renderers[1]", "renderers[0]", "raycast/"],
    );
    // A label of dots saves its images inside images/, not above it.
    let exp = write_exp(
        &d,
        "dots.toml",
        "datasets = [{ mesh = \"spx\", tets = 1500, label = \"..\" }]\nrenderers = [{ name = \"raycast\" }]\nsizes = [\"16x16\"]\nrepeats = 1\nwarmup = 0\nsave_images = true\n",
    );
    let out = d.join("dots");
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let top: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png") || n.ends_with(".exr"))
        // The image figure of the whole run belongs there.
        .filter(|n| !n.starts_with("results-images."))
        .collect();
    assert!(
        top.is_empty(),
        "images written into the output directory: {top:?}"
    );
    assert!(out.join("images/__").is_dir());
    let _ = std::fs::remove_dir_all(&d);
}

/// A lock file whose pid belongs to an unrelated live process does not block a run; a run
/// that holds the lock does, and so does it for `merge`.
#[test]
fn the_lock_is_held_by_runs_not_by_pids() {
    let d = tmpdir("lock");
    let exp = write_exp(&d, "small.toml", SMALL);
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    // pid 1 runs, but it is no tetbench run holding this directory.
    std::fs::write(out.join(".lock"), "1\n").unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    assert!(!out.join(".lock").exists());
    // Held by this process: bench and merge into it are refused, nothing is replaced.
    let shard = d.join("shard");
    let o = tetbench(&["bench", s(&exp), "--out", s(&shard), "--shard", "0/1"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let before = std::fs::read(out.join("results.csv")).unwrap();
    let lock = tetbench::sweep::Lock::take(&out).unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--force"]);
    one_line_error(
        &o,
        &["another tetbench run", &std::process::id().to_string()],
    );
    let o = tetbench(&["merge", "--out", s(&out), "--force", s(&shard)]);
    one_line_error(&o, &["another tetbench run"]);
    assert_eq!(std::fs::read(out.join("results.csv")).unwrap(), before);
    drop(lock);
    let _ = std::fs::remove_dir_all(&d);
}

/// `merge` refuses results already in `--out` without `--force`, an `--out` that is one of
/// its shards, a shard whose rows are not the ones it was given (a key edited, the count
/// unchanged), shards that disagree on the sweep's size, and names a bad `shard:` line's file.
#[test]
fn merge_checks_keys_and_never_overwrites_silently() {
    let d = tmpdir("merge");
    let exp = write_exp(&d, "small.toml", SMALL);
    let shards: Vec<PathBuf> = (0..2).map(|i| d.join(format!("s{i}"))).collect();
    for (i, sd) in shards.iter().enumerate() {
        let o = tetbench(&[
            "bench",
            s(&exp),
            "--out",
            s(sd),
            "--shard",
            &format!("{i}/2"),
        ]);
        assert!(o.status.success(), "{}", err_lines(&o));
    }
    let merged = d.join("merged");
    let args = |out: &Path, force: bool| {
        let mut a: Vec<String> = vec!["merge".into(), "--out".into(), s(out).into()];
        if force {
            a.push("--force".into());
        }
        a.extend(shards.iter().map(|p| s(p).to_string()));
        a
    };
    let run = |a: Vec<String>| tetbench(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(args(&merged, false));
    assert!(o.status.success(), "{}", err_lines(&o));
    let o = run(args(&merged, false));
    one_line_error(&o, &[s(&merged), "--force"]);
    let o = run(args(&merged, true));
    assert!(o.status.success(), "{}", err_lines(&o));
    // Into one of its own shards.
    let shard0 = std::fs::read(shards[0].join("results.csv")).unwrap();
    let o = run(args(&shards[0], true));
    one_line_error(&o, &["--out", s(&shards[0]), "shard"]);
    assert_eq!(
        std::fs::read(shards[0].join("results.csv")).unwrap(),
        shard0
    );

    // One row's view edited to one the sweep does not have, the row count unchanged.
    let csv = shards[1].join("results.csv");
    let text = String::from_utf8(std::fs::read(&csv).unwrap()).unwrap();
    let forged = text.replacen(",named:", ",named:9", 1);
    assert_ne!(forged, text);
    std::fs::write(&csv, &forged).unwrap();
    let o = run(args(&d.join("m2"), false));
    one_line_error(&o, &[s(&shards[1])]);
    std::fs::write(&csv, &text).unwrap();

    // Shards that disagree on the sweep's size.
    let sf = shards[1].join("shard.txt");
    let info = std::fs::read_to_string(&sf).unwrap();
    let total: String = info
        .lines()
        .find_map(|l| l.strip_prefix("rows_total: "))
        .unwrap()
        .into();
    std::fs::write(
        &sf,
        info.replace(
            &format!("rows_total: {total}"),
            &format!("rows_total: {}", total.parse::<usize>().unwrap() + 1),
        ),
    )
    .unwrap();
    let o = run(args(&d.join("m3"), false));
    one_line_error(&o, &[s(&shards[1]), "rows_total"]);
    // A bad `shard:` line: the file is named, not the --shard flag.
    std::fs::write(&sf, info.replace("shard: 1/2", "shard: 5/2")).unwrap();
    let o = run(args(&d.join("m4"), false));
    let e = err_lines(&o);
    one_line_error(&o, &[s(&sf), "shard: '5/2'"]);
    assert!(!e.contains("--shard"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

/// Cache entries are used only when they match their checksum: two swapped entries, an
/// all-black image and an all-NaN image of the right size are rendered again, and the errors
/// stay those of the real reference.
#[test]
fn cache_entries_that_lie_are_rendered_again() {
    let d = tmpdir("cache");
    let exp = write_exp(&d, "small.toml", SMALL);
    let out = d.join("out");
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let truth = rmse_by_cell(&out.join("results.csv"));
    let mut entries: Vec<PathBuf> = std::fs::read_dir(out.join(".cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    entries.sort();
    assert_eq!(entries.len(), 4);
    let rerun = |want_rendered: usize| {
        let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--force"]);
        assert!(o.status.success(), "{}", err_lines(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            text.contains(&format!("reference_images: {want_rendered} rendered")),
            "{text}"
        );
        assert_eq!(rmse_by_cell(&out.join("results.csv")), truth);
    };
    let (a, b) = (
        std::fs::read(&entries[0]).unwrap(),
        std::fs::read(&entries[1]).unwrap(),
    );
    std::fs::write(&entries[0], &b).unwrap();
    std::fs::write(&entries[1], &a).unwrap();
    rerun(2);
    let black = algorithms::image::Image::new(24, 24);
    black.write(&entries[2]).unwrap();
    let mut nan = algorithms::image::Image::new(24, 24);
    nan.pixels.iter_mut().for_each(|p| *p = [f32::NAN; 4]);
    nan.write(&entries[3]).unwrap();
    rerun(2);
    rerun(0);
    let _ = std::fs::remove_dir_all(&d);
}

/// A shared cache directory: another machine's temporary file is left alone while it may be
/// written (also one named without its machine, whose pid means nothing here); this
/// machine's, whose writer is gone, is removed.
#[test]
fn temporary_files_of_other_machines_are_left_alone() {
    let d = tmpdir("tmp");
    let exp = d.join("small.toml");
    let cache = d.join("shared-cache");
    std::fs::create_dir_all(&cache).unwrap();
    std::fs::write(&exp, format!("cache_dir = \"{}\"\n{SMALL}", s(&cache))).unwrap();
    let host = algorithms::io::files::host_name();
    let foreign = cache.join(".ref-a.exr.tmp4242@another-node");
    let mine_dead = cache.join(format!(".ref-b.exr.tmp999999999@{host}"));
    let unnamed = cache.join(".ref-c.exr.tmp999999998");
    std::fs::write(&foreign, b"half").unwrap();
    std::fs::write(&mine_dead, b"half").unwrap();
    std::fs::write(&unnamed, b"half").unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&d.join("out")), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    assert!(
        foreign.exists(),
        "another machine's temporary file was removed"
    );
    assert!(
        unnamed.exists(),
        "a temporary file of an unknown machine was removed"
    );
    assert!(!mine_dead.exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// A yardstick that cannot be made leaves its rows without an error, each with a note; the
/// run says so and ends with exit 3.
#[test]
fn rows_without_their_error_end_the_run_with_exit_3() {
    let d = tmpdir("noerr");
    let exp = write_exp(
        &d,
        "ys.toml",
        "datasets = [\"spx:1500\"]\nrenderers = [{ name = \"raycast\", reference = \"volume-raycast\" }]\nsizes = [\"16x16\"]\nrepeats = 1\nwarmup = 0\n",
    );
    let o = tetbench(&["bench", s(&exp), "--out", s(&d.join("out")), "--no-plots"]);
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    assert!(
        err_lines(&o).contains("1 of 1 rows have no error measurement"),
        "{}",
        err_lines(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `meta.txt` is replaced whole or not at all: a write that fails (here, past a file-size
/// limit, as on a full disk) leaves the previous one as it was.
#[test]
fn meta_txt_is_never_left_half_written() {
    use std::os::unix::process::CommandExt;
    let d = tmpdir("meta");
    let exp = write_exp(&d, "small.toml", SMALL);
    let out = d.join("out");
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert!(o.status.success(), "{}", err_lines(&o));
    let meta = std::fs::read(out.join("meta.txt")).unwrap();
    assert!(meta.len() > 100);
    let mut c = command();
    c.args(["bench", s(&exp), "--out", s(&out), "--no-plots", "--resume"]);
    // SAFETY: signal and setrlimit only, between fork and exec (async-signal-safe).
    unsafe {
        c.pre_exec(|| {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let l = libc::rlimit {
                rlim_cur: 64,
                rlim_max: 64,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &l) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let o = c.output().unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(out.join("meta.txt")).unwrap(), meta);
    let _ = std::fs::remove_dir_all(&d);
}

/// `reproduce --merge` refuses shards measured with the other `--quick` setting, naming it.
#[test]
fn reproduce_merge_refuses_shards_of_the_other_quick_setting() {
    let d = tmpdir("quick");
    let shard = d.join("shard");
    let o = tetbench(&[
        "reproduce",
        "--quick",
        "--only",
        "bcc_pt",
        "--shard",
        "0/1",
        "--out",
        s(&shard),
    ]);
    assert!(matches!(o.status.code(), Some(0 | 3)), "{}", err_lines(&o));
    let o = tetbench(&[
        "reproduce",
        "--only",
        "bcc_pt",
        "--merge",
        s(&shard),
        "--out",
        s(&d.join("m")),
    ]);
    one_line_error(&o, &[s(&shard), "with --quick"]);
    let o = tetbench(&[
        "reproduce",
        "--quick",
        "--only",
        "bcc_pt",
        "--merge",
        s(&shard),
        "--out",
        s(&d.join("m")),
    ]);
    assert!(matches!(o.status.code(), Some(0 | 3)), "{}", err_lines(&o));
    let _ = std::fs::remove_dir_all(&d);
}
