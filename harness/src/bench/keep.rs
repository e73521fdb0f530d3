//! What a sweep keeps for its image figure: for one representative cell (a projection, size and
//! view), each variant's image exactly as it was measured (the last frame, whose error is the
//! row's) and the yardstick image it was compared with, under `DIR/figure/`:
//!
//! ```text
//! DIR/figure/cell.json                  the cell: projection, size, view
//! DIR/figure/<dataset>/<variant>.exr    each variant's measured image
//! DIR/figure/<dataset>/<variant>.json   which yardstick it was compared with, and its file
//! DIR/figure/<dataset>/ref-<hash>.exr   the yardstick images (named by their cache hash)
//! ```
//!
//! The image figure is drawn from these and the rows (the `report` module); it adds the PNGs the
//! HTML report shows at 1:1 beside them.

use std::path::{Path, PathBuf};

use algorithms::image::Image;
use algorithms::{Error, Result};
use serde::{Deserialize, Serialize};

/// The folder under a sweep's output directory.
pub const DIR: &str = "figure";
const CELL_FILE: &str = "cell.json";

/// The representative cell of a sweep's figure.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct KeptCell {
    pub projection: String,
    pub width: u32,
    pub height: u32,
    pub view_id: String,
    pub azimuth: f64,
    pub elevation: f64,
}

impl KeptCell {
    /// Whether `c` is this cell.
    pub fn is(&self, c: &super::Cell) -> bool {
        c.projection.name() == self.projection
            && c.size == (self.width, self.height)
            && c.view.id == self.view_id
    }

    /// Whether a measured row is of this cell.
    pub fn holds(&self, r: &crate::rows::Row) -> bool {
        r.projection == self.projection
            && (r.width, r.height) == (self.width, self.height)
            && r.view_id == self.view_id
    }

    /// How the cell reads in a caption.
    pub fn describe(&self) -> String {
        format!(
            "{}×{} {}, view {} (azimuth {:.1}°, elevation {:.1}°)",
            self.width, self.height, self.projection, self.view_id, self.azimuth, self.elevation
        )
    }

    /// Writes `DIR/figure/cell.json`.
    pub fn write(&self, out: &Path) -> Result<()> {
        let d = out.join(DIR);
        std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
        let p = d.join(CELL_FILE);
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Internal(format!("{}: {e}", p.display())))?;
        algorithms::io::atomic_write(&p, |w| std::io::Write::write_all(w, text.as_bytes()))
    }

    /// Reads `DIR/figure/cell.json`, if the sweep kept a figure.
    pub fn read(out: &Path) -> Result<Option<KeptCell>> {
        let p = out.join(DIR).join(CELL_FILE);
        if !p.exists() {
            return Ok(None);
        }
        let text =
            algorithms::io::read_input_string(&p, algorithms::io::files::MAX_SETTINGS_BYTES)?;
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| Error::Input(format!("{}: {e}", p.display())))
    }
}

/// The folder of one dataset's kept images.
pub fn dataset_dir(out: &Path, dataset: &str) -> PathBuf {
    out.join(DIR).join(super::sanitize(dataset))
}

/// A variant's kept image (`ext` "exr") or one of the report's PNGs of it (`ext` "png", or
/// "error.png" for its error map).
pub fn variant_file(out: &Path, dataset: &str, variant: &str, ext: &str) -> PathBuf {
    dataset_dir(out, dataset).join(format!("{}.{ext}", super::sanitize(variant)))
}

/// The yardstick a variant's kept image was compared with.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct Against {
    /// Its name in the `reference` column (`reference`, `analytic`, a renderer).
    pub yardstick: String,
    /// Its image, a file name in the dataset's folder.
    pub file: String,
}

impl Against {
    /// What a variant's kept image was compared with (None: no error was measured).
    pub fn read(out: &Path, dataset: &str, variant: &str) -> Option<Against> {
        let text = algorithms::io::read_input_string(
            &variant_file(out, dataset, variant, "json"),
            algorithms::io::files::MAX_SETTINGS_BYTES,
        )
        .ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// Keeps a variant's measured image and, when its error was measured, the yardstick image it
/// was compared with (`against`: the file and the yardstick's name; a copy, since the cache
/// may be shared, cleaned or elsewhere).
pub fn keep_image(
    out: &Path,
    dataset: &str,
    variant: &str,
    img: &Image,
    against: Option<(&Path, &str)>,
) -> Result<()> {
    let d = dataset_dir(out, dataset);
    std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
    img.write(&variant_file(out, dataset, variant, "exr"))?;
    let side = variant_file(out, dataset, variant, "json");
    let Some((yardstick, name)) = against else {
        let _ = std::fs::remove_file(&side);
        return Ok(());
    };
    let file = yardstick
        .file_name()
        .ok_or_else(|| Error::Internal(format!("{}: no file name", yardstick.display())))?
        .to_string_lossy()
        .to_string();
    let to = d.join(&file);
    if !to.exists() {
        let tmp = algorithms::io::files::temp_name(&to, None);
        std::fs::copy(yardstick, &tmp)
            .and_then(|_| std::fs::rename(&tmp, &to))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                Error::io(&to, e)
            })?;
    }
    let text = serde_json::to_string(&Against {
        yardstick: name.to_string(),
        file,
    })
    .map_err(|e| Error::Internal(format!("{}: {e}", side.display())))?;
    algorithms::io::atomic_write(&side, |w| std::io::Write::write_all(w, text.as_bytes()))
}

/// Copies the kept images of shard directories into `out` (the merge of a sharded sweep: each
/// shard kept the cells it measured).
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<()> {
    for s in shards {
        let from = s.join(DIR);
        if !from.is_dir() {
            continue;
        }
        copy_tree(&from, &out.join(DIR))?;
    }
    Ok(())
}

fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to).map_err(|e| Error::io(to, e))?;
    for entry in std::fs::read_dir(from).map_err(|e| Error::io(from, e))? {
        let entry = entry.map_err(|e| Error::io(from, e))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if src.is_dir() {
            copy_tree(&src, &dst)?;
        } else if src.extension().is_some_and(|e| e == "exr" || e == "json") {
            // Opened as every input is (a named pipe there would block a plain copy).
            let mut f = algorithms::io::open_input(&src)?;
            algorithms::io::atomic_write(&dst, |w| std::io::copy(&mut f, w).map(|_| ()))?;
        }
    }
    Ok(())
}
