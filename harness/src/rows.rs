//! Measured rows and their CSV files: `results.csv` (one [`Row`] per measurement) and
//! `pairs.csv` (one [`PairRow`] per image-against-image comparison), written row by row and
//! flushed, so an interrupted run keeps what it measured.

use std::fs::File;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};
use serde::{Deserialize, Serialize};

/// One measurement: the columns of CONVENTIONS §6–§8 and a few more.
#[derive(Serialize, Deserialize, Debug, Clone, Default)]
pub struct Row {
    pub dataset: String,
    pub tets: usize,
    pub vertices: usize,
    pub renderer: String,
    pub sort: String,
    pub integrator: String,
    pub variant: String,
    pub width: u32,
    pub height: u32,
    pub view_id: String,
    pub azimuth: f64,
    pub elevation: f64,
    pub projection: String,
    pub tf: String,
    pub repeats: usize,
    pub warmup: usize,
    pub threads: usize,
    pub device: String,
    pub setup_ms: f64,
    pub project_ms: f64,
    pub sort_ms: f64,
    pub draw_ms: f64,
    pub readback_ms: f64,
    pub total_ms: f64,
    pub total_min_ms: f64,
    /// Median wall-clock time of one `render` call as the harness sees it: for a peer, the
    /// whole request (transfers included) beside its own stage times.
    #[serde(default)]
    pub wall_ms: f64,
    pub fps: f64,
    pub tets_per_s: f64,
    pub cpu_bytes_per_tet: f64,
    pub cpu_peak_bytes_per_tet: f64,
    pub gpu_bytes_per_tet: f64,
    pub rmse: Option<f64>,
    pub psnr: Option<f64>,
    pub max_abs: Option<f64>,
    pub diff_pixels_pct: Option<f64>,
    pub max_err_pct: Option<f64>,
    pub avg_err_pct: Option<f64>,
    pub non_finite_pixels: usize,
    /// What the error columns are measured against: `reference` (the exact renderer), another
    /// renderer's name, `analytic` or `analytic-box` (see `experiment::Yardstick`); empty
    /// without errors.
    #[serde(default)]
    pub reference: String,
    /// The renderer's counters of the last measured frame, `name=value;...` (e.g. a `jbu:`
    /// wrapper's `low_ms`, `depth_ms`, `filter_ms`; `tets_skipped`).
    #[serde(default)]
    pub counters: String,
    /// The last measured image's content hash: equal hashes mean bit-identical images.
    #[serde(default)]
    pub image_hash: String,
    pub note: String,
}

impl Row {
    /// The counter `name` of [`Row::counters`], if the renderer reported it.
    pub fn counter(&self, name: &str) -> Option<f64> {
        self.counters
            .split(';')
            .filter_map(|kv| kv.split_once('='))
            .find(|(k, _)| *k == name)
            .and_then(|(_, v)| v.parse().ok())
    }
}

/// Counters as the `counters` column writes them.
pub fn format_counters(counters: &[(&str, f64)]) -> String {
    counters
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// One image-against-image comparison of two variants (`DIR/pairs.csv`).
#[derive(Serialize, Deserialize, Debug, Clone, Default)]
pub struct PairRow {
    pub dataset: String,
    pub tets: usize,
    pub test: String,
    pub reference: String,
    pub width: u32,
    pub height: u32,
    pub view_id: String,
    pub azimuth: f64,
    pub elevation: f64,
    pub projection: String,
    pub rmse: f64,
    pub psnr: f64,
    pub max_abs: f64,
    pub diff_pixels_pct: f64,
    pub max_err_pct: f64,
    pub avg_err_pct: f64,
}

/// A CSV file written one complete row at a time: each row is formatted in memory and appended
/// with one write; if that write fails (a full disk), the file is cut back to its last complete
/// row, so a reader never sees a torn line. The error names the file.
pub struct CsvSink {
    path: PathBuf,
    f: File,
    len: u64,
    header: bool,
}

impl CsvSink {
    /// A new, empty file (the header is written with the first row).
    pub fn create(path: &Path) -> Result<CsvSink> {
        let f = File::create(path).map_err(|e| Error::io(path, e))?;
        Ok(CsvSink {
            path: path.to_path_buf(),
            f,
            len: 0,
            header: true,
        })
    }

    /// Appends to an existing file of complete rows (a resumed run); a header is written only
    /// when the file is empty.
    pub fn append(path: &Path) -> Result<CsvSink> {
        let f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
        Ok(CsvSink {
            path: path.to_path_buf(),
            f,
            len,
            header: len == 0,
        })
    }

    pub fn write<T: Serialize>(&mut self, row: &T) -> Result<()> {
        let err = |e: &dyn std::fmt::Display| Error::Io(format!("{}: {e}", self.path.display()));
        let bytes = safe_record(row, self.header).map_err(|e| err(&e))?;
        use std::io::Write;
        if let Err(e) = self.f.write_all(&bytes).and_then(|_| self.f.flush()) {
            // Rows whole or not at all: cut back what part of this one reached the file.
            let _ = self.f.set_len(self.len);
            return Err(err(&e));
        }
        self.len += bytes.len() as u64;
        self.header = false;
        Ok(())
    }
}

/// Whether a text cell would start a formula in a spreadsheet: it begins with `=`, `+`, `-`,
/// `@`, a tab or a carriage return (OWASP's CSV-injection list), after any leading `'`s (so
/// that the escape below can be undone exactly).
fn formula_like(s: &str) -> bool {
    s.trim_start_matches('\'')
        .starts_with(['=', '+', '-', '@', '\t', '\r'])
}

/// Whether a cell is a number (`-1.5`, `NaN`, `-inf`, `12%`): numbers are written as they are.
fn numeric(s: &str) -> bool {
    s.strip_suffix('%').unwrap_or(s).parse::<f64>().is_ok()
}

/// A cell as tetbench writes it into a CSV file: a text cell that a spreadsheet would run as a
/// formula gets a leading `'`, as the CSV-injection guidance says; numbers never do.
/// [`cell_from_csv`] undoes it.
pub fn cell_to_csv(s: &str) -> std::borrow::Cow<'_, str> {
    if !numeric(s) && formula_like(s) {
        format!("'{s}").into()
    } else {
        s.into()
    }
}

/// A cell as it was before [`cell_to_csv`].
pub fn cell_from_csv(s: &str) -> &str {
    match s.strip_prefix('\'') {
        Some(rest) if !numeric(rest) && formula_like(rest) => rest,
        _ => s,
    }
}

/// One serialised row (with the header line first when `header`), every text cell passed
/// through [`cell_to_csv`].
fn safe_record<T: Serialize>(row: &T, header: bool) -> std::result::Result<Vec<u8>, String> {
    let mut w = csv::WriterBuilder::new()
        .has_headers(header)
        .from_writer(Vec::new());
    w.serialize(row).map_err(|e| e.to_string())?;
    let raw = w.into_inner().map_err(|e| e.error().to_string())?;
    let mut r = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(raw.as_slice());
    let mut out = csv::Writer::from_writer(Vec::new());
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| e.to_string())?;
        if header && i == 0 {
            out.write_record(&rec)
        } else {
            out.write_record(rec.iter().map(|c| cell_to_csv(c).into_owned()))
        }
        .map_err(|e| e.to_string())?;
    }
    out.into_inner().map_err(|e| e.error().to_string())
}

/// The longest line a tetbench CSV file holds (a row with its longest note is a few KiB): a
/// longer one is a file that is not ours, or one that never ends a record.
pub const MAX_CSV_LINE: usize = 1 << 20;

/// Reads a CSV file of rows written by [`CsvSink`] (regular files only, lines bounded, cells
/// as [`cell_from_csv`] gives them back).
fn read_csv<T: serde::de::DeserializeOwned>(path: &Path) -> Result<Vec<T>> {
    let f = algorithms::io::open_input(path)?;
    let bounded = algorithms::io::files::BoundedLines::new(f, MAX_CSV_LINE);
    let bad = |e: csv::Error| Error::Input(format!("{}: {e}", path.display()));
    let mut r = csv::Reader::from_reader(bounded);
    let headers = r.headers().map_err(bad)?.clone();
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(bad)?;
        let rec: csv::StringRecord = rec.iter().map(cell_from_csv).collect();
        out.push(rec.deserialize(Some(&headers)).map_err(bad)?);
    }
    Ok(out)
}

/// Reads a `results.csv` back.
pub fn read_rows(path: &Path) -> Result<Vec<Row>> {
    read_csv(path)
}

/// Reads a `pairs.csv` back (empty when the file does not exist).
pub fn read_pairs(path: &Path) -> Result<Vec<PairRow>> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    read_csv(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_disk_gives_one_line_naming_the_file_and_no_torn_row() {
        // /dev/full refuses every write with ENOSPC.
        let p = Path::new("/dev/full");
        if !p.exists() {
            return;
        }
        let mut w = CsvSink::create(p).unwrap();
        let e = w.write(&Row::default()).unwrap_err().to_string();
        assert!(e.starts_with("/dev/full: ") && !e.contains('\n'), "{e}");
        assert!(e.to_lowercase().contains("space"), "{e}");
        // A real file: whole rows, appended, a header only once.
        let d = std::env::temp_dir().join(format!("tetbench-rows-{}.csv", std::process::id()));
        let _ = std::fs::remove_file(&d);
        CsvSink::create(&d).unwrap().write(&Row::default()).unwrap();
        CsvSink::append(&d).unwrap().write(&Row::default()).unwrap();
        let text = std::fs::read_to_string(&d).unwrap();
        assert_eq!(text.lines().count(), 3);
        assert!(text.ends_with('\n'));
        assert_eq!(read_rows(&d).unwrap().len(), 2);
        let _ = std::fs::remove_file(&d);
    }

    /// Text cells that a spreadsheet would run as formulas are written with a leading `'`;
    /// numbers (negative ones too) are not; reading gives every cell back as it was.
    #[test]
    fn formula_like_text_is_escaped_and_read_back_unchanged() {
        let d = std::env::temp_dir().join(format!("tetbench-inject-{}.csv", std::process::id()));
        let texts = [
            "=HYPERLINK(\"http://x\")",
            "+1+1",
            "-2+3",
            "@SUM(A1)",
            "\tx",
            "'=x",
            "''@y",
            "'plain",
            "plain",
        ];
        let mut w = CsvSink::create(&d).unwrap();
        for t in texts {
            let row = Row {
                dataset: t.into(),
                note: t.into(),
                azimuth: -30.5,
                total_ms: f64::NAN,
                psnr: Some(f64::NEG_INFINITY),
                ..Default::default()
            };
            w.write(&row).unwrap();
        }
        let raw = std::fs::read_to_string(&d).unwrap();
        let mut r = csv::Reader::from_path(&d).unwrap();
        let h = r.headers().unwrap().clone();
        let col = |n: &str| h.iter().position(|x| x == n).unwrap();
        for rec in r.records() {
            let rec = rec.unwrap();
            for c in ["dataset", "note"] {
                let v = &rec[col(c)];
                assert!(!formula_like(v) || v.starts_with('\''), "{v} in {raw}");
            }
            assert_eq!(&rec[col("azimuth")], "-30.5");
            assert_eq!(&rec[col("psnr")], "-inf");
        }
        let back = read_rows(&d).unwrap();
        let got: Vec<&str> = back.iter().map(|r| r.dataset.as_str()).collect();
        assert_eq!(got, texts);
        assert!(back
            .iter()
            .all(|r| r.note == r.dataset && r.azimuth == -30.5));
        let _ = std::fs::remove_file(&d);
    }
}
