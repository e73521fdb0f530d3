//! Peers end to end (docs/peers.md): the example peers of `peers/examples/peers.toml` in `list`,
//! `render`, `bench`, PTINT Table 1 and `peer check`; the page's plain-Python peer as written;
//! experiment files' own peers only with `--allow-peers`; and supervision — peers that crash,
//! hang, print garbage or an endless line, send wrong-size or NaN images, die mid-frame or stop
//! reading cost one failed row each, the run exits 3 within their timeouts, and no peer process
//! or private directory outlives tetbench (Ctrl-C, SIGTERM and SIGKILL included). The same
//! supervision serves VTK's helper: a stand-in for `TETBENCH_VTK_PYTHON` that never replies,
//! exits or writes an endless line gives one line or a failed row, never a hang, a SIGPIPE death
//! or an abort.
//!
//! Needs `g++` (the C++ examples are built here with `make`) and a `python3` with numpy (the
//! first on PATH, else `/usr/bin/python3`, whose directory is then put first on PATH).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use crate::test_util::{self, Csv};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn examples() -> PathBuf {
    root().join("peers/examples/peers.toml")
}

fn fault_peer() -> PathBuf {
    root().join("harness/tests/harness/fault_peer.py")
}

/// A PATH on which `python3` has numpy (the example peers run `python3`).
fn path_with_numpy() -> String {
    static PATH: OnceLock<String> = OnceLock::new();
    PATH.get_or_init(|| {
        let path = std::env::var("PATH").unwrap_or_default();
        let has_numpy = |py: &str| {
            Command::new(py)
                .args(["-c", "import numpy"])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success())
        };
        if has_numpy("python3") {
            return path;
        }
        assert!(
            has_numpy("/usr/bin/python3"),
            "the example peers need a python3 with numpy (Debian: apt-get install python3-numpy)"
        );
        format!("/usr/bin:{path}")
    })
    .clone()
}

/// Builds the C++ examples once (`make -C peers/examples/cpp`).
fn build_cpp_examples() {
    static BUILT: OnceLock<()> = OnceLock::new();
    BUILT.get_or_init(|| {
        let o = Command::new("make")
            .arg("-C")
            .arg(root().join("peers/examples/cpp"))
            .output()
            .expect("run make (the C++ examples need make and g++)");
        assert!(
            o.status.success(),
            "building the C++ examples failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    });
}

/// A private temporary directory, also used as the peers' TMPDIR: removed when the test
/// passes, kept (for a look) when it fails.
struct TmpDir(PathBuf);

impl std::ops::Deref for TmpDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A fresh directory with a `tmp/` for the peers' private directories.
fn tmpdir(tag: &str) -> TmpDir {
    let d = test_util::tmpdir(&format!("peers-{tag}"));
    std::fs::create_dir_all(d.join("tmp")).unwrap();
    TmpDir(d)
}

fn tetbench(dir: &Path) -> Command {
    let mut c = test_util::command();
    c.env("PATH", path_with_numpy())
        .env("TMPDIR", dir.join("tmp"))
        .env_remove("TETBENCH_PEERS")
        .current_dir(dir);
    c
}

fn run(c: &mut Command) -> Output {
    c.output().expect("run tetbench")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Processes whose command line mentions `tag` (a peer, or a peer's child).
fn survivors(tag: &str) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let name = e.file_name();
        if name.to_string_lossy().parse::<u32>().is_err() {
            continue;
        }
        if let Ok(cmd) = std::fs::read(e.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            // Zombies have an empty command line; a live process that names the tag survived.
            if cmd.contains(tag) {
                out.push(format!("{}: {cmd}", name.to_string_lossy()));
            }
        }
    }
    out
}

/// Waits (up to 5 s) until no process mentions `tag`, else fails naming them.
fn assert_no_survivors(tag: &str) {
    let t0 = Instant::now();
    loop {
        let s = survivors(tag);
        if s.is_empty() {
            return;
        }
        assert!(t0.elapsed() < Duration::from_secs(5), "left behind: {s:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The private directories of peers in `dir/tmp`.
fn peer_dirs(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir.join("tmp"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("tetbench-peer-") || n.starts_with("tetbench-vtk-"))
        .collect()
}

/// Runs `c` and kills it after `limit` (a hang fails the test instead of blocking it).
fn run_within(c: &mut Command, limit: Duration) -> Output {
    let mut child = c
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let t0 = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!("still running after {limit:?}; stderr: {}", text(&o.stderr));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn unique_tag(what: &str) -> String {
    format!(
        "tag-{what}-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos()
    )
}

// ---------------------------------------------------------------------------------------------
// The example peers

#[test]
fn example_peers_are_listed_render_and_get_bench_rows_and_ptint_table1_rows() {
    build_cpp_examples();
    let d = tmpdir("examples");
    let peers = examples();
    let peers = peers.to_str().unwrap();

    let o = run(tetbench(&d).args(["list", "--peers", peers]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let list = text(&o.stdout);
    for want in [
        "numpy-raycast",
        "cpp-pt",
        "peer of family pt",
        "peer of family raycasting",
        "runs: python3 python/numpy_raycast.py",
    ] {
        assert!(
            list.contains(want),
            "{want:?} not in tetbench list:\n{list}"
        );
    }

    // A real image of the scene: close to the reference, and not a constant.
    let reference = d.join("ref.exr");
    let o = run(tetbench(&d).args([
        "render",
        "spx:3000",
        "--renderer",
        "reference",
        "--view",
        "30,20",
        "--size",
        "64x48",
        "--out",
        reference.to_str().unwrap(),
    ]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    for name in ["numpy-raycast", "cpp-pt"] {
        for projection in ["ortho", "persp"] {
            let out = d.join(format!("{name}-{projection}.exr"));
            let o = run(tetbench(&d).args([
                "render",
                "spx:3000",
                "--peers",
                peers,
                "--renderer",
                name,
                "--view",
                "30,20",
                "--size",
                "64x48",
                "--projection",
                projection,
                "--out",
                out.to_str().unwrap(),
            ]));
            let err = text(&o.stderr);
            assert!(o.status.success(), "{name}: {err}");
            assert!(err.contains(&format!("peer '{name}' runs `")), "{err}");
            let stdout = text(&o.stdout);
            assert!(stdout.contains("non_finite_pixels: 0"), "{stdout}");
            let img = algorithms::image::Image::read(&out).unwrap();
            let alphas: Vec<f32> = img.pixels.iter().map(|p| p[3]).collect();
            let (lo, hi) = alphas
                .iter()
                .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(lo == 0.0 && hi > 0.5, "{name}: alpha {lo}..{hi}");
            let r = algorithms::image::Image::read(&reference).unwrap();
            if projection == "ortho" {
                let e = algorithms::metrics::compare(&img, &r).unwrap();
                assert!(e.rmse < 1e-2, "{name}: rmse {}", e.rmse);
            }
        }
    }

    // bench: rows with the peer's own draw_ms and the request's wall time; logs kept.
    let exp = d.join("exp.toml");
    std::fs::write(
        &exp,
        r#"
datasets = ["spx:2000"]
renderers = [{ name = "numpy-raycast", integrators = ["average", "partial"] }, { name = "cpp-pt" }]
sizes = ["32x32"]
views = { named = ["30,20", "120,-10"] }
repeats = 2
"#,
    )
    .unwrap();
    let out = d.join("bench");
    let o = run(tetbench(&d).args([
        "bench",
        exp.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
        "--peers",
        peers,
    ]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let table = Csv::read(&out.join("results.csv"));
    let col = |n: &str| table.col(n);
    let rows = &table.rows;
    assert_eq!(rows.len(), 6);
    for r in rows {
        let num = |n: &str| r[col(n)].parse::<f64>().unwrap();
        assert!(r[col("note")].is_empty(), "{r:?}");
        assert!(
            num("draw_ms") > 0.0 && num("wall_ms") >= num("total_ms"),
            "{r:?}"
        );
        assert!(num("rmse") < 1e-2, "{r:?}");
        // The peer's process group's peak RSS, per tet: a whole process, far above a heap count.
        assert!(num("cpu_bytes_per_tet") > 100.0, "{r:?}");
        assert!(r[col("device")].starts_with("cpu ("), "{r:?}");
    }
    for name in ["numpy-raycast", "cpp-pt"] {
        let log = out.join("peer-logs").join(format!("{name}.log"));
        assert!(log.is_file(), "{} missing", log.display());
    }
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));

    // PTINT Table 1 takes pt and raycasting peers (not `other` ones): its experiment's variants,
    // from a shard that measures almost nothing.
    let rq = d.join("rq");
    let o = run(tetbench(&d).args([
        "reproduce",
        "--quick",
        "--only",
        "ptint-table1",
        "--out",
        rq.to_str().unwrap(),
        "--shard",
        "999/1000",
        "--peers",
        peers,
    ]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let meta = std::fs::read_to_string(rq.join("raw/ptint-table1/meta.txt")).unwrap();
    let variants = meta.lines().find(|l| l.starts_with("variants:")).unwrap();
    for want in ["numpy-raycast/partial", "cpp-pt/partial"] {
        assert!(variants.contains(want), "{want} not in {variants}");
    }
    assert!(!variants.contains("null-"), "{variants}");
}

#[test]
fn example_peers_pass_the_conformance_check() {
    build_cpp_examples();
    let d = tmpdir("check");
    for name in ["cpp-pt", "numpy-raycast"] {
        let report = d.join(format!("{name}.md"));
        let o = run(tetbench(&d).args([
            "peer",
            "check",
            name,
            "--peers",
            examples().to_str().unwrap(),
            "--size",
            "48x48",
            "--out",
            report.to_str().unwrap(),
        ]));
        let out = text(&o.stdout);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{name}:\n{out}\n{}",
            text(&o.stderr)
        );
        assert!(out.contains("**PASS**"), "{out}");
        assert_eq!(std::fs::read_to_string(&report).unwrap(), out);
        // Both projections, both integrators, the family's hard cases, the non-square image.
        for want in [
            "| persp |",
            "| partial |",
            "| average |",
            "48×32",
            "hard-translated",
        ] {
            assert!(out.contains(want), "{want:?} not in the report:\n{out}");
        }
    }
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));
}

#[test]
fn the_conformance_check_fails_a_peer_that_misbehaves() {
    let d = tmpdir("check-bad");
    let tag = unique_tag("check");
    let o = run(tetbench(&d)
        .args(["peer", "check", "--timeout", "5", "--size", "16x16", "--"])
        .arg("python3")
        .arg(fault_peer())
        .args(["nan", &tag]));
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(3), "{out}\n{}", text(&o.stderr));
    // Named by its hello, checked as its hello's family says (other: no hard cases).
    assert!(
        out.starts_with("# Conformance of peer `fault-nan`"),
        "{out}"
    );
    assert!(
        out.contains("**FAIL**: peer 'fault-nan': image has 256 pixels that are NaN"),
        "{out}"
    );
    assert!(!out.contains("hard-slivers"), "{out}");
    // It refuses an unknown request, but answers a hello of another major version: caught.
    assert!(
        out.contains("- pass a request of an unknown type: refused"),
        "{out}"
    );
    assert!(
        out.contains("- **FAIL** `hello` of protocol 99.0: expected an error reply"),
        "{out}"
    );
    assert_no_survivors(&tag);
}

/// The plain-Python peer of docs/peers.md, exactly as the page shows it (the first ```python
/// block after the `<!-- tested: tiny_peer.py` marker), draws what `raycast --integrator
/// average` draws.
#[test]
fn the_pages_plain_python_peer_works_as_written() {
    let page = std::fs::read_to_string(root().join("docs/peers.md")).unwrap();
    let after = page
        .split("<!-- tested: tiny_peer.py")
        .nth(1)
        .expect("the marker in docs/peers.md");
    let code = after
        .split("```python\n")
        .nth(1)
        .and_then(|c| c.split("\n```").next())
        .expect("a python block after the marker");
    let d = tmpdir("tiny");
    std::fs::write(d.join("tiny_peer.py"), code).unwrap();
    // The declaration as the page gives it.
    let decl = page
        .split("Save it as `tiny_peer.py` and declare it:")
        .nth(1)
        .and_then(|t| t.split("```toml\n").nth(1))
        .and_then(|t| t.split("\n```").next())
        .expect("the page's declaration of the tiny peer");
    std::fs::write(d.join("tiny.toml"), decl).unwrap();
    let mut images = Vec::new();
    for r in ["tiny", "raycast"] {
        let out = d.join(format!("{r}.exr"));
        let o = run(tetbench(&d).args([
            "render",
            "spx:1500",
            "--peers",
            "tiny.toml",
            "--renderer",
            r,
            "--integrator",
            "average",
            "--projection",
            "persp",
            "--view",
            "30,20",
            "--size",
            "32x24",
            "--out",
            out.to_str().unwrap(),
        ]));
        assert!(o.status.success(), "{r}: {}", text(&o.stderr));
        images.push(algorithms::image::Image::read(&out).unwrap());
    }
    let e = algorithms::metrics::compare(&images[0], &images[1]).unwrap();
    assert!(e.rmse < 1e-6, "rmse {} against raycast", e.rmse);
    assert!(images[0].pixels.iter().any(|p| p[3] > 0.5));
}

// ---------------------------------------------------------------------------------------------
// Declarations

#[test]
fn an_experiment_files_own_peers_run_only_with_allow_peers() {
    let d = tmpdir("allow");
    let tag = unique_tag("allow");
    let exp = d.join("exp.toml");
    std::fs::write(
        &exp,
        format!(
            r#"
datasets = ["spx:300"]
renderers = [{{ name = "mine" }}]
sizes = ["8x8"]
repeats = 1
warmup = 0
error = false

[[peer]]
name = "mine"
command = ["python3", "{}", "good", "{tag}"]
family = "other"
integrators = ["average"]
"#,
            fault_peer().display()
        ),
    )
    .unwrap();
    let out = d.join("out");
    let o = run(tetbench(&d).args([
        "bench",
        exp.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("--allow-peers") && err.contains("fault_peer.py good"),
        "{err}"
    );
    assert!(!out.join("results.csv").exists());
    assert_no_survivors(&tag);
    let o = run(tetbench(&d).args([
        "bench",
        exp.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--allow-peers",
        "--no-plots",
    ]));
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("peer 'mine' runs `python3 "), "{err}");
}

#[test]
fn bad_declarations_and_protocol_versions_are_one_line() {
    let d = tmpdir("decl");
    let bad = d.join("bad.toml");
    std::fs::write(
        &bad,
        "[[peer]]\nname = \"x\"\ncommand = []\nfamily = \"pt\"\nintegrators = [\"average\"]\n",
    )
    .unwrap();
    let clash = d.join("clash.toml");
    std::fs::write(&clash, "[[peer]]\nname = \"raycast\"\ncommand = [\"x\"]\nfamily = \"pt\"\nintegrators = [\"average\"]\n").unwrap();
    let v2 = d.join("v2.toml");
    let tag = unique_tag("v2");
    std::fs::write(
        &v2,
        format!(
            "[[peer]]\nname = \"v2\"\ncommand = [\"python3\", \"{}\", \"v2\", \"{tag}\"]\nfamily = \"pt\"\nintegrators = [\"average\"]\n",
            fault_peer().display()
        ),
    )
    .unwrap();
    for (file, args, want) in [
        (&bad, vec!["list"], "`command` is empty"),
        (&clash, vec!["list"], "the name of a built-in renderer"),
        (
            &v2,
            vec![
                "render",
                "spx:300",
                "--renderer",
                "v2",
                "--size",
                "8x8",
                "--out",
                "x.png",
            ],
            "peer 'v2' speaks protocol 2.0; this tetbench speaks 1.x",
        ),
    ] {
        let o = run(tetbench(&d)
            .args(&args)
            .args(["--peers", file.to_str().unwrap()]));
        let err: Vec<String> = text(&o.stderr)
            .lines()
            .filter(|l| !l.contains(" runs `"))
            .map(str::to_string)
            .collect();
        assert_eq!(o.status.code(), Some(2), "{err:?}");
        assert_eq!(err.len(), 1, "{err:?}");
        assert!(err[0].contains(want), "{want:?} not in {err:?}");
    }
    // The environment's files count too.
    let o = run(tetbench(&d).env("TETBENCH_PEERS", &bad).arg("list"));
    assert_eq!(o.status.code(), Some(2));
    assert!(!d.join("x.png").exists());
    assert_no_survivors(&tag);
}

// ---------------------------------------------------------------------------------------------
// Faults

/// A peers file declaring the fault peer in each mode (timeout 2 s), tagged for /proc.
fn fault_peers(d: &Path, tag: &str, modes: &[&str]) -> PathBuf {
    let mut toml = String::new();
    for m in modes {
        toml.push_str(&format!(
            "[[peer]]\nname = \"{m}\"\ncommand = [\"python3\", \"{}\", \"{m}\", \"{tag}\", \"{}\"]\nfamily = \"other\"\nintegrators = [\"average\"]\ntimeout_s = 2\n\n",
            fault_peer().display(),
            d.display()
        ));
    }
    let p = d.join("faults.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

#[test]
fn faults_cost_one_row_each_and_no_process_outlives_the_bench() {
    let d = tmpdir("faults");
    let tag = unique_tag("faults");
    let modes = [
        "good",
        "crash",
        "hang",
        "hang-hello",
        "hang-prepare",
        "garbage",
        "endless",
        "wrong-size",
        "nan",
        "die-mid-frame",
        "close-stdin",
        "child",
        "flaky",
        "refuse-prepare",
    ];
    let peers = fault_peers(&d, &tag, &modes);
    let renderers: Vec<String> = modes
        .iter()
        .map(|m| format!("{{ name = \"{m}\" }}"))
        .collect();
    let exp = d.join("exp.toml");
    std::fs::write(
        &exp,
        format!(
            "datasets = [\"spx:300\"]\nrenderers = [{}]\nsizes = [\"16x16\"]\nviews = {{ named = [\"30,20\", \"90,0\"] }}\nrepeats = 1\nwarmup = 1\nerror = false\n",
            renderers.join(", ")
        ),
    )
    .unwrap();
    let out = d.join("out");
    let t0 = Instant::now();
    let o = run_within(
        tetbench(&d).args([
            "bench",
            exp.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--no-plots",
            "--peers",
            peers.to_str().unwrap(),
        ]),
        Duration::from_secs(120),
    );
    let secs = t0.elapsed().as_secs_f64();
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let table = Csv::read(&out.join("results.csv"));
    let col = |n: &str| table.col(n);
    let rows = &table.rows;
    assert_eq!(rows.len(), 2 * modes.len(), "{rows:?}");
    let note = |m: &str, view: &str| -> String {
        rows.iter()
            .find(|r| r[col("renderer")] == m && r[col("view_id")] == view)
            .unwrap_or_else(|| panic!("no row {m} {view}"))[col("note")]
        .to_string()
    };
    let v = ["named:0", "named:1"];
    for view in v {
        assert_eq!(note("good", view), "");
        for (m, want) in [
            ("crash", "exited during render"),
            ("hang", "no reply to render within 2 s"),
            ("hang-hello", "no reply to hello within 2 s"),
            ("hang-prepare", "no reply to prepare within 2 s"),
            ("garbage", "not a reply object"),
            ("endless", "longer than 1048576 bytes"),
            (
                "wrong-size",
                "image of 4080 bytes, expected 16×16 RGBA f32 = 4096 bytes",
            ),
            ("nan", "256 pixels that are NaN or infinite"),
            ("die-mid-frame", "exited during render"),
            ("close-stdin", "stopped reading requests before prepare"),
            ("child", "no reply to render within 2 s"),
            // The peer's own error reply, as one line.
            (
                "refuse-prepare",
                "peer 'refuse-prepare' failed prepare: no mesh for me",
            ),
        ] {
            let n = note(m, view);
            assert!(n.contains(want), "{m} {view}: {want:?} not in {n:?}");
            assert!(!n.contains('\n'));
        }
    }
    // The crashing peer's last words reach the note.
    assert!(
        note("crash", v[0]).contains("crashing as asked"),
        "{}",
        note("crash", v[0])
    );
    // A peer that crashed once is started afresh for the next cell.
    assert!(note("flaky", v[0]).contains("exited during render"));
    assert_eq!(note("flaky", v[1]), "");
    // Within the timeouts: hang, child (2 cells each), hang-hello, hang-prepare — 2 s each.
    assert!(secs < 60.0, "took {secs:.1} s");
    assert_no_survivors(&tag);
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));
    let log = std::fs::read_to_string(out.join("peer-logs/crash.log")).unwrap();
    assert!(log.contains("crashing as asked"), "{log}");
}

/// Starts a bench whose one peer hangs in render (timeout 60 s), and waits for the peer.
fn hanging_bench(d: &Path, tag: &str) -> Child {
    let peers = fault_peers(d, tag, &["hang"]);
    let exp = d.join("exp.toml");
    std::fs::write(
        &exp,
        "datasets = [\"spx:300\"]\nrenderers = [{ name = \"hang\" }]\nsizes = [\"8x8\"]\nerror = false\n",
    )
    .unwrap();
    std::fs::write(
        &peers,
        std::fs::read_to_string(&peers)
            .unwrap()
            .replace("timeout_s = 2", "timeout_s = 60"),
    )
    .unwrap();
    let child = tetbench(d)
        .args([
            "bench",
            exp.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
            "--no-plots",
            "--force",
            "--peers",
            peers.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while survivors(tag).is_empty() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the peer never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let it reach the render request.
    std::thread::sleep(Duration::from_millis(500));
    child
}

fn signal(child: &Child, sig: i32) {
    // SAFETY: kill has no memory preconditions.
    unsafe {
        libc::kill(child.id() as i32, sig);
    }
}

fn wait_within(child: &mut Child, limit: Duration) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        assert!(
            t0.elapsed() < limit,
            "tetbench did not exit within {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn no_peer_outlives_tetbench_on_ctrl_c_sigterm_or_sigkill() {
    use std::os::unix::process::ExitStatusExt;
    let d = tmpdir("signals");
    // Two Ctrl-Cs: the second exits at once, ending the peer's group first.
    for sig in [libc::SIGINT, libc::SIGTERM] {
        let tag = unique_tag("sig");
        let mut c = hanging_bench(&d, &tag);
        signal(&c, sig);
        std::thread::sleep(Duration::from_millis(200));
        signal(&c, sig);
        let s = wait_within(&mut c, Duration::from_secs(10));
        assert_eq!(s.code(), Some(130), "{sig}: {s:?}");
        assert_no_survivors(&tag);
    }
    // SIGKILL: the kernel ends the peer (PR_SET_PDEATHSIG); its private directory stays until
    // the next run, which removes it.
    let tag = unique_tag("kill");
    let mut c = hanging_bench(&d, &tag);
    signal(&c, libc::SIGKILL);
    let s = wait_within(&mut c, Duration::from_secs(10));
    assert_eq!(s.signal(), Some(libc::SIGKILL));
    assert_no_survivors(&tag);
    assert_eq!(peer_dirs(&d).len(), 1, "{:?}", peer_dirs(&d));
    let o = run(tetbench(&d).args([
        "render",
        "spx:300",
        "--peers",
        fault_peers(&d, &tag, &["good"]).to_str().unwrap(),
        "--renderer",
        "good",
        "--size",
        "8x8",
        "--out",
        "x.png",
    ]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));
}

// ---------------------------------------------------------------------------------------------
// VTK's helper, through the same supervision: a stand-in for TETBENCH_VTK_PYTHON.

fn fake_vtk(d: &Path, mode: &str, tag: &str) -> Command {
    let mut c = tetbench(d);
    c.env("TETBENCH_VTK_PYTHON", fault_peer())
        .env("TETBENCH_VTK_TIMEOUT_S", "2")
        .env("FAULT_MODE", mode)
        .env("FAULT_TAG", tag)
        .env("FAULT_STATE", d);
    c
}

fn vtk_render(d: &Path, mode: &str, tag: &str) -> Output {
    run_within(
        fake_vtk(d, mode, tag).args([
            "render",
            "spx:300",
            "--renderer",
            "vtk-raycast",
            "--size",
            "8x8",
            "--out",
            d.join("v.png").to_str().unwrap(),
        ]),
        Duration::from_secs(60),
    )
}

fn assert_one_line(o: &Output, want: &str) {
    let err = text(&o.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| !l.contains(" runs `")).collect();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains(want), "{want:?} not in {err:?}");
}

#[test]
fn a_vtk_helper_that_never_replies_times_out_at_start_in_prepare_and_in_render() {
    let d = tmpdir("vtk-hang");
    let tag = unique_tag("vtk-hang");
    for (mode, want) in [
        ("hang-hello", "no reply to hello within 2 s"),
        ("hang-prepare", "no reply to prepare within 2 s"),
        ("hang", "no reply to render within 2 s"),
    ] {
        assert_one_line(&vtk_render(&d, mode, &tag), want);
    }
    assert_no_survivors(&tag);
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));
}

#[test]
fn a_vtk_helper_that_exits_is_an_error_not_a_sigpipe() {
    let d = tmpdir("vtk-exit");
    let tag = unique_tag("vtk-exit");
    // It stops reading after hello: writing prepare to it must fail, not kill tetbench.
    assert_one_line(
        &vtk_render(&d, "close-stdin", &tag),
        "stopped reading requests before prepare",
    );
    // It dies mid-frame in a bench (as an OOM kill or a segfault would): a failed row, exit 3.
    let exp = d.join("exp.toml");
    std::fs::write(
        &exp,
        "datasets = [\"spx:300\"]\nrenderers = [{ name = \"vtk-raycast\" }, { name = \"vtk-pt\" }]\nsizes = [\"8x8\"]\nerror = false\nrepeats = 1\n",
    )
    .unwrap();
    let o = run_within(
        fake_vtk(&d, "die-mid-frame", &tag).args([
            "bench",
            exp.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
            "--no-plots",
        ]),
        Duration::from_secs(60),
    );
    assert_eq!(o.status.code(), Some(3), "{}", text(&o.stderr));
    let csv = std::fs::read_to_string(d.join("out/results.csv")).unwrap();
    assert_eq!(csv.matches("exited during render").count(), 2, "{csv}");
    assert_no_survivors(&tag);
}

#[test]
fn a_vtk_helper_that_writes_an_endless_line_is_cut_off() {
    use std::os::unix::process::CommandExt;
    let d = tmpdir("vtk-endless");
    let tag = unique_tag("vtk-endless");
    let mut c = fake_vtk(&d, "endless", &tag);
    c.args([
        "render",
        "spx:300",
        "--renderer",
        "vtk-raycast",
        "--size",
        "8x8",
        "--out",
        d.join("v.png").to_str().unwrap(),
    ]);
    // Under a 4 GiB address-space limit, a reply buffered without bound would abort tetbench.
    // SAFETY: setrlimit is async-signal-safe.
    unsafe {
        c.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: 4 << 30,
                rlim_max: 4 << 30,
            };
            libc::setrlimit(libc::RLIMIT_AS, &lim);
            Ok(())
        });
    }
    assert_one_line(
        &run_within(&mut c, Duration::from_secs(60)),
        "longer than 1048576 bytes",
    );
    assert_no_survivors(&tag);
}

#[test]
fn killed_runs_leave_no_private_directories_behind() {
    let d = tmpdir("vtk-dirs");
    let tag = unique_tag("vtk-dirs");
    // A directory of a killed run (its lock is free) and one of an older tetbench's VTK helper
    // whose process is gone: both are removed by the next run; a fresh one of this run is not
    // left behind either.
    let stale = d.join("tmp/tetbench-peer-999999999-0");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join(".lock"), "").unwrap();
    std::fs::write(stale.join("positions.f64"), [0u8; 64]).unwrap();
    let old = d.join("tmp/tetbench-vtk-999999999-3");
    std::fs::create_dir_all(&old).unwrap();
    let o = vtk_render(&d, "good", &tag);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(peer_dirs(&d).is_empty(), "{:?}", peer_dirs(&d));
    assert_no_survivors(&tag);
}

/// `tetbench list | head -1` ends quietly (SIGPIPE's default action is kept for stdout).
#[test]
fn list_into_a_closed_pipe_is_quiet() {
    use std::io::{BufRead, BufReader};
    let d = tmpdir("pipe");
    let mut c = tetbench(&d)
        .args(["list", "--peers", examples().to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(c.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert_eq!(first.trim(), "renderers:");
    let o = c.wait_with_output().unwrap();
    assert!(text(&o.stderr).is_empty(), "{}", text(&o.stderr));
}
