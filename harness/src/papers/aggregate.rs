//! Aggregation of a table's measured rows: the mean over a (dataset, variant)'s views, and what
//! a table shows where measurements failed (a cell, a row, a note) rather than dropping them.

use crate::bench::Outcome;
use crate::rows::Row;
use crate::stats;

pub(crate) fn rows_of<'a>(o: &'a Outcome, dataset: &str, variant: &str) -> Vec<&'a Row> {
    o.rows
        .iter()
        .filter(|r| r.dataset == dataset && r.variant == variant && r.total_ms.is_finite())
        .collect()
}

/// Aggregates over a set of rows (views): mean frame time → fps, tet/s; mean error.
pub(crate) struct Agg {
    pub tets: usize,
    pub vertices: usize,
    pub ms: f64,
    pub fps: f64,
    pub tets_per_s: f64,
    pub sort_ms: f64,
    pub draw_ms: f64,
    pub rmse: f64,
    pub cpu_b: f64,
    pub gpu_b: f64,
    pub setup_ms: f64,
}

pub(crate) fn agg(rows: &[&Row]) -> Agg {
    let mean =
        |g: &dyn Fn(&Row) -> f64| stats::mean(&rows.iter().map(|r| g(r)).collect::<Vec<_>>());
    // The papers average over a rotating model: mean frame time over the views.
    let ms = mean(&|r| r.total_ms);
    let tets = rows.first().map(|r| r.tets).unwrap_or(0);
    Agg {
        tets,
        vertices: rows.first().map(|r| r.vertices).unwrap_or(0),
        ms,
        fps: 1e3 / ms,
        tets_per_s: tets as f64 / (ms * 1e-3),
        sort_ms: mean(&|r| r.sort_ms),
        draw_ms: mean(&|r| r.draw_ms),
        rmse: mean(&|r| r.rmse.unwrap_or(f64::NAN)),
        cpu_b: rows
            .first()
            .map(|r| r.cpu_bytes_per_tet)
            .unwrap_or(f64::NAN),
        gpu_b: rows
            .first()
            .map(|r| r.gpu_bytes_per_tet)
            .unwrap_or(f64::NAN),
        setup_ms: rows.first().map(|r| r.setup_ms).unwrap_or(f64::NAN),
    }
}

/// A table cell's source: the aggregate over a (dataset, variant)'s measured views, or the
/// failure that left it none (the sweep records a failed measurement as a row with its message,
/// and a table shows it as failed rather than as missing), or nothing at all.
pub(crate) enum Measured {
    Ok(Agg),
    Failed(String),
    Missing,
}

impl Measured {
    /// One value of the aggregate; "failed" or "—" without one.
    pub fn show(&self, value: impl Fn(&Agg) -> String) -> String {
        match self {
            Measured::Ok(a) => value(a),
            Measured::Failed(_) => "failed".into(),
            Measured::Missing => "—".into(),
        }
    }
}

/// The rows of (dataset, variant): measured, failed (with the first failure's message) or none.
pub(crate) fn measured(o: &Outcome, dataset: &str, variant: &str) -> Measured {
    let rs = rows_of(o, dataset, variant);
    if !rs.is_empty() {
        return Measured::Ok(agg(&rs));
    }
    match failure(o, |r| r.dataset == dataset && r.variant == variant) {
        Some(m) => Measured::Failed(m),
        None => Measured::Missing,
    }
}

/// "failed: <message>" when the rows `pick` selects are all failed measurements, for the first
/// measured column of a table row that has nothing else to show.
pub(crate) fn failure(o: &Outcome, pick: impl Fn(&Row) -> bool) -> Option<String> {
    let mut rows = o.rows.iter().filter(|r| pick(r)).peekable();
    rows.peek()?;
    let mut first = None;
    for r in rows {
        if !crate::sweep::failed(r) {
            return None;
        }
        first.get_or_insert(r);
    }
    first.map(|r| format!("failed: {}", one_line(&r.note, 100)))
}

/// The mesh sizes (vertices, tets) of (dataset, variant)'s rows, failed ones included.
pub(crate) fn sizes_of(o: &Outcome, dataset: &str, variant: &str) -> (usize, usize) {
    o.rows
        .iter()
        .find(|r| r.dataset == dataset && r.variant == variant)
        .map_or((0, 0), |r| (r.vertices, r.tets))
}

/// A row of `cols` cells for a measurement that failed: the message, then "—".
pub(crate) fn failed_cells(msg: String, cols: usize) -> Vec<String> {
    std::iter::once(msg)
        .chain(std::iter::repeat_n("—".to_string(), cols.saturating_sub(1)))
        .collect()
}

/// A message fit for one table cell: one line, no `|`, at most `max` characters.
fn one_line(s: &str, max: usize) -> String {
    let flat: String = s
        .chars()
        .map(|c| match c {
            '\n' | '\r' | '\t' => ' ',
            '|' => '/',
            c => c,
        })
        .collect();
    let flat = flat.trim();
    if flat.chars().count() <= max {
        flat.to_string()
    } else {
        format!("{}…", flat.chars().take(max).collect::<String>())
    }
}

/// The table note listing every failed measurement, grouped by dataset and variant (how many of
/// its views failed, and the first message); `None` when nothing failed.
pub(crate) fn failed_note(o: &Outcome) -> Option<String> {
    let mut groups: Vec<(String, String, usize, usize, String)> = Vec::new();
    for r in &o.rows {
        let i = match groups
            .iter()
            .position(|g| g.0 == r.dataset && g.1 == r.variant)
        {
            Some(i) => i,
            None => {
                groups.push((r.dataset.clone(), r.variant.clone(), 0, 0, String::new()));
                groups.len() - 1
            }
        };
        let g = &mut groups[i];
        g.3 += 1;
        if crate::sweep::failed(r) {
            g.2 += 1;
            if g.4.is_empty() {
                g.4 = one_line(&r.note, 200);
            }
        }
    }
    let failed: Vec<String> = groups
        .into_iter()
        .filter(|g| g.2 > 0)
        .map(|(d, v, k, n, m)| format!("{d} · {v}: {k} of {n} measurements failed ({m})"))
        .collect();
    (!failed.is_empty()).then(|| {
        format!(
            "**Failed measurements** (rows in `results.csv` with NaN times and the message in `note`; cells with no measured view say \"failed\", and means are over the measurements that did not fail): {}.",
            failed.join("; ")
        )
    })
}

pub(crate) fn variants(o: &Outcome) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in &o.rows {
        if !v.contains(&r.variant) {
            v.push(r.variant.clone());
        }
    }
    v
}

/// `*` matches any run of characters.
pub(crate) fn glob(pattern: &str, s: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == s,
        Some((head, rest)) => {
            if !s.starts_with(head) {
                return false;
            }
            let s = &s[head.len()..];
            (0..=s.len()).any(|i| s.is_char_boundary(i) && glob(rest, &s[i..]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(variant: &str, view: &str, ms: f64, note: &str) -> Row {
        Row {
            dataset: "d".into(),
            variant: variant.into(),
            view_id: view.into(),
            total_ms: ms,
            note: note.into(),
            tets: 10,
            ..Default::default()
        }
    }

    /// A cell whose every measurement failed shows the message; one with some failed views is
    /// the mean over the others; the note counts both, and a `|` cannot break the table.
    #[test]
    fn failed_measurements_are_shown_not_dropped() {
        let o = Outcome {
            rows: vec![
                row("a", "v0", f64::NAN, "device lost | twice"),
                row("a", "v1", f64::NAN, "device lost"),
                row("b", "v0", 4.0, ""),
                row("b", "v1", f64::NAN, "out of memory"),
            ],
            ..Default::default()
        };
        match measured(&o, "d", "a") {
            Measured::Failed(m) => assert_eq!(m, "failed: device lost / twice"),
            _ => panic!("a: every view failed"),
        }
        match measured(&o, "d", "b") {
            Measured::Ok(a) => assert_eq!(a.ms, 4.0),
            _ => panic!("b: one view measured"),
        }
        assert!(matches!(measured(&o, "d", "c"), Measured::Missing));
        assert_eq!(measured(&o, "d", "a").show(|a| a.ms.to_string()), "failed");
        let note = failed_note(&o).unwrap();
        assert!(
            note.contains("d · a: 2 of 2 measurements failed (device lost / twice)"),
            "{note}"
        );
        assert!(
            note.contains("d · b: 1 of 2 measurements failed (out of memory)"),
            "{note}"
        );
        assert_eq!(failed_cells("failed: x".into(), 3), ["failed: x", "—", "—"]);
        let ok = Outcome {
            rows: vec![row("b", "v0", 4.0, "")],
            ..Default::default()
        };
        assert!(failed_note(&ok).is_none());
    }

    #[test]
    fn glob_matches() {
        assert!(glob("cpu-pt/centroid/*", "cpu-pt/centroid/partial"));
        assert!(!glob("cpu-pt/centroid/*", "cpu-pt/centroid-radix/partial"));
        assert!(glob("ptint*", "ptint/partial"));
        assert!(glob("raycast/preint", "raycast/preint"));
    }
}
