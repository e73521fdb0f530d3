//! The set-up that the harness's end-to-end tests share: the `tetbench` binary and its runs,
//! a fresh temporary directory, an experiment file written into it, the one-line errors that
//! bad input must get, and a results CSV read back by column name. Both test binaries (`cli`
//! and `harness`) include this module; each uses part of it, hence `allow(dead_code)`.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A command that runs the `tetbench` binary built for these tests.
pub fn command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tetbench"))
}

/// Runs `tetbench args` and waits for it.
pub fn tetbench(args: &[&str]) -> Output {
    command().args(args).output().expect("run tetbench")
}

/// A new empty directory under the system's temporary directory, named after `tag`, this
/// process and a counter (the tests of one binary share a process, and some share tags).
pub fn tmpdir(tag: &str) -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("tetbench-test-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes an experiment file `name` into `dir`, returning its path.
pub fn write_exp(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A path as the `&str` a command line takes.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The `tetbench:` lines of a run's stderr (its errors and warnings, without others' noise).
pub fn err_lines(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.starts_with("tetbench:"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Exit 2 with one `tetbench:` line on stderr containing every one of `want`, and no panic.
pub fn one_line_error(o: &Output, want: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    let e = err_lines(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(e.lines().count(), 1, "expected one line, got: {err}");
    for w in want {
        assert!(e.contains(w), "{w:?} not in {err:?}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

/// A CSV file read back whole: its header and its records, each cell as text.
pub struct Csv {
    pub head: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    pub fn read(p: &Path) -> Csv {
        let mut r = csv::Reader::from_path(p)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()));
        let head = r.headers().unwrap().iter().map(String::from).collect();
        let rows = r
            .records()
            .map(|x| x.unwrap().iter().map(String::from).collect())
            .collect();
        Csv { head, rows }
    }

    /// The index of column `name`.
    pub fn col(&self, name: &str) -> usize {
        self.head
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column '{name}' in {:?}", self.head))
    }

    /// The records of a results CSV by their key (dataset, variant, projection, size and view);
    /// a key that stands twice fails the test.
    pub fn by_key(self) -> BTreeMap<String, Vec<String>> {
        let cols = [
            "dataset",
            "variant",
            "projection",
            "width",
            "height",
            "view_id",
        ]
        .map(|c| self.col(c));
        let mut m = BTreeMap::new();
        for rec in self.rows {
            let key = cols.map(|c| rec[c].as_str()).join("|");
            assert!(!m.contains_key(&key), "doubled {key}");
            m.insert(key, rec);
        }
        m
    }
}

/// Two unit tets sharing a face, as a tetrahedral `.off` file (CONVENTIONS §9).
pub const TWO_TETS: &str = "5 2\n0 0 0 0.5\n1 0 0 1\n0 1 0 2\n0 0 1 3\n1 1 1 4\n0 1 2 3\n1 2 3 4\n";

/// [`TWO_TETS`] written as `dir/two.off`: the mesh most command tests render.
pub fn two_tets_in(dir: &Path) -> PathBuf {
    let p = dir.join("two.off");
    std::fs::write(&p, TWO_TETS).unwrap();
    p
}
