//! Inputs that used to block or abort tetbench: a named pipe, a device, a directory or a
//! socket where a file is read; image headers that announce huge images; records that never
//! end; memory that runs out under `ulimit -v`. Each exits 2 with one line naming the input,
//! or becomes a failed row (exit 3) — never a wait without end, an abort or a lost row.

use std::ffi::CString;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use crate::test_util::{command, one_line_error, s, tmpdir, two_tets_in, Csv, TWO_TETS};

/// Runs tetbench with a deadline: a run that blocks is killed and reported as such.
fn run(args: &[&str], limit_as: Option<u64>) -> Output {
    let mut c = command();
    c.args(args)
        .env("RAYON_NUM_THREADS", "2")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(bytes) = limit_as {
        // SAFETY: setrlimit only, between fork and exec (async-signal-safe).
        unsafe {
            c.pre_exec(move || {
                let l = libc::rlimit {
                    rlim_cur: bytes,
                    rlim_max: bytes,
                };
                if libc::setrlimit(libc::RLIMIT_AS, &l) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    let mut child = c.spawn().expect("run tetbench");
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(120) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("tetbench {args:?} blocked (killed after 120 s)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn tetbench(args: &[&str]) -> Output {
    run(args, None)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn mkfifo(p: &Path) {
    let c = CString::new(s(p)).unwrap();
    // SAFETY: mkfifo with a valid NUL-terminated path.
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o600) },
        0,
        "{}",
        p.display()
    );
}

const SMALL: &str = r#"
name = "small"
datasets = ["spx:1500"]
renderers = [{ name = "raycast", integrators = ["partial"] }]
sizes = ["24x24"]
repeats = 1
warmup = 0
"#;

/// Every kind of input tetbench reads, given as a named pipe (or another file that is not a
/// regular file), is refused at once with one line naming it.
#[test]
fn inputs_that_are_not_regular_files_are_refused_by_name() {
    let d = tmpdir("fifo");
    let good = d.join("good.off");
    std::fs::write(&good, TWO_TETS).unwrap();
    let tf = d.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points":[{"s":0,"rgb":[1,1,1],"tau":1},{"s":1,"rgb":[1,1,1],"tau":2}]}"#,
    )
    .unwrap();
    // Real images for the other side of `compare`.
    for ext in ["png", "exr"] {
        let img = d.join(format!("img.{ext}"));
        let o = tetbench(&[
            "render",
            s(&good),
            "--renderer",
            "raycast",
            "--size",
            "8x8",
            "--out",
            s(&img),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let junk_xyz = d.join("junkxyz.bin");
    std::fs::write(&junk_xyz, [0u8; 64]).unwrap();

    let fifo = |name: &str| {
        let p = d.join(name);
        mkfifo(&p);
        p
    };
    for ext in ["off", "vtk", "vtu"] {
        let p = fifo(&format!("mesh.{ext}"));
        one_line_error(&tetbench(&["info", s(&p)]), &[s(&p), "named pipe"]);
    }
    let xyz = fifo("pipexyz.bin");
    one_line_error(&tetbench(&["info", s(&xyz)]), &[s(&xyz), "named pipe"]);
    let q = fifo("q.bin");
    one_line_error(
        &tetbench(&["info", s(&junk_xyz), "--q", s(&q)]),
        &[s(&q), "named pipe"],
    );
    let tfp = fifo("tf-pipe.json");
    one_line_error(
        &tetbench(&[
            "render",
            s(&good),
            "--renderer",
            "raycast",
            "--tf",
            s(&tfp),
            "--out",
            s(&d.join("x.png")),
        ]),
        &[s(&tfp), "named pipe"],
    );
    let exp = fifo("exp.toml");
    one_line_error(
        &tetbench(&["bench", s(&exp), "--out", s(&d.join("o"))]),
        &[s(&exp), "named pipe"],
    );
    for ext in ["png", "exr"] {
        let p = fifo(&format!("pipe.{ext}"));
        let img = d.join(format!("img.{ext}"));
        one_line_error(
            &tetbench(&["compare", s(&p), s(&img)]),
            &[s(&p), "named pipe"],
        );
    }
    // `/dev/zero` as a mesh (through a link, as a probe would give it), and a directory.
    let zero = d.join("zero.off");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    one_line_error(
        &tetbench(&["info", s(&zero)]),
        &[s(&zero), "character device"],
    );
    let dir = d.join("dir.vtu");
    std::fs::create_dir_all(&dir).unwrap();
    one_line_error(&tetbench(&["info", s(&dir)]), &[s(&dir), "directory"]);

    // A sweep's files: a shard's shard.txt and results.csv, plot's input, --resume's rows.
    let exp = d.join("small.toml");
    std::fs::write(&exp, SMALL).unwrap();
    let shard = d.join("shard");
    let o = tetbench(&["bench", s(&exp), "--out", s(&shard), "--shard", "0/1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["results.csv", "shard.txt"] {
        let copy = d.join(format!("shard-{f}"));
        std::fs::create_dir_all(&copy).unwrap();
        for g in ["results.csv", "shard.txt"] {
            if g == f {
                mkfifo(&copy.join(g));
            } else {
                std::fs::copy(shard.join(g), copy.join(g)).unwrap();
            }
        }
        let p = copy.join(f);
        one_line_error(
            &tetbench(&["merge", "--out", s(&d.join(format!("m-{f}"))), s(&copy)]),
            &[s(&p), "named pipe"],
        );
        if f == "results.csv" {
            one_line_error(&tetbench(&["plot", s(&copy)]), &[s(&p), "named pipe"]);
            one_line_error(
                &tetbench(&["bench", s(&exp), "--out", s(&copy), "--resume"]),
                &[s(&p), "named pipe"],
            );
        }
    }
    // A shard's kept figure files (copied by merge).
    let copy = d.join("shard-figure");
    std::fs::create_dir_all(copy.join("figure")).unwrap();
    for g in ["results.csv", "shard.txt"] {
        std::fs::copy(shard.join(g), copy.join(g)).unwrap();
    }
    let p = copy.join("figure").join("cell.json");
    mkfifo(&p);
    one_line_error(
        &tetbench(&["merge", "--out", s(&d.join("m-figure")), s(&copy)]),
        &[s(&p), "named pipe"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The files of the reference cache (`DIR/.cache/ref-*.exr`).
fn cache_entries(out: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(out.join(".cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    v.sort();
    v
}

/// A cache entry that is a named pipe, or an EXR whose header announces a huge image, is
/// neither waited on nor allocated: it is rendered again, and the run ends cleanly.
#[test]
fn a_cache_entry_that_is_a_pipe_or_a_huge_header_is_rendered_again() {
    let d = tmpdir("cache");
    let exp = d.join("small.toml");
    std::fs::write(&exp, SMALL).unwrap();
    let out = d.join("out");
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let entry = cache_entries(&out).pop().expect("a cache entry");
    let good = std::fs::read(&entry).unwrap();
    std::fs::remove_file(&entry).unwrap();
    mkfifo(&entry);
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout_has(&o, "reference_images: 1 rendered"),
        "{}",
        stderr(&o)
    );
    assert!(std::fs::metadata(&entry).unwrap().is_file());
    // The same entry, its header now announcing 100000 × 100000 pixels.
    std::fs::write(&entry, huge_exr_header(&good)).unwrap();
    let o = tetbench(&["bench", s(&exp), "--out", s(&out), "--no-plots", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout_has(&o, "reference_images: 1 rendered"),
        "{}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

fn stdout_has(o: &Output, want: &str) -> bool {
    String::from_utf8_lossy(&o.stdout).contains(want)
}

/// An EXR file whose `dataWindow` now says 100000 × 100000 pixels (the rest unchanged).
fn huge_exr_header(exr: &[u8]) -> Vec<u8> {
    let mut b = exr.to_vec();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = b
            .windows(name.len())
            .position(|w| w == name)
            .expect("an EXR header")
            + name.len()
            + 4;
        for (k, v) in [0i32, 0, 99_999, 99_999].iter().enumerate() {
            b[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    b
}

/// CRC-32 (ISO-HDLC, as PNG chunks use it).
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A valid PNG of a few dozen bytes whose header says `w` × `h` RGBA pixels.
fn tiny_png(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let chunk = |out: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
        out.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend(data);
        out.extend(&body);
        out.extend(crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

/// Image headers announcing 100000 × 100000 pixels in a file of a few bytes are refused before
/// anything of that size is allocated.
#[test]
fn compare_refuses_headers_that_announce_huge_images() {
    let d = tmpdir("huge");
    let good = d.join("good.exr");
    let mesh = two_tets_in(&d);
    let o = tetbench(&[
        "render",
        s(&mesh),
        "--renderer",
        "raycast",
        "--size",
        "8x8",
        "--out",
        s(&good),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = d.join("huge.png");
    let bytes = tiny_png(100_000, 100_000);
    assert!(bytes.len() < 80, "{}", bytes.len());
    std::fs::write(&png, &bytes).unwrap();
    let small = d.join("small.png");
    std::fs::write(&small, tiny_png(8, 8)).unwrap();
    one_line_error(
        &tetbench(&["compare", s(&png), s(&small)]),
        &[s(&png), "100000x100000"],
    );
    let exr = d.join("huge.exr");
    std::fs::write(&exr, huge_exr_header(&std::fs::read(&good).unwrap())).unwrap();
    one_line_error(
        &tetbench(&["compare", s(&good), s(&exr)]),
        &[s(&exr), "100000x100000"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A results file that never ends a record (a line of megabytes) is refused by name where it
/// is read: `plot`, `merge`, `bench --resume`.
#[test]
fn a_record_that_never_ends_is_refused() {
    let d = tmpdir("endless");
    let exp = d.join("small.toml");
    std::fs::write(&exp, SMALL).unwrap();
    let shard = d.join("shard");
    let o = tetbench(&["bench", s(&exp), "--out", s(&shard), "--shard", "0/1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = shard.join("results.csv");
    let mut text = std::fs::read(&csv).unwrap();
    text.extend(std::iter::repeat_n(b'0', 3 << 20));
    std::fs::write(&csv, &text).unwrap();
    one_line_error(&tetbench(&["plot", s(&shard)]), &[s(&csv), "never ends"]);
    one_line_error(
        &tetbench(&["merge", "--out", s(&d.join("m")), s(&shard)]),
        &[s(&csv), "never ends"],
    );
    one_line_error(
        &tetbench(&["bench", s(&exp), "--out", s(&shard), "--resume"]),
        &[s(&csv), "longer than"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// `compare` with an all-NaN image: the errors are NaN (not "identical": psnr inf, max_abs 0),
/// and a warning says why.
#[test]
fn compare_with_an_all_nan_image_says_nan() {
    let d = tmpdir("nan");
    let mut nan = algorithms::image::Image::new(4, 4);
    nan.pixels.iter_mut().for_each(|p| *p = [f32::NAN; 4]);
    let (a, b) = (d.join("nan.exr"), d.join("black.exr"));
    nan.write(&a).unwrap();
    algorithms::image::Image::new(4, 4).write(&b).unwrap();
    let o = tetbench(&["compare", s(&a), s(&b)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    for k in ["rmse", "psnr", "max_abs"] {
        assert!(out.contains(&format!("{k}: NaN\n")), "{out}");
    }
    assert!(stderr(&o).contains("16 pixels are NaN"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&d);
}

/// A file name with a line break in it is named on one line (escaped).
#[test]
fn a_file_name_with_a_newline_gives_one_line() {
    let o = tetbench(&["info", "no\nsuch.off"]);
    one_line_error(&o, &["no\\nsuch.off", "no such file"]);
}

/// Under an address-space limit (a batch system's `ulimit -v`), frames whose buffers do not fit
/// are failed rows saying "out of memory", the others are measured, the run ends with exit 3
/// and leaves no lock; `render` says the same in one line.
#[test]
fn out_of_memory_under_ulimit_v_is_a_failed_row_not_an_abort() {
    let d = tmpdir("oom");
    let exp = d.join("oom.toml");
    std::fs::write(
        &exp,
        r#"
name = "oom"
datasets = ["spx:1500"]
renderers = [{ name = "raycast", integrators = ["partial"] }, { name = "cpu-pt" }]
sizes = ["32x32", "16384x16384"]
repeats = 1
warmup = 0
"#,
    )
    .unwrap();
    let out = d.join("out");
    let limit = 1536 << 20;
    let o = run(
        &["bench", s(&exp), "--out", s(&out), "--no-plots"],
        Some(limit),
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(!out.join(".lock").exists());
    let table = Csv::read(&out.join("results.csv"));
    let col = |n: &str| table.col(n);
    let rows = &table.rows;
    assert_eq!(rows.len(), 4, "{err}");
    for row in rows {
        let big = row[col("width")] == "16384";
        let measured = row[col("total_ms")] != "NaN";
        assert_eq!(measured, !big, "{row:?}");
        if big {
            assert!(row[col("note")].contains("out of memory"), "{row:?}");
        } else {
            assert!(!row[col("rmse")].is_empty(), "{row:?}");
        }
    }
    let o = run(
        &[
            "render",
            "spx:1500",
            "--renderer",
            "raycast",
            "--size",
            "16384x16384",
            "--out",
            s(&d.join("big.exr")),
        ],
        Some(limit),
    );
    one_line_error(&o, &["out of memory"]);
    assert!(!d.join("big.exr").exists());
    let _ = std::fs::remove_dir_all(&d);
}
