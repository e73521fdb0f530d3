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
    pub note: String,
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

/// A CSV file written one row at a time, each row flushed as it is written.
pub struct CsvSink {
    path: PathBuf,
    w: csv::Writer<File>,
}

impl CsvSink {
    pub fn create(path: &Path) -> Result<CsvSink> {
        let f = File::create(path).map_err(|e| Error::io(path, e))?;
        Ok(CsvSink {
            path: path.to_path_buf(),
            w: csv::Writer::from_writer(f),
        })
    }

    pub fn write<T: Serialize>(&mut self, row: &T) -> Result<()> {
        let err = |e: &dyn std::fmt::Display| Error::Io(format!("{}: {e}", self.path.display()));
        self.w.serialize(row).map_err(|e| err(&e))?;
        self.w.flush().map_err(|e| err(&e))
    }
}

fn io_err(p: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io(format!("{}: {e}", p.display()))
}

/// Reads a `results.csv` back.
pub fn read_rows(path: &Path) -> Result<Vec<Row>> {
    let mut r = csv::Reader::from_path(path).map_err(|e| io_err(path, e))?;
    r.deserialize()
        .map(|x| x.map_err(|e| Error::Input(format!("{}: {e}", path.display()))))
        .collect()
}

/// Reads a `pairs.csv` back (empty when the file does not exist).
pub fn read_pairs(path: &Path) -> Result<Vec<PairRow>> {
    if !path.exists() {
        return Ok(Vec::new());
    }
    let mut r = csv::Reader::from_path(path).map_err(|e| io_err(path, e))?;
    r.deserialize()
        .map(|x| x.map_err(|e| Error::Input(format!("{}: {e}", path.display()))))
        .collect()
}
