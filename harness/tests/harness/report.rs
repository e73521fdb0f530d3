//! The report of a `reproduce --quick` run in a real browser: headless Chromium loads
//! `index.html` from `file://` (and again with the 1:1 viewer open on an error map), the test
//! fails on any console message, and each screenshot must show something. The run has one
//! failed measurement on purpose (a renderer that panics in the figure's cell), which the
//! figure must show as a failed cell and the report list, not crash on.
//!
//! Chromium is Debian's `chromium`; without it the test says so and passes, unless
//! `TETBENCH_REQUIRE_CHROMIUM=1` (CI) makes that a failure.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::test_util::{command, tmpdir};

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|n| {
            std::env::var_os("PATH")
                .map(|p| {
                    std::env::split_paths(&p)
                        .map(|d| d.join(n))
                        .collect::<Vec<_>>()
                })
                .unwrap_or_default()
        })
        .find(|p| p.is_file())
}

/// Loads `url` in headless Chromium and screenshots it; returns Chromium's log lines.
fn screenshot(browser: &Path, url: &str, shot: &Path, profile: &Path) -> Vec<String> {
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--enable-logging=stderr",
            "--v=0",
            "--window-size=1280,1400",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(url)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start chromium");
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let t0 = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("chromium did not finish loading {url} in 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    reader.join().unwrap().lines().map(String::from).collect()
}

/// RGBA pixels of a PNG.
fn pixels(p: &Path) -> (u32, u32, Vec<[u8; 4]>) {
    let mut dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    dec.set_transformations(
        png::Transformations::normalize_to_color8() | png::Transformations::ALPHA,
    );
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    let px = buf[..info.buffer_size()]
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    (info.width, info.height, px)
}

/// Share of the pixels that differ from the most common colour.
fn not_background(px: &[[u8; 4]]) -> f64 {
    let mut counts = std::collections::HashMap::new();
    for p in px {
        *counts.entry(*p).or_insert(0usize) += 1;
    }
    let most = counts.values().copied().max().unwrap_or(0);
    1.0 - most as f64 / px.len().max(1) as f64
}

/// Every `src="…"` and `href="…"` of the page that is a file beside it exists; none leaves the
/// machine.
fn check_links(html: &str, dir: &Path) {
    for attr in ["src=\"", "href=\""] {
        for part in html.split(attr).skip(1) {
            let link = &part[..part.find('"').unwrap()];
            assert!(
                !link.contains("://"),
                "the report reaches outside: {attr}{link}"
            );
            if link.starts_with('#') {
                continue;
            }
            assert!(dir.join(link).is_file(), "{link}: not beside the report");
        }
    }
}

#[test]
fn the_quick_report_loads_in_chromium_without_console_messages() {
    let Some(browser) = chromium() else {
        if std::env::var("TETBENCH_REQUIRE_CHROMIUM").is_ok_and(|v| v == "1") {
            panic!("chromium not found and TETBENCH_REQUIRE_CHROMIUM=1");
        }
        eprintln!("chromium not found: the report's browser test is skipped");
        return;
    };
    let d = tmpdir("quick");
    let out = d.join("results");
    // One PTINT table (the exact reference as its yardstick) and one of the BCC paper (the
    // analytic ground truth as its yardstick), each with its figure; the ray caster with full
    // pre-integration panics in the figure's cell.
    let o = command()
        .args([
            "reproduce",
            "--quick",
            "--only",
            "ptint-table2,bcc_pt",
            "--out",
        ])
        .arg(&out)
        .env("TETBENCH_TEST_PANIC", "raycast/preint@rot:0")
        .env_remove("TETBENCH_VTK_PYTHON")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // One line per table, then the report and the wall time.
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 4, "{stdout}");
    assert!(lines[0].starts_with("ptint-table2: 8 rows in "), "{stdout}");
    assert!(lines[1].starts_with("bcc_pt: "), "{stdout}");
    assert!(lines[2].ends_with("index.html"), "{stdout}");

    for f in [
        "index.html",
        "ptint-table2-images.png",
        "ptint-table2-images.svg",
        "bcc_pt-images.png",
        "bcc_pt-images.svg",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    check_links(&html, &out);
    // Each figure is shown once, in its section (not again from the table's note).
    assert_eq!(html.matches("src=\"ptint-table2-images.png\"").count(), 1);
    assert!(
        html.contains("raycast/preint: internal error: panicked"),
        "the failure is not listed"
    );
    // The figure holds the failed cell, not a crash; the other cells are clickable.
    let (w, h, fig) = pixels(&out.join("ptint-table2-images.png"));
    assert!(w > 400 && h > 1000, "{w}x{h}");
    assert!(not_background(&fig) > 0.3);
    assert!(html.contains("data-hits=\"[{&quot;x&quot;"));

    let profile = d.join("profile");
    let page = format!("file://{}", out.join("index.html").display());
    for (url, shot) in [
        (page.clone(), d.join("page.png")),
        // The viewer open on the first cell's error map.
        (format!("{page}#view=0/0/2"), d.join("viewer.png")),
    ] {
        let log = screenshot(&browser, &url, &shot, &profile);
        let console: Vec<&String> = log.iter().filter(|l| l.contains(":CONSOLE")).collect();
        assert!(console.is_empty(), "{url}: console messages: {console:#?}");
        assert!(
            shot.is_file(),
            "{url}: no screenshot; chromium said:\n{}",
            log.join("\n")
        );
        let (_, _, px) = pixels(&shot);
        assert!(not_background(&px) > 0.02, "{url}: the screenshot is blank");
    }
    // The viewer covers the page with its dark background and shows the error map.
    let (vw, vh, v) = pixels(&d.join("viewer.png"));
    let dark = v
        .iter()
        .filter(|p| p[0] < 40 && p[1] < 40 && p[2] < 40)
        .count();
    assert!(
        dark as f64 > 0.5 * (vw * vh) as f64,
        "the viewer did not open"
    );
    let _ = std::fs::remove_dir_all(&d);
}
