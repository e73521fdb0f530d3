//! The papers' tables, one [`PaperTable`] each, one file per paper, listed once in [`TABLES`]:
//! adding a table is one `impl PaperTable` and one line there, and `tetbench reproduce`
//! (`--only`, the README index, the status lines) finds it.
//!
//! The experiment tables build their experiment from whatever renderers the registry holds, by
//! family (so a new projected-tetrahedra variant gets rows in every PT table with no change
//! here), and lay the measured rows out beside the paper's own figures.

use std::path::{Path, PathBuf};

use algorithms::Result;

use crate::bench::Outcome;
use crate::table::Table;

/// A [`PaperTable`] over an experiment: `table!(Type, id, title, about, experiment, build,
/// plots)` (see [`common::run_experiment`]).
macro_rules! table {
    ($ty:ident, $id:literal, $title:literal, $about:literal, $exp:ident, $build:ident, $plots:expr) => {
        #[doc = $title]
        pub struct $ty;

        impl PaperTable for $ty {
            fn id(&self) -> &'static str {
                $id
            }
            fn title(&self) -> &'static str {
                $title
            }
            fn about(&self) -> &'static str {
                $about
            }
            fn run(&self, ctx: &Ctx) -> Result<Done> {
                $crate::papers::common::run_experiment(self, ctx, $exp, $build, &$plots)
            }
            fn replot(
                &self,
                o: &$crate::bench::Outcome,
                dir: &std::path::Path,
            ) -> Result<Vec<std::path::PathBuf>> {
                ($plots)(o, dir)
            }
        }
    };
}

pub mod aggregate;
pub mod bcc;
pub mod bcc_reconstruction;
pub mod common;
pub mod hapt;
pub mod hapt_algorithms;
pub mod jbu;
pub mod ptint;

/// What a table is run with.
pub struct Ctx {
    /// Smaller meshes, fewer views, smaller images.
    pub quick: bool,
    /// The output directory (`DIR`): tables, plots, `raw/<id>/`, the shared `.cache/`.
    pub out: PathBuf,
    /// Whole, one shard of each experiment table, or the merge of shard directories.
    pub sweep: Sweep,
    /// Keep the raw rows already measured under `DIR/raw/<id>/` (an interrupted run) and
    /// measure only the missing ones; otherwise they are measured again.
    pub resume: bool,
    /// Failed measurements in the tables run so far (`reproduce` exits 3 when there are any).
    pub failed: std::cell::Cell<usize>,
}

/// How `reproduce` runs the experiment tables.
#[derive(Clone, Debug)]
pub enum Sweep {
    /// Every row here.
    Whole,
    /// `--shard I/N`: this shard of every table's rows, under `DIR/raw/<id>/`; no tables.
    Shard(crate::sweep::Shard),
    /// `--merge`: the rows of the shard directories' `raw/<id>/`, checked and merged, then
    /// the tables.
    Merge(Vec<PathBuf>),
}

impl Ctx {
    /// Adds the failed rows among `rows`, and those without their error, to [`Ctx::failed`].
    pub fn count_failed(&self, rows: &[crate::rows::Row]) {
        let n = rows
            .iter()
            .filter(|r| crate::sweep::failed(r) || crate::sweep::error_missing(r))
            .count();
        self.failed.set(self.failed.get() + n);
    }
}

/// What running a table gave.
pub enum Done {
    /// A table for `DIR/<id>.csv` and `DIR/<id>.md`, and the plots it drew.
    Table { table: Table, plots: Vec<PathBuf> },
    /// Files but no table (a shard's raw rows); the line says which (for the README).
    Files(String),
    /// Not run, and why (one line).
    Skipped(String),
}

/// One of the papers' tables or figures.
pub trait PaperTable: Sync {
    /// The id: `--only` name and file stem.
    fn id(&self) -> &'static str;
    /// The paper's caption, as the table's heading.
    fn title(&self) -> &'static str;
    /// What it measures and how to read it (for `DIR/README.md`).
    fn about(&self) -> &'static str;
    /// Measures it.
    fn run(&self, ctx: &Ctx) -> Result<Done>;
    /// Redraws its plots into `dir` from the raw rows of an earlier run (`DIR/raw/<id>/`);
    /// tables whose plots do not come from raw rows draw none.
    fn replot(&self, _rows: &Outcome, _dir: &Path) -> Result<Vec<PathBuf>> {
        Ok(Vec::new())
    }
}

/// Every table `reproduce` writes, in order.
pub static TABLES: &[&dyn PaperTable] = &[
    &ptint::Table1,
    &ptint::Table2,
    &ptint::Fig8,
    &hapt::Table1,
    &hapt::Table2,
    &hapt_algorithms::Table3,
    &hapt_algorithms::Table4,
    &jbu::Figures,
    &bcc::Pt,
    &bcc_reconstruction::Reconstruction,
];

/// The table with this id.
pub fn find(id: &str) -> Option<&'static dyn PaperTable> {
    TABLES.iter().copied().find(|t| t.id() == id)
}

/// The ids of every table.
pub fn ids() -> Vec<&'static str> {
    TABLES.iter().map(|t| t.id()).collect()
}

/// Redraws the plots of every table from what an earlier run wrote into `dir` (the raw rows
/// under `dir/raw/<id>/`, or the table itself).
pub fn replot_all(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for t in TABLES {
        let raw = dir.join("raw").join(t.id());
        let csv = raw.join("results.csv");
        let o = if csv.exists() {
            Outcome {
                rows: crate::rows::read_rows(&csv)?,
                pairs: crate::rows::read_pairs(&raw.join("pairs.csv"))?,
                ..Default::default()
            }
        } else {
            Outcome::default()
        };
        out.extend(t.replot(&o, dir)?);
    }
    Ok(out)
}
