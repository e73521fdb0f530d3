//! What a run leaves to look at, beside its tables and plots: the image figure of each table or
//! sweep ([`figure`]: renders, error maps, RMSE) and the offline HTML report `index.html`
//! ([`html`]) that holds every table, plot and figure with a 1:1 image viewer.

pub mod figure;
mod grid;
pub mod html;
pub mod pixels;

use std::path::{Path, PathBuf};

use algorithms::Result;

use crate::rows::Row;
use crate::stats::{mean, median};
use crate::table::{fixed, sci, Table};

/// The figure of a `bench` or `merge` output directory: `DIR/results-images.png` and `.svg`
/// (beside `results.csv`, whose representative cell it shows).
pub const SWEEP_FIGURE: &str = "results-images";

/// After `tetbench bench` or `merge`: draws the image figure and writes `DIR/index.html` with
/// the summary of `rows`, the plots and the figure. Returns the files written.
pub fn sweep(dir: &Path, rows: &[Row], plots: &[PathBuf], command: &str) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let figure = figure::draw(rows, dir, &dir.join(SWEEP_FIGURE), "Renders and error maps")?;
    if let Some(f) = &figure {
        written.push(dir.join(&f.png));
        written.push(dir.join(&f.svg));
    }
    let section = html::Section {
        id: "results".into(),
        title: "Results".into(),
        about: "One row per dataset and variant: medians over its cells (views, sizes, projections) of `results.csv`, which has every measurement.".into(),
        status: format!("{} measurements", rows.len()),
        figure,
        files: ["results.csv", "pairs.csv", "meta.txt"]
            .iter()
            .filter(|f| dir.join(f).exists())
            .map(|f| f.to_string())
            .collect(),
        ..Default::default()
    }
    .with_table(&summary(rows))
    .with_plots(plots, dir)
    .with_failures(rows);
    let report = html::Report {
        title: command.to_string(),
        facts: facts(),
        sections: vec![section],
    };
    written.push(html::write(&report, dir)?);
    Ok(written)
}

/// The machine, the date and the threads, as the report's header says them.
pub fn facts() -> Vec<(String, String)> {
    vec![
        ("machine".into(), crate::sysinfo::machine()),
        ("date".into(), crate::sysinfo::now_utc()),
        ("threads".into(), rayon::current_num_threads().to_string()),
        ("tetbench".into(), env!("CARGO_PKG_VERSION").to_string()),
    ]
}

/// One row per (dataset, variant) of a sweep: medians over its measured cells.
pub fn summary(rows: &[Row]) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("dataset", false),
        ("tets", false),
        ("variant", false),
        ("cells", false),
        ("ms/frame", true),
        ("fps", true),
        ("M tet/s", true),
        ("RMSE", false),
        ("CPU B/tet", false),
        ("GPU B/tet", false),
        ("setup ms", true),
        ("failed", false),
    ] {
        t.col(c, hw);
    }
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !keys.contains(&(&r.dataset, &r.variant)) {
            keys.push((&r.dataset, &r.variant));
        }
    }
    for (d, v) in keys {
        let all: Vec<&Row> = rows
            .iter()
            .filter(|r| r.dataset == d && r.variant == v)
            .collect();
        let ok: Vec<&Row> = all
            .iter()
            .copied()
            .filter(|r| !crate::sweep::failed(r))
            .collect();
        let med = |f: fn(&Row) -> f64| median(&ok.iter().map(|r| f(r)).collect::<Vec<_>>());
        let errs: Vec<f64> = ok.iter().filter_map(|r| r.rmse).collect();
        let failed = all.len() - ok.len();
        t.rows.push(vec![
            d.to_string(),
            all[0].tets.to_string(),
            v.to_string(),
            all.len().to_string(),
            fixed(med(|r| r.total_ms), 2),
            fixed(med(|r| r.fps), 2),
            fixed(med(|r| r.tets_per_s) / 1e6, 3),
            if errs.is_empty() {
                "—".into()
            } else {
                sci(mean(&errs), 2)
            },
            fixed(med(|r| r.cpu_bytes_per_tet), 1),
            fixed(med(|r| r.gpu_bytes_per_tet), 1),
            fixed(med(|r| r.setup_ms), 0),
            if failed == 0 {
                "0".into()
            } else {
                format!("failed: {failed}")
            },
        ]);
    }
    t
}
