//! Running an experiment: every dataset × variant × projection × size × view, timed by
//! [`crate::measure`], with its memory and its error against the cached reference image. Rows
//! go to `DIR/results.csv` as they finish (flushed), so an interrupted run keeps what it measured.
//!
//! The loop is split so that each piece can be reused (by a sharded or resumed sweep, say):
//! [`preflight`] checks everything before the first frame, [`Prepared::new`] sets one variant up
//! on one mesh, and [`measure_cell`] measures one cell (variant × projection × size × view)
//! into one [`Row`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use algorithms::camera::Camera;
use algorithms::image::Image;
use algorithms::render::{self, RenderOptions, Renderer};
use algorithms::{metrics, Error, Mesh, Result, TransferFunction};
use indicatif::ProgressBar;

use crate::experiment::{Experiment, Variant};
use crate::measure;
use crate::meshes::{self, Source};
use crate::progress;
use crate::rows::{CsvSink, PairRow, Row};
use crate::sweep::{self, Lock, Shard, ShardInfo};

mod cell;
mod images;
pub mod keep;
mod yardsticks;
pub use crate::experiment::sanitize;
pub use cell::{
    cells, isolated, measure_cell, measure_cell_interleaved, Cell, Prepared, RefImage,
    TEST_PANIC_ENV,
};
use images::{compare_pairs, image_stem, save_images};
pub use images::{image_hash, mesh_hash};
use yardsticks::{ref_path, references};

/// Where the peers' logs (their stderr) go in the output directory, one file per peer.
pub const PEER_LOGS: &str = "peer-logs";

/// What a run produced.
#[derive(Debug, Default)]
pub struct Outcome {
    pub rows: Vec<Row>,
    pub pairs: Vec<PairRow>,
    pub interrupted: bool,
    /// Reference images rendered (cache misses) and read from the cache (hits).
    pub reference_renders: usize,
    pub reference_hits: usize,
    /// With `interleave`: every frame in the order it was rendered (also `DIR/order.csv`).
    pub order: Vec<OrderRow>,
}

/// One frame of an interleaved measurement, as `DIR/order.csv` lists them: which variant of
/// which cell, warm-up or measured, and in which round (0-based in each kind).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OrderRow {
    pub dataset: String,
    pub variant: String,
    pub projection: String,
    pub size: String,
    pub view: String,
    pub warmup: bool,
    pub round: usize,
}

/// How to run: output directory, cache and progress display.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub out: PathBuf,
    pub cache_dir: PathBuf,
    pub progress: bool,
    /// Label in front of the progress bar.
    pub title: String,
    /// Print a line for each variant left out of a dataset (`max_tets`); `reproduce` turns it
    /// off (its tables' notes say so, and it prints one line per table).
    pub log: bool,
    /// The part of the measurement matrix this run measures.
    pub shard: Shard,
    /// Measure only the rows not yet in `results.csv`.
    pub resume: bool,
    /// Start again in a directory that already holds results (they are removed).
    pub force: bool,
    /// The experiment's identity (blake3 of its file) written to `shard.txt`, checked by
    /// `merge` and `--resume`.
    pub identity: String,
}

impl RunOptions {
    pub fn new(exp: &Experiment, out: &Path) -> RunOptions {
        let cache_dir = match &exp.cache_dir {
            Some(c) if c.is_absolute() => c.clone(),
            Some(c) => out.join(c),
            None => out.join(".cache"),
        };
        RunOptions {
            out: out.to_path_buf(),
            cache_dir,
            progress: true,
            title: exp.name.clone(),
            log: true,
            shard: Shard::ALL,
            resume: false,
            force: false,
            identity: format!("experiment {}", exp.name),
        }
    }
}

/// Checks what can fail before the first frame: the output directory can be written, every
/// dataset can be found (a NASA grid's file is present), every variant can be made. One line
/// naming what is wrong.
pub fn preflight(exp: &Experiment, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let probe = out.join(".tetbench-write-test");
    std::fs::write(&probe, b"").map_err(|e| {
        Error::Input(format!(
            "output directory {}: not writable ({e})",
            out.display()
        ))
    })?;
    let _ = std::fs::remove_file(&probe);
    for ds in &exp.datasets {
        let what = |e: Error| match e {
            Error::Input(m) => Error::Input(format!("dataset '{}': {m}", ds.display_name())),
            o => o,
        };
        let spec = ds.mesh_spec(&exp.base_dir, exp.seed).map_err(what)?;
        if spec.lattice.is_some() {
            continue;
        }
        if let Source::Nasa(n) = meshes::resolve(&spec.mesh, Path::new(".")).map_err(what)? {
            if let Some(Err(e)) = algorithms::io::resolve_short_name(n) {
                return Err(what(e));
            }
        }
    }
    // An `optional` variant that cannot be made here is measured as failed rows instead.
    for v in exp.variants.iter().filter(|v| v.unavailable.is_none()) {
        render::make(&v.renderer, &v.options)
            .map_err(|e| Error::Input(format!("variant '{}': {e}", v.label)))?;
    }
    // What each peer will run, before the first frame.
    announce_peers(
        exp.variants
            .iter()
            .filter(|v| v.unavailable.is_none())
            .map(|v| v.renderer.as_str()),
    );
    Ok(())
}

/// Prints, once each, the command line of every peer among `renderers` (before the first
/// frame, so that the user sees what will run). Once a process: `reproduce` runs many
/// experiments with the same peers.
pub fn announce_peers<'a>(renderers: impl IntoIterator<Item = &'a str>) {
    for name in renderers {
        if !first_announcement(name) {
            continue;
        }
        if let Some(Ok(spec)) = render::peer::spec_of(name) {
            let dir = match &spec.launch.cwd {
                Some(d) => d.display().to_string(),
                None => "its private directory".to_string(),
            };
            eprintln!(
                "tetbench: peer '{name}' runs `{}` in {dir} (timeout {} s a request)",
                spec.launch.command_line(),
                spec.timeout.as_secs_f64()
            );
        }
    }
}

/// Whether `name` is announced for the first time in this process.
fn first_announcement(name: &str) -> bool {
    static DONE: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut done = DONE.lock().unwrap_or_else(|e| e.into_inner());
    if done.iter().any(|n| n == name) {
        return false;
    }
    done.push(name.to_string());
    true
}

/// Opens `results.csv` for this run: refuses a directory holding results unless resumed or
/// forced, checks a resumed one is this experiment's (and shard's), cuts a torn last line.
/// Returns the sink and the rows already measured.
fn open_results(exp: &Experiment, opts: &RunOptions) -> Result<(CsvSink, Vec<Row>)> {
    let csv_path = opts.out.join("results.csv");
    let has_rows = std::fs::metadata(&csv_path).is_ok_and(|m| m.len() > 0);
    let has_images = opts.out.join("images").exists();
    if opts.resume {
        if !exp.pairs.is_empty() {
            return Err(Error::Input(
                "--resume: experiments with [[pairs]] cannot be resumed yet (pair images are kept only while a dataset runs); run them again with --force".into(),
            ));
        }
        if has_rows {
            let here = ShardInfo::read(&opts.out)?;
            match here {
                Some(i) if i.experiment == opts.identity && i.shard == opts.shard => {}
                Some(i) if i.experiment == opts.identity => {
                    return Err(Error::Input(format!(
                        "--resume: {} holds shard {}, not {}",
                        opts.out.display(),
                        i.shard,
                        opts.shard
                    )))
                }
                _ => {
                    return Err(Error::Input(format!(
                        "--resume: {} is from another experiment (or another experiment file version); refusing to mix them",
                        csv_path.display()
                    )))
                }
            }
        }
        let (rows, note) = sweep::existing_rows(&csv_path)?;
        if let Some(n) = note {
            eprintln!("tetbench: note: {n}");
        }
        return Ok((CsvSink::append(&csv_path)?, rows));
    }
    if (has_rows || has_images) && !opts.force {
        return Err(Error::Input(format!(
            "{} already holds results ({}); pass --resume to measure only the missing rows, or --force to discard them and start again",
            opts.out.display(),
            if has_rows { "results.csv" } else { "images/" }
        )));
    }
    if opts.force {
        for f in ["results.csv", "pairs.csv", sweep::SHARD_FILE] {
            let _ = std::fs::remove_file(opts.out.join(f));
        }
        let _ = std::fs::remove_dir_all(opts.out.join("images"));
        let _ = std::fs::remove_dir_all(opts.out.join(keep::DIR));
    }
    let _ = std::fs::remove_dir_all(opts.out.join(yardsticks::RUN_DIR));
    Ok((CsvSink::create(&csv_path)?, Vec::new()))
}

/// Runs the experiment (this run's shard of it), writing `results.csv` (and `pairs.csv` when
/// pairs are asked for) and `shard.txt`.
pub fn run(exp: &Experiment, opts: &RunOptions) -> Result<Outcome> {
    if opts.shard.count > 1 && !exp.pairs.is_empty() {
        return Err(Error::Input(
            "--shard: experiments with [[pairs]] cannot be sharded yet (both images of a pair must be measured in one run)".into(),
        ));
    }
    preflight(exp, &opts.out)?;
    let _lock = Lock::take(&opts.out)?;
    sweep::clean_stale_tmp(&opts.out);
    if opts.cache_dir.exists() && !opts.cache_dir.starts_with(&opts.out) {
        sweep::clean_stale_tmp(&opts.cache_dir);
    }
    let (mut csv, done_rows) = open_results(exp, opts)?;
    let done = sweep::keys(&done_rows);
    let mut pair_csv = if exp.pairs.is_empty() {
        None
    } else {
        Some(CsvSink::create(&opts.out.join("pairs.csv"))?)
    };
    write_meta(exp, opts)?;
    let mut info = ShardInfo {
        experiment: opts.identity.clone(),
        shard: opts.shard,
        version: env!("CARGO_PKG_VERSION").to_string(),
        rows: None,
        keys: None,
    };
    info.write(&opts.out)?;

    let cells = cells(exp);
    // The image figure's cell: its images are kept as measured (`keep`).
    let figure = figure_cell(&cells);
    if let Some(c) = &figure {
        c.write(&opts.out)?;
    }
    let refs = if exp.error {
        cells.len() * yardsticks::kinds(exp)
    } else {
        0
    };
    let total = exp.datasets.len() * (exp.variants.len() * cells.len() + refs);
    let total = total.div_ceil(opts.shard.count);
    let bar = progress::bar(opts.progress, total as u64, &opts.title);

    let mut out = Outcome::default();
    // Every row key of the sweep, and this shard's (for `shard.txt`, which `merge` checks).
    let (mut mine, mut all) = (Vec::new(), Vec::new());
    let mut loads = vec![0.0; opts.shard.count];
    out.rows = done_rows;
    // Warm the thread pool so its allocations are not counted as a renderer's.
    rayon::broadcast(|_| ());

    'datasets: for ds in &exp.datasets {
        let name = ds.display_name();
        bar.set_message(format!("loading {name}"));
        let named = |e| match e {
            Error::Input(m) => Error::Input(format!("dataset '{name}': {m}")),
            o => o,
        };
        let spec = ds.mesh_spec(&exp.base_dir, exp.seed).map_err(named)?;
        let mesh = meshes::load_mesh(&spec).map_err(named)?;
        let lattice = spec.lattice.as_ref();
        let frame = lattice.map_or_else(|| mesh.bbox(), |l| l.frame(&mesh));
        let hash = mesh_hash(&mesh);
        // The units of this dataset (variant × cell), their shards and whether measured.
        let kept: Vec<usize> = (0..exp.variants.len())
            .filter(|&v| exp.variants[v].runs_on(&name, mesh.num_tets()))
            .collect();
        let frames = (exp.warmup + exp.repeats.max(1)) as f64;
        let costs: Vec<f64> = kept
            .iter()
            .flat_map(|_| cells.iter())
            .map(|c| mesh.num_tets() as f64 * c.size.0 as f64 * c.size.1 as f64 * frames)
            .collect();
        let owner = sweep::assign(&costs, &mut loads);
        let is_mine = |k: usize, c: usize| owner[k * cells.len() + c] == opts.shard.index;
        let key_of = |v: usize, c: &Cell| {
            sweep::cell_key(
                &name,
                &exp.variants[v].label,
                c.projection.name(),
                c.size,
                &c.view.id,
            )
        };
        for (k, &v) in kept.iter().enumerate() {
            for (c, cell) in cells.iter().enumerate() {
                let key = key_of(v, cell);
                if is_mine(k, c) {
                    mine.push(key.clone());
                }
                all.push(key);
            }
        }
        // A cell needs its reference when some unit of it is this shard's and not yet measured.
        let todo =
            |k: usize, c: usize| is_mine(k, c) && !done.contains(&key_of(kept[k], &cells[c]));
        let mut ref_failed = BTreeMap::new();
        if exp.error {
            let need: Vec<(usize, Vec<usize>)> = (0..kept.len())
                .map(|k| (kept[k], (0..cells.len()).filter(|&c| todo(k, c)).collect()))
                .collect();
            // Yardstick images first, so they never interleave with a measured renderer.
            let done = references(
                exp,
                opts,
                &mesh,
                &hash,
                lattice,
                &frame,
                &cells,
                &need,
                &bar,
                &name,
                &mut out,
                &mut ref_failed,
            )?;
            if !done {
                break 'datasets;
            }
        }
        // A variant's yardstick image of a cell, or why there is none.
        let ref_of = |var: &Variant, cell: &Cell| -> Option<(PathBuf, Option<String>)> {
            exp.error.then(|| {
                let p = ref_path(opts, &hash, var, lattice, cell);
                let why = ref_failed.get(&p).cloned();
                (p, why)
            })
        };
        let pair_labels: BTreeSet<&str> = exp
            .pairs
            .iter()
            .flat_map(|p| [p.test.as_str(), p.reference.as_str()])
            .collect();
        let pair_dir = opts.out.join(".pairs");
        // What is done with each measured row: its images, its pair image, the CSV.
        let emit = |var: &Variant,
                    cell: &Cell,
                    row: Row,
                    image: Option<Image>,
                    csv: &mut CsvSink,
                    out: &mut Outcome|
         -> Result<()> {
            if let Some(img) = &image {
                let reference = ref_of(var, cell).filter(|r| r.1.is_none()).map(|r| r.0);
                if figure.as_ref().is_some_and(|f| f.is(cell)) {
                    let yardstick = var.yardstick.label();
                    let against = reference.as_deref().map(|p| (p, yardstick.as_str()));
                    keep::keep_image(&opts.out, &name, &var.label, img, against)?;
                }
                save_images(exp, opts, var, &name, cell, img, reference.as_deref())?;
                if pair_labels.contains(var.label.as_str()) {
                    let d = pair_dir.join(sanitize(&var.label));
                    std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
                    img.write(&d.join(format!("{}.exr", image_stem(&var.label, cell))))?;
                }
            }
            csv.write(&row)?;
            out.rows.push(row);
            bar.inc(1);
            Ok(())
        };
        let mut prepared = Vec::new();
        for (vi, var) in exp.variants.iter().enumerate() {
            if !var.runs_on(&name, mesh.num_tets()) {
                // Left out by its `datasets`: nothing to say; by its `max_tets`: said.
                if !var.runs_on(&name, 0) {
                    continue;
                }
                progress::note(
                    &bar,
                    &format!(
                        "{name}: {} left out ({} tets > max_tets {})",
                        var.label,
                        mesh.num_tets(),
                        var.max_tets.unwrap_or(0)
                    ),
                );
                continue;
            }
            let k = kept.iter().position(|&x| x == vi).unwrap_or(0);
            if !(0..cells.len()).any(|c| todo(k, c)) {
                continue;
            }
            bar.set_message(format!("{name}: {} setup", var.label));
            let mut p = Prepared::new(
                exp,
                var,
                &name,
                &mesh,
                frame,
                Some(&opts.out.join(PEER_LOGS)),
            )?;
            if exp.interleave {
                // Measured below, cell by cell, with the other variants.
                prepared.push((var, k, p));
                continue;
            }
            for (ci, cell) in cells.iter().enumerate() {
                if !todo(k, ci) {
                    continue;
                }
                if measure::interrupted() {
                    out.interrupted = true;
                    break 'datasets;
                }
                let (w, h) = cell.size;
                bar.set_message(format!("{name}: {} {w}x{h} {}", var.label, cell.view.id));
                let reference = ref_of(var, cell);
                let (row, image) = measure_cell(exp, &mut p, cell, as_ref_image(&reference))?;
                emit(var, cell, row, image, &mut csv, &mut out)?;
            }
        }
        // `interleave`: every variant prepared above, each cell measured in rounds A B C ….
        for (ci, cell) in cells.iter().enumerate() {
            let mut group: Vec<(&Variant, &mut Prepared)> = prepared
                .iter_mut()
                .filter(|(_, k, _)| todo(*k, ci))
                .map(|(v, _, p)| (*v, p))
                .collect();
            if group.is_empty() {
                continue;
            }
            if measure::interrupted() {
                out.interrupted = true;
                break 'datasets;
            }
            let (w, h) = cell.size;
            bar.set_message(format!(
                "{name}: {} variants interleaved, {w}x{h} {}",
                group.len(),
                cell.view.id
            ));
            let refs: Vec<_> = group.iter().map(|(v, _)| ref_of(v, cell)).collect();
            let refs: Vec<Option<RefImage>> = refs.iter().map(as_ref_image).collect();
            let mut ps: Vec<&mut Prepared> = group.iter_mut().map(|(_, p)| &mut **p).collect();
            let rows = measure_cell_interleaved(exp, &mut ps, cell, &refs, |v, t| {
                out.order.push(OrderRow {
                    dataset: name.clone(),
                    variant: v.to_string(),
                    projection: cell.projection.name().to_string(),
                    size: format!("{w}x{h}"),
                    view: cell.view.id.clone(),
                    warmup: t.warmup,
                    round: t.round,
                })
            })?;
            for ((var, _), (row, image)) in group.iter().zip(rows) {
                emit(var, cell, row, image, &mut csv, &mut out)?;
            }
        }
        drop(prepared);
        // Pairs: image against image, after every variant of this dataset has run.
        for row in compare_pairs(exp, &cells, &pair_dir, &name, mesh.num_tets()) {
            if let Some(w) = pair_csv.as_mut() {
                w.write(&row)?;
            }
            out.pairs.push(row);
        }
        let _ = std::fs::remove_dir_all(&pair_dir);
    }
    bar.finish_and_clear();
    if !out.interrupted {
        let _ = std::fs::remove_dir_all(opts.out.join(yardsticks::RUN_DIR));
    }
    if exp.interleave {
        write_order(&opts.out.join("order.csv"), &out.order)?;
    }
    if !out.interrupted {
        info.rows = Some((mine.len(), all.len()));
        info.keys = Some((sweep::keys_hash(&mine), sweep::keys_hash(&all)));
        info.write(&opts.out)?;
    }
    Ok(out)
}

/// A yardstick file, or why there is none, as [`measure_cell`] takes it.
fn as_ref_image(r: &Option<(PathBuf, Option<String>)>) -> Option<RefImage<'_>> {
    r.as_ref().map(|(p, why)| match why {
        Some(w) => Err(w.as_str()),
        None => Ok(p.as_path()),
    })
}

/// The cell whose images the figure shows: the first projection and view at the largest size
/// up to 512² (else the smallest size).
fn figure_cell(cells: &[Cell]) -> Option<keep::KeptCell> {
    let first = cells.first()?;
    let px = |c: &Cell| c.size.0 as u64 * c.size.1 as u64;
    let size = cells
        .iter()
        .filter(|c| px(c) <= 512 * 512)
        .max_by_key(|c| px(c))
        .or_else(|| cells.iter().min_by_key(|c| px(c)))?
        .size;
    Some(keep::KeptCell {
        projection: first.projection.name().to_string(),
        width: size.0,
        height: size.1,
        view_id: first.view.id.clone(),
        azimuth: first.view.view.azimuth,
        elevation: first.view.view.elevation,
    })
}

/// Writes the frame order of an interleaved run.
fn write_order(p: &Path, order: &[OrderRow]) -> Result<()> {
    let mut w = CsvSink::create(p)?;
    for r in order {
        w.write(r)?;
    }
    Ok(())
}

fn write_meta(exp: &Experiment, opts: &RunOptions) -> Result<()> {
    let p = opts.out.join("meta.txt");
    let text = format!(
        "experiment: {}\ndate: {}\nmachine: {}\nthreads: {}\ntf: {}\nrepeats: {}\nwarmup: {}\ninterleave: {}\nvariants: {}\nshared_fixed_bytes: {} (the shared Ψ table; not in cpu_bytes_per_tet)\n",
        exp.name,
        crate::sysinfo::now_utc(),
        crate::sysinfo::machine(),
        rayon::current_num_threads(),
        exp.tf_name,
        exp.repeats,
        exp.warmup,
        exp.interleave,
        exp.variants
            .iter()
            .map(|v| v.label.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        crate::measure::shared_fixed_bytes(),
    );
    algorithms::io::atomic_write(&p, |w| std::io::Write::write_all(w, text.as_bytes()))
}

#[cfg(test)]
mod tests {
    #[test]
    fn each_peer_is_announced_once_a_process() {
        assert!(super::first_announcement("announce-test-a"));
        assert!(!super::first_announcement("announce-test-a"));
        assert!(super::first_announcement("announce-test-b"));
    }
}
