//! The JBU and BCC tables run through the one measurement pipeline like every paper table:
//! `reproduce --quick --only <table>` writes the table and its plots; its shards merged give the
//! unsharded run's rows and table; a renderer that panics costs failed rows (NaN times and the
//! message) that the table names, and the run exits 3; `--resume` measures only the rows that
//! are missing. (JBU's quick run is the longest of the three: its shards are left to the BCC
//! tables, which share the same code, and its table's independence of row order is tested in
//! `papers::jbu`.)

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Output;

use crate::test_util::{command, err_lines, s, tmpdir, Csv};

/// `reproduce --quick --only <id>` with `args`, the renderer cells `panic` names panicking.
fn reproduce(id: &str, panic: &str, args: &[&str]) -> Output {
    command()
        .args(["reproduce", "--quick", "--only", id])
        .args(args)
        .env("TETBENCH_TEST_PANIC", panic)
        .output()
        .unwrap()
}

/// key (dataset|variant|projection|size|view) -> (rmse, failed) of a raw results.csv, and its
/// lines in file order.
fn raw_rows(p: &Path) -> (BTreeMap<String, (String, bool)>, Vec<String>) {
    let t = Csv::read(p);
    let (rmse, total) = (t.col("rmse"), t.col("total_ms"));
    let m = t
        .by_key()
        .into_iter()
        .map(|(key, rec)| {
            let failed = rec[total].parse::<f64>().map_or(true, f64::is_nan);
            (key, (rec[rmse].clone(), failed))
        })
        .collect();
    let lines = std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    (m, lines)
}

/// The table's rows, cut to their first `cols` cells (those that do not depend on timing).
fn table_rows(md: &str, cols: usize) -> Vec<String> {
    md.lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| ---"))
        .skip(1)
        .map(|l| l.split(" | ").take(cols).collect::<Vec<_>>().join("|"))
        .collect()
}

/// The whole table (failed rows, exit 3, its files), its shards merged (with `shards`), and a
/// resumed run.
fn table_through_the_pipeline(
    id: &str,
    panic: &str,
    failed: &str,
    files: &[&str],
    cols: usize,
    shards: bool,
) {
    let d = tmpdir(id);
    let (whole, s0, s1, merged) = (
        d.join("whole"),
        d.join("s0"),
        d.join("s1"),
        d.join("merged"),
    );
    let o = reproduce(id, panic, &["--out", s(&whole)]);
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    assert!(
        err_lines(&o).contains("measurement(s) failed"),
        "{}",
        err_lines(&o)
    );
    for f in files
        .iter()
        .chain(&[&*format!("{id}.md"), &*format!("{id}.csv")])
    {
        assert!(whole.join(f).exists(), "{f} not written");
    }
    let md = std::fs::read_to_string(whole.join(format!("{id}.md"))).unwrap();
    assert!(md.contains("**Failed measurements**"), "{md}");
    assert!(md.contains(failed), "no '{failed}' in\n{md}");
    let raw = |dir: &Path| dir.join(format!("raw/{id}/results.csv"));
    let (rows, lines) = raw_rows(&raw(&whole));
    assert!(rows.values().any(|r| r.1) && rows.values().any(|r| !r.1));

    if shards {
        for (i, dir) in [(0, &s0), (1, &s1)] {
            let o = reproduce(id, panic, &["--shard", &format!("{i}/2"), "--out", s(dir)]);
            assert!(matches!(o.status.code(), Some(0 | 3)), "{}", err_lines(&o));
            assert!(
                !dir.join(format!("{id}.md")).exists(),
                "a shard writes no table"
            );
            assert!(
                raw_rows(&raw(dir)).0.len() < rows.len(),
                "shard {i} has every row"
            );
        }
        let o = reproduce(id, panic, &["--merge", s(&s0), s(&s1), "--out", s(&merged)]);
        assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
        let (mrows, _) = raw_rows(&raw(&merged));
        assert_eq!(
            rows.keys().collect::<Vec<_>>(),
            mrows.keys().collect::<Vec<_>>()
        );
        for (k, (rmse, failed)) in &rows {
            assert_eq!(&mrows[k], &(rmse.clone(), *failed), "{k}");
        }
        let mmd = std::fs::read_to_string(merged.join(format!("{id}.md"))).unwrap();
        assert_eq!(table_rows(&md, cols), table_rows(&mmd, cols));
        assert!(mmd.contains(failed), "{mmd}");
    }

    // An interrupted run: the first half of its rows kept; `--resume` measures the rest only.
    let keep = 1 + (lines.len() - 1) / 2;
    std::fs::write(raw(&whole), lines[..keep].join("\n") + "\n").unwrap();
    let o = reproduce(id, panic, &["--resume", "--out", s(&whole)]);
    assert_eq!(o.status.code(), Some(3), "{}", err_lines(&o));
    let (rrows, rlines) = raw_rows(&raw(&whole));
    assert_eq!(&rlines[..keep], &lines[..keep], "kept rows measured again");
    assert_eq!(
        rrows.keys().collect::<Vec<_>>(),
        rows.keys().collect::<Vec<_>>()
    );
    let rmd = std::fs::read_to_string(whole.join(format!("{id}.md"))).unwrap();
    assert_eq!(table_rows(&md, cols).len(), table_rows(&rmd, cols).len());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn jbu_table_runs_through_the_pipeline() {
    table_through_the_pipeline(
        "jbu",
        // cpu-pt's full-size frames: its speed-ups have no time to beat, its errors no
        // yardstick of its own (the wrapper's rows still measure).
        "cpu-pt/centroid/partial@*",
        "cpu-pt/centroid/partial: 2 of 2 measurements failed (internal error: panicked: test-only",
        &["jbu_time_raycast.png", "jbu_rmse_raycast.svg"],
        5,
        false,
    );
}

#[test]
fn bcc_pt_table_runs_through_the_pipeline() {
    table_through_the_pipeline(
        "bcc_pt",
        // Empty-space skipping on every lattice.
        "cpu-pt/bcc-implicit-skip/partial[tf=sparse]@*",
        "cc5 shell · cpu-pt/bcc-implicit-skip/partial[tf=sparse]: 1 of 1 measurements failed",
        &["bcc_pt-time_vs_error.png", "bcc_pt-time_vs_error.svg"],
        5,
        true,
    );
}

#[test]
fn bcc_reconstruction_table_runs_through_the_pipeline() {
    table_through_the_pipeline(
        "bcc_reconstruction",
        "volume-raycast/exact[scheme=bary,step=0.0625]@*",
        "BCC shell · volume-raycast/exact[scheme=bary,step=0.0625]: 1 of 1 measurements failed",
        &["bcc_reconstruction-time_vs_error.png"],
        3,
        true,
    );
}
