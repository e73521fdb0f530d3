//! The `datasets-gen` binary (CONVENTIONS §8) and the files it writes, read back by the
//! project's own loader (what `tetbench info` does).

use std::path::{Path, PathBuf};
use std::process::Command;

use algorithms::io::{load_path, LoadOptions};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_datasets-gen"))
}

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("datasets-gen-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn files_in(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn list_prints_every_generator() {
    let out = bin().arg("--list").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for g in datasets_gen::generators() {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(g.name))
            .unwrap_or_else(|| panic!("{} not listed", g.name));
        assert!(line.contains(&g.default_tets.to_string()), "{line}");
        if g.breaks.is_some() {
            assert!(line.contains("breaks:"), "{line}");
        }
    }
}

#[test]
fn help_works() {
    let out = bin().arg("--help").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("--tets") && text.contains("--out") && text.contains("--list"));
}

#[test]
fn bad_input_exits_2_with_one_line_and_no_file() {
    let d = tmpdir("bad");
    let out_file = d.join("x.off");
    let cases: Vec<Vec<String>> = vec![
        vec![
            "nope".into(),
            "--out".into(),
            out_file.display().to_string(),
        ],
        vec![
            "cc5".into(),
            "--tets".into(),
            "many".into(),
            "--out".into(),
            out_file.display().to_string(),
        ],
        vec![
            "cc5".into(),
            "--bogus".into(),
            "--out".into(),
            out_file.display().to_string(),
        ],
        vec![
            "cc5".into(),
            "--tets".into(),
            "0".into(),
            "--out".into(),
            out_file.display().to_string(),
        ],
        vec![
            "cc5".into(),
            "--out".into(),
            d.join("x.png").display().to_string(),
        ],
        vec!["cc5".into()],
        vec![
            "cc5".into(),
            "--tets".into(),
            "100".into(),
            "--out".into(),
            d.join("no/such/dir/x.off").display().to_string(),
        ],
    ];
    for args in cases {
        let out = bin().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(files_in(&d).is_empty(), "{:?}", files_in(&d));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn every_generator_writes_a_file_the_loader_reads() {
    let d = tmpdir("all");
    for g in datasets_gen::generators() {
        let tets = if g.name == "hard-saturate" { 40 } else { 600 };
        let path = d.join(format!("{}.off", g.name));
        let st = bin()
            .args([g.name, "--tets", &tets.to_string(), "--seed", "3", "--out"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}: {}",
            g.name,
            String::from_utf8_lossy(&st.stderr)
        );
        let m = datasets_gen::generate(g.name, Some(tets), 3).unwrap();
        let read_path = if m.fields()[0].steps.len() > 1 {
            d.join(format!("{}.0000.off", g.name))
        } else {
            path
        };
        let r = load_path(&read_path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.num_tets(), m.num_tets(), "{}", g.name);
        assert_eq!(r.positions(), m.positions(), "{}", g.name);
        assert_eq!(r.degenerate_tets(), m.degenerate_tets(), "{}", g.name);
        assert_eq!(r.scalars(), &m.fields()[0].steps[0][..], "{}", g.name);
    }
    // tv-gaussian to .off: one file per step.
    let steps = files_in(&d)
        .iter()
        .filter(|f| f.starts_with("tv-gaussian."))
        .count();
    assert_eq!(steps, datasets_gen::TV_STEPS);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn vtu_keeps_the_lattice_and_the_steps_once_the_writer_exists() {
    let d = tmpdir("vtu");
    for name in ["bcc", "tv-gaussian"] {
        let m = datasets_gen::generate(name, Some(500), 0).unwrap();
        let path = d.join(format!("{name}.vtu"));
        if let Err(e) = algorithms::io::write(&m, &path) {
            assert!(e.to_string().contains("not built in"), "{e}");
            continue; // the .vtu writer is not in yet
        }
        let r = match load_path(&path, &LoadOptions::default()) {
            Ok(r) => r,
            Err(e) if e.to_string().contains("not built in") => continue,
            Err(e) => panic!("{e}"),
        };
        assert_eq!(r.field_data, m.field_data, "{name}");
        assert_eq!(
            r.fields()[0].steps.len(),
            m.fields()[0].steps.len(),
            "{name}"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_size_after_the_name_is_the_tet_count_and_a_second_one_is_refused() {
    let d = tmpdir("spec");
    let a = d.join("a.vtu");
    let b = d.join("b.vtu");
    let out = bin()
        .args(["brain:2000", "--out"])
        .arg(&a)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let out = bin()
        .args(["brain", "--tets", "2000", "--out"])
        .arg(&b)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    for args in [
        &["brain:2000", "--tets", "3000"][..],
        &["brain:abc"][..],
        &["brain:0"][..],
    ] {
        let c = d.join("c.vtu");
        let out = bin().args(args).arg("--out").arg(&c).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!c.exists(), "{args:?} wrote a file");
    }
    std::fs::remove_dir_all(&d).ok();
}
