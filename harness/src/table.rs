//! Paper tables and number formatting: a [`Table`] is written as `DIR/<id>.csv` and
//! `DIR/<id>.md`; the formatters give every table and every `name: value` line the same
//! numbers ("—" where there is no value).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};

/// A finished table: header, rows, which columns depend on the hardware, notes.
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub id: String,
    pub title: String,
    pub columns: Vec<String>,
    /// Parallel to `columns`: true where the value depends on the machine (times, rates).
    pub hardware: Vec<bool>,
    pub rows: Vec<Vec<String>>,
    pub notes: Vec<String>,
}

impl Table {
    pub fn col(&mut self, name: &str, hw: bool) {
        self.columns.push(name.to_string());
        self.hardware.push(hw);
    }
}

/// Writes `DIR/<id>.csv` and `DIR/<id>.md`.
pub fn write_table(t: &Table, dir: &Path, machine: &str, date: &str) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let csvp = dir.join(format!("{}.csv", t.id));
    let mut w =
        csv::Writer::from_path(&csvp).map_err(|e| Error::Io(format!("{}: {e}", csvp.display())))?;
    let werr = |e: csv::Error| Error::Io(format!("{}: {e}", csvp.display()));
    w.write_record(&t.columns).map_err(werr)?;
    for r in &t.rows {
        w.write_record(r.iter().map(|c| crate::rows::cell_to_csv(c).into_owned()))
            .map_err(werr)?;
    }
    w.flush().map_err(|e| Error::io(&csvp, e))?;

    let mut md = String::new();
    let _ = writeln!(md, "# {}\n", t.title);
    let _ = writeln!(md, "- machine: {machine}");
    let _ = writeln!(md, "- date: {date}");
    let _ = writeln!(
        md,
        "- columns marked † depend on the hardware (times and rates); the others (sizes, errors, bytes) do not.\n"
    );
    let head: Vec<String> = t
        .columns
        .iter()
        .zip(&t.hardware)
        .map(|(c, &h)| if h { format!("{c} †") } else { c.clone() })
        .collect();
    let _ = writeln!(md, "| {} |", head.join(" | "));
    let _ = writeln!(md, "|{}", " --- |".repeat(head.len()));
    for r in &t.rows {
        let _ = writeln!(md, "| {} |", r.join(" | "));
    }
    if !t.notes.is_empty() {
        md.push('\n');
        for n in &t.notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    let mdp = dir.join(format!("{}.md", t.id));
    std::fs::write(&mdp, md).map_err(|e| Error::io(&mdp, e))
}

/// Links each PNG plot from the table's notes.
pub fn plot_notes(table: &mut Table, plots: &[PathBuf]) {
    for p in plots {
        if p.extension().is_some_and(|e| e == "png") {
            if let Some(n) = p.file_name() {
                table
                    .notes
                    .push(format!("Plot: ![{0}]({0})", n.to_string_lossy()));
            }
        }
    }
}

/// A fixed-point number with `digits` decimals; "—" for a missing (non-finite) value.
pub fn fixed(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        "—".into()
    }
}

/// A number in exponent notation with `digits` decimals (`1.234e-3`); "—" when missing.
pub fn sci(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$e}")
    } else {
        "—".into()
    }
}

/// A count in thousands or millions, as the papers print sizes: `13.0 K`, `1.40 M`.
pub fn count(n: usize) -> String {
    if n >= 1_000_000 {
        format!("{:.2} M", n as f64 / 1e6)
    } else {
        format!("{:.1} K", n as f64 / 1e3)
    }
}

/// A float for `name: value` lines: integers without a fraction, plain decimals in the usual
/// range, exponent notation for the very small and very large.
pub fn plain(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let a = v.abs();
    if v == v.trunc() && a < 1e15 {
        format!("{}", v as i64)
    } else if (1e-4..1e15).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(fixed(1.23456, 2), "1.23");
        assert_eq!(fixed(f64::NAN, 2), "—");
        assert_eq!(sci(0.00123, 2), "1.23e-3");
        assert_eq!(count(13_000), "13.0 K");
        assert_eq!(count(1_400_000), "1.40 M");
        assert_eq!(plain(3.0), "3");
        assert_eq!(plain(0.5), "0.5");
        assert_eq!(plain(1e-7), "1e-7");
    }
}
