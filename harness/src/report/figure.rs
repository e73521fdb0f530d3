//! The image figure of a sweep (`<table>-images.png` and `.svg`), laid out like a paper's
//! figure: one column per dataset, the exact `reference` in the first row, then one row per
//! variant with its render over a checkerboard and, under it, its error map against the
//! reference in false colour on one logarithmic colour bar shared by the figure, and the RMSE of
//! the row under each cell. A failed row is a failed cell that says why; a variant not run on
//! a dataset (`max_tets`) is an empty cell that says so.
//!
//! Everything comes from what the sweep kept ([`crate::bench::keep`]): the images as measured
//! and the reference they were compared with, so the figure shows what the table measured. Beside
//! the kept EXRs it writes the PNGs the HTML report flips between at 1:1.

use std::path::{Path, PathBuf};

use algorithms::image::Image;
use algorithms::{Error, Result};
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use super::grid::{Layout, Page};
use super::pixels::{self, LogScale, Rgb, Scale};
use crate::bench::keep::{self, KeptCell};
use crate::rows::Row;

/// A clickable cell of the figure, for the report's viewer: its rectangle in figure pixels and
/// the 1:1 PNGs (paths relative to the figure's folder).
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Hit {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
    pub dataset: String,
    pub variant: String,
    pub image: String,
    pub reference: Option<String>,
    pub error: Option<String>,
    pub rmse: Option<f64>,
}

/// A drawn figure.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Figure {
    /// File names of the PNG and SVG, in the figure's folder.
    pub png: String,
    pub svg: String,
    pub width: u32,
    pub height: u32,
    /// What the figure shows (the cell, the background, the scale), one line.
    pub caption: String,
    /// The error maps' colour scale, lowest and highest error.
    pub scale: [f64; 2],
    pub hits: Vec<Hit>,
}

/// What one cell of the grid holds.
pub(super) enum Content {
    Ok {
        render: Rgb,
        error: Option<Rgb>,
        rmse: Option<f64>,
        /// The yardstick it was compared with, when not the first row's.
        versus: Option<String>,
    },
    /// Failed (the row's message) or not run (why).
    Empty { what: &'static str, why: String },
}

pub(super) struct Column {
    pub(super) label: String,
    pub(super) tets: usize,
    pub(super) reference: Option<Rgb>,
}

/// Draws `STEM.png` and `STEM.svg` from the rows of a sweep and the images it kept under
/// `data` (its output directory), writing the report's 1:1 PNGs beside the kept images. None
/// when the sweep kept no images (an older run, or no rows).
///
/// Each variant's error map is against the yardstick its row was measured with. The first row
/// shows, per dataset, the exact reference when some variant was compared with it, else the
/// yardstick most variants were; a cell compared with another one says so under its RMSE.
pub fn draw(rows: &[Row], data: &Path, stem: &Path, title: &str) -> Result<Option<Figure>> {
    let Some(cell) = KeptCell::read(data)? else {
        return Ok(None);
    };
    let datasets = uniq(rows.iter().map(|r| r.dataset.as_str()));
    let variants = uniq(rows.iter().map(|r| r.variant.as_str()));
    if datasets.is_empty() || variants.is_empty() {
        return Ok(None);
    }
    let find = |d: &str, v: &str| {
        rows.iter()
            .find(|r| r.dataset == d && r.variant == v && cell.holds(r))
    };
    let read = |p: PathBuf| -> Result<Option<Image>> {
        if p.exists() {
            Image::read(&p).map(Some)
        } else {
            Ok(None)
        }
    };
    // What each measured cell was compared with, and each dataset's first-row yardstick.
    let against = |d: &str, v: &str| {
        find(d, v)
            .filter(|r| !crate::sweep::failed(r))
            .and_then(|_| keep::Against::read(data, d, v))
    };
    let first_row: Vec<Option<keep::Against>> = datasets
        .iter()
        .map(|d| {
            let all: Vec<keep::Against> = variants.iter().filter_map(|v| against(d, v)).collect();
            all.iter()
                .find(|a| a.yardstick == "reference")
                .or_else(|| {
                    all.iter()
                        .max_by_key(|a| all.iter().filter(|b| b.file == a.file).count())
                })
                .cloned()
        })
        .collect();

    // First pass: the largest error of any map, for the shared scale.
    let mut max_err = 0f64;
    for d in &datasets {
        for v in &variants {
            let Some(a) = against(d, v) else { continue };
            let img = read(keep::variant_file(data, d, v, "exr"))?;
            let yard = read(keep::dataset_dir(data, d).join(&a.file))?;
            if let (Some(img), Some(yard)) = (img, yard) {
                if let Some(e) = pixels::error_map(&img, &yard) {
                    let m = e
                        .iter()
                        .filter(|x| x.is_finite())
                        .fold(0f32, |a, &b| a.max(b));
                    max_err = max_err.max(m as f64);
                }
            }
        }
    }
    let scale = LogScale::for_max(max_err);
    let side = cell.width.max(cell.height);
    let target = match variants.len() {
        0..=8 => 256,
        9..=12 => 192,
        _ => 160,
    };
    let factor = Scale::to_fit(side, target);
    let folder = stem.parent().unwrap_or(Path::new("."));
    let rel = |p: &Path| -> String {
        p.strip_prefix(folder)
            .unwrap_or(p)
            .to_string_lossy()
            .replace('\\', "/")
    };

    // Second pass: the 1:1 PNGs and the figure's cells.
    let mut columns = Vec::new();
    let mut grid: Vec<Vec<Content>> = variants.iter().map(|_| Vec::new()).collect();
    // The viewer's cells, placed once the layout is known.
    let mut links: Vec<Vec<Option<Hit>>> = variants.iter().map(|_| Vec::new()).collect();
    for (di, d) in datasets.iter().enumerate() {
        // The dataset's yardstick images (few: most variants share one), and their 1:1 PNGs.
        let mut yards: Vec<(String, Image, String)> = Vec::new();
        let mut yard = |file: &str| -> Result<Option<(Image, String)>> {
            if let Some(y) = yards.iter().find(|y| y.0 == file) {
                return Ok(Some((y.1.clone(), y.2.clone())));
            }
            let p = keep::dataset_dir(data, d).join(file);
            let Some(img) = read(p.clone())? else {
                return Ok(None);
            };
            let png = p.with_extension("png");
            write_rgb(&pixels::over_checkerboard(&img, Scale::Up(1)), &png)?;
            yards.push((file.to_string(), img.clone(), rel(&png)));
            Ok(Some((img, rel(&png))))
        };
        let top = match &first_row[di] {
            Some(a) => yard(&a.file)?,
            None => None,
        };
        columns.push(Column {
            label: d.to_string(),
            tets: rows.iter().find(|r| r.dataset == *d).map_or(0, |r| r.tets),
            reference: top
                .as_ref()
                .map(|(r, _)| pixels::over_checkerboard(r, factor)),
        });
        for (vi, v) in variants.iter().enumerate() {
            let row = find(d, v);
            let (content, link) = match row {
                None => (
                    Content::Empty {
                        what: "not run",
                        why: not_run_reason(rows, d, v),
                    },
                    None,
                ),
                Some(r) if crate::sweep::failed(r) => (
                    Content::Empty {
                        what: "failed",
                        why: r.note.clone(),
                    },
                    None,
                ),
                Some(r) => match read(keep::variant_file(data, d, v, "exr"))? {
                    None => (
                        Content::Empty {
                            what: "no image",
                            why: "the sweep kept no image of this cell (an older run)".into(),
                        },
                        None,
                    ),
                    Some(img) => {
                        let png = keep::variant_file(data, d, v, "png");
                        write_rgb(&pixels::over_checkerboard(&img, Scale::Up(1)), &png)?;
                        let a = against(d, v);
                        let y = match &a {
                            Some(a) => yard(&a.file)?,
                            None => None,
                        };
                        let mut err_link = None;
                        let error = match y.as_ref().and_then(|(re, _)| {
                            pixels::error_map(&img, re).map(|e| (e, re.width, re.height))
                        }) {
                            Some((e, w, h)) => {
                                let p = keep::variant_file(data, d, v, "error.png");
                                let idx = pixels::error_indices(&e, &scale);
                                pixels::write_png(&p, (w, h), &idx, Some(pixels::palette()))?;
                                err_link = Some(rel(&p));
                                Some(pixels::false_colour(&e, w, h, factor, &scale))
                            }
                            None => None,
                        };
                        // Compared with another yardstick than the first row's: say which.
                        let versus = a
                            .as_ref()
                            .filter(|a| first_row[di].as_ref().is_none_or(|f| f.file != a.file))
                            .map(|a| a.yardstick.clone());
                        (
                            Content::Ok {
                                render: pixels::over_checkerboard(&img, factor),
                                error,
                                rmse: r.rmse,
                                versus,
                            },
                            Some(Hit {
                                x: 0,
                                y: 0,
                                w: 0,
                                h: 0,
                                dataset: d.to_string(),
                                variant: v.to_string(),
                                image: rel(&png),
                                reference: y.map(|(_, link)| link),
                                error: err_link,
                                rmse: r.rmse,
                            }),
                        )
                    }
                },
            };
            grid[vi].push(content);
            links[vi].push(link);
        }
    }
    // The first row's name: the yardstick's, when every dataset's is the same one.
    let names: Vec<&str> = first_row
        .iter()
        .flatten()
        .map(|a| a.yardstick.as_str())
        .collect();
    let first_label = match names.first() {
        Some(n) if names.iter().all(|m| m == n) => match *n {
            "reference" => ("reference".to_string(), "(exact)".to_string()),
            "analytic" | "analytic-box" => (n.to_string(), "(ground truth)".to_string()),
            other => (other.to_string(), "(yardstick)".to_string()),
        },
        _ => ("yardstick".to_string(), String::new()),
    };

    let caption = format!(
        "{}; renders over a checkerboard ({}/{} grey, linear like the PNGs, no gamma); error maps: per-pixel RMS error over RGB against each row's yardstick, log scale {} to {} (black: exact)",
        cell.describe(),
        pixels::CHECKER[0],
        pixels::CHECKER[1],
        sci(scale.lo),
        sci(scale.hi)
    );
    let layout = Layout::new(
        factor.apply(cell.width),
        factor.apply(cell.height),
        &columns,
        &variants,
        (title, &caption),
    );
    let png = PathBuf::from(format!("{}.png", stem.display()));
    let svg = PathBuf::from(format!("{}.svg", stem.display()));
    let page = Page {
        title,
        first_label: &first_label,
        caption: &caption,
        columns: &columns,
        variants: &variants,
        grid: &grid,
        scale: &scale,
        layout: &layout,
    };
    atomic_draw(&png, |p| {
        let root = BitMapBackend::new(p, (layout.width, layout.height)).into_drawing_area();
        page.draw(&root)
    })?;
    atomic_draw(&svg, |p| {
        let root = SVGBackend::new(p, (layout.width, layout.height)).into_drawing_area();
        page.draw(&root)
    })?;

    let mut hits = Vec::new();
    for (vi, row) in links.into_iter().enumerate() {
        for (di, hit) in row.into_iter().enumerate() {
            if let Some(mut hit) = hit {
                (hit.x, hit.y) = layout.cell(vi, di);
                (hit.w, hit.h) = (layout.cw, 2 * layout.ch + layout.gap);
                hits.push(hit);
            }
        }
    }
    let name = |p: &Path| {
        p.file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string()
    };
    Ok(Some(Figure {
        png: name(&png),
        svg: name(&svg),
        width: layout.width,
        height: layout.height,
        caption,
        scale: [scale.lo, scale.hi],
        hits,
    }))
}

/// Why a variant has no row on a dataset: left out by its `max_tets` (the only way a sweep
/// skips a unit), or not measured in this run.
fn not_run_reason(rows: &[Row], dataset: &str, variant: &str) -> String {
    let tets = rows
        .iter()
        .find(|r| r.dataset == dataset)
        .map_or(0, |r| r.tets);
    let largest_run = rows
        .iter()
        .filter(|r| r.variant == variant)
        .map(|r| r.tets)
        .max();
    match largest_run {
        Some(m) if m < tets => format!("left out on meshes this size ({tets} tets)"),
        _ => "not measured in this run".into(),
    }
}

fn uniq<'a>(it: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut v: Vec<&str> = Vec::new();
    for s in it {
        if !v.contains(&s) {
            v.push(s);
        }
    }
    v
}

fn sci(v: f64) -> String {
    format!("1e{}", v.log10().round() as i32)
}

/// Writes an RGB picture as an 8-bit PNG (through a temporary file).
fn write_rgb(rgb: &Rgb, path: &Path) -> Result<()> {
    pixels::write_png(path, (rgb.width, rgb.height), &rgb.data, None)
}

/// Draws into a hidden temporary sibling and renames it into place: a failure (a full disk)
/// never leaves a cut figure.
fn atomic_draw(
    path: &Path,
    draw: impl FnOnce(&Path) -> std::result::Result<(), Box<dyn std::error::Error>>,
) -> Result<()> {
    // The extension kept last: the plotting backend picks the format by it.
    let ext = path.extension().unwrap_or_default().to_string_lossy();
    let tmp = algorithms::io::files::temp_name(path, Some(&ext));
    let r = draw(&tmp)
        .map_err(|e| Error::Io(format!("{}: {e}", path.display())))
        .and_then(|_| std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)));
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}
