//! Running an experiment: every dataset × variant × projection × size × view, timed (median of
//! the repeats after warm-up frames), with its memory and its error against the cached reference
//! image. Rows are written to `DIR/results.csv` as they finish and flushed, so an interrupted run
//! keeps what it measured.

use std::collections::BTreeSet;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use algorithms::camera::{Camera, Projection};
use algorithms::image::Image;
use algorithms::render::{self, FrameTimes, RenderOptions};
use algorithms::{alloc, metrics, Error, Mesh, Result, TransferFunction};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};

use crate::experiment::Experiment;

/// Set by the Ctrl-C handler; the runner stops at the next frame boundary.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Bumped when the reference renderer's output changes, so old cache entries are not reused.
const REFERENCE_VERSION: &str = "reference-exact-v1";

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

/// What a run produced.
#[derive(Debug, Default)]
pub struct Outcome {
    pub rows: Vec<Row>,
    pub pairs: Vec<PairRow>,
    pub interrupted: bool,
    /// Reference images rendered (cache misses) and read from the cache (hits).
    pub reference_renders: usize,
    pub reference_hits: usize,
}

/// How to run: output directory, cache and progress display.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub out: PathBuf,
    pub cache_dir: PathBuf,
    pub progress: bool,
    /// Label in front of the progress bar.
    pub title: String,
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
        }
    }
}

fn io_err(p: &Path, e: impl std::fmt::Display) -> Error {
    Error::Io(format!("{}: {e}", p.display()))
}

/// Runs the experiment, writing `results.csv` (and `pairs.csv` when pairs are asked for).
pub fn run(exp: &Experiment, opts: &RunOptions) -> Result<Outcome> {
    std::fs::create_dir_all(&opts.out).map_err(|e| io_err(&opts.out, e))?;
    let csv_path = opts.out.join("results.csv");
    let file = File::create(&csv_path).map_err(|e| io_err(&csv_path, e))?;
    let mut csv = csv::Writer::from_writer(file);
    let mut pair_csv = if exp.pairs.is_empty() {
        None
    } else {
        let p = opts.out.join("pairs.csv");
        Some(csv::Writer::from_writer(
            File::create(&p).map_err(|e| io_err(&p, e))?,
        ))
    };
    write_meta(exp, opts)?;

    let per_ds_refs = if exp.error {
        exp.projections.len() * exp.sizes.len() * exp.views.len()
    } else {
        0
    };
    let per_ds = exp.variants.len() * exp.projections.len() * exp.sizes.len() * exp.views.len();
    let total = exp.datasets.len() * (per_ds + per_ds_refs);
    let bar = if opts.progress {
        ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] [{bar:30}] {pos}/{len} ETA {eta} {msg}",
        )
        .unwrap()
        .progress_chars("=> "),
    );
    bar.set_prefix(opts.title.clone());

    let mut out = Outcome::default();
    let threads = rayon::current_num_threads();
    // Warm the thread pool so its allocations are not counted as a renderer's.
    rayon::broadcast(|_| ());

    'datasets: for ds in &exp.datasets {
        let name = ds.display_name();
        bar.set_message(format!("loading {name}"));
        let mesh = crate::commands::load_mesh(&ds.mesh_args(&exp.base_dir, exp.seed)).map_err(
            |e| match e {
                Error::Input(m) => Error::Input(format!("dataset '{name}': {m}")),
                o => o,
            },
        )?;
        let mesh_hash = mesh_hash(&mesh);
        let tets = mesh.num_tets();

        // Reference images first, so they never interleave with a measured renderer.
        let mut reference = None;
        if exp.error {
            for &proj in &exp.projections {
                for &(w, h) in &exp.sizes {
                    for v in &exp.views {
                        if INTERRUPTED.load(Ordering::Relaxed) {
                            out.interrupted = true;
                            break 'datasets;
                        }
                        bar.set_message(format!("{name}: reference {w}x{h} {}", v.id));
                        let p = ref_path(opts, &mesh_hash, exp, proj, w, h, v.view);
                        if p.exists() {
                            out.reference_hits += 1;
                        } else {
                            if reference.is_none() {
                                let mut r = render::make("reference", &RenderOptions::default())?;
                                r.prepare(&mesh, &exp.tf)?;
                                reference = Some(r);
                            }
                            let cam = Camera::new(&mesh.bbox(), v.view, proj, w, h);
                            let f = reference.as_mut().unwrap().render(&mesh, &cam)?;
                            std::fs::create_dir_all(&opts.cache_dir)
                                .map_err(|e| io_err(&opts.cache_dir, e))?;
                            f.image.write(&p)?;
                            out.reference_renders += 1;
                        }
                        bar.inc(1);
                    }
                }
            }
        }
        drop(reference);

        let pair_labels: BTreeSet<&str> = exp
            .pairs
            .iter()
            .flat_map(|p| [p.test.as_str(), p.reference.as_str()])
            .collect();
        let pair_dir = opts.out.join(".pairs");

        for var in &exp.variants {
            if var.max_tets.is_some_and(|m| tets > m) {
                bar.println(format!(
                    "{name}: {} left out ({tets} tets > max_tets {})",
                    var.label,
                    var.max_tets.unwrap_or(0)
                ));
                continue;
            }
            bar.set_message(format!("{name}: {} setup", var.label));
            let mut renderer = render::make(&var.renderer, &var.options)?;
            // A fresh clone has empty caches: derived data the renderer needs is counted.
            let fresh = mesh.clone();
            let t0 = Instant::now();
            let (prep, bytes, peak) = alloc::measure(|| renderer.prepare(&fresh, &exp.tf));
            let setup_ms = t0.elapsed().as_secs_f64() * 1e3;
            let counting = alloc::is_counting();
            let base = Row {
                dataset: name.clone(),
                tets,
                vertices: mesh.num_vertices(),
                renderer: var.renderer.clone(),
                sort: var.sort.clone(),
                integrator: var.integrator.clone(),
                variant: var.label.clone(),
                tf: exp.tf_name.clone(),
                repeats: exp.repeats,
                warmup: exp.warmup,
                threads,
                device: renderer.device(),
                setup_ms,
                cpu_bytes_per_tet: if counting {
                    bytes as f64 / tets as f64
                } else {
                    f64::NAN
                },
                cpu_peak_bytes_per_tet: if counting {
                    peak as f64 / tets as f64
                } else {
                    f64::NAN
                },
                gpu_bytes_per_tet: renderer.gpu_bytes() as f64 / tets as f64,
                ..Default::default()
            };
            for &proj in &exp.projections {
                for &(w, h) in &exp.sizes {
                    for v in &exp.views {
                        if INTERRUPTED.load(Ordering::Relaxed) {
                            out.interrupted = true;
                            break 'datasets;
                        }
                        bar.set_message(format!("{name}: {} {w}x{h} {}", var.label, v.id));
                        let mut row = base.clone();
                        row.width = w;
                        row.height = h;
                        row.view_id = v.id.clone();
                        row.azimuth = v.view.azimuth;
                        row.elevation = v.view.elevation;
                        row.projection = proj.name().to_string();
                        let result = match &prep {
                            Err(e) => Err(Error::Input(format!("prepare: {e}"))),
                            Ok(()) => {
                                let cam = Camera::new(&fresh.bbox(), v.view, proj, w, h);
                                measure_frames(renderer.as_mut(), &fresh, &cam, exp)
                            }
                        };
                        match result {
                            Err(e) => {
                                for t in [
                                    &mut row.project_ms,
                                    &mut row.sort_ms,
                                    &mut row.draw_ms,
                                    &mut row.readback_ms,
                                    &mut row.total_ms,
                                    &mut row.total_min_ms,
                                    &mut row.fps,
                                    &mut row.tets_per_s,
                                ] {
                                    *t = f64::NAN;
                                }
                                row.note = e.to_string().replace(['\n', '\r'], " ");
                            }
                            Ok((img, t, tmin)) => {
                                row.project_ms = t.project_ms;
                                row.sort_ms = t.sort_ms;
                                row.draw_ms = t.draw_ms;
                                row.readback_ms = t.readback_ms;
                                row.total_ms = t.total_ms;
                                row.total_min_ms = tmin;
                                row.fps = 1e3 / t.total_ms.max(1e-9);
                                row.tets_per_s = tets as f64 / (t.total_ms.max(1e-9) * 1e-3);
                                row.non_finite_pixels = img.non_finite_pixels();
                                if exp.error {
                                    let p = ref_path(opts, &mesh_hash, exp, proj, w, h, v.view);
                                    let r = Image::read(&p)?;
                                    match metrics::compare(&img, &r) {
                                        Ok(m) => {
                                            row.rmse = Some(m.rmse);
                                            row.psnr = Some(m.psnr);
                                            row.max_abs = Some(m.max_abs);
                                            row.diff_pixels_pct = Some(m.diff_pixels_pct);
                                            row.max_err_pct = Some(m.max_err_pct);
                                            row.avg_err_pct = Some(m.avg_err_pct);
                                        }
                                        Err(e) => row.note = format!("compare: {e}"),
                                    }
                                }
                                let stem = image_stem(&var.label, proj, w, h, &v.id);
                                if exp.save_images {
                                    let dir = opts.out.join("images").join(sanitize(&name));
                                    std::fs::create_dir_all(&dir).map_err(|e| io_err(&dir, e))?;
                                    img.write(&dir.join(format!("{stem}.exr")))?;
                                    img.write(&dir.join(format!("{stem}.png")))?;
                                    if exp.error {
                                        let p = ref_path(opts, &mesh_hash, exp, proj, w, h, v.view);
                                        let rs = image_stem("reference-cached", proj, w, h, &v.id);
                                        let rp = dir.join(format!("{rs}.png"));
                                        if !rp.exists() {
                                            Image::read(&p)?.write(&rp)?;
                                        }
                                    }
                                }
                                if pair_labels.contains(var.label.as_str()) {
                                    let d = pair_dir.join(sanitize(&var.label));
                                    std::fs::create_dir_all(&d).map_err(|e| io_err(&d, e))?;
                                    img.write(&d.join(format!("{stem}.exr")))?;
                                }
                            }
                        }
                        csv.serialize(&row).map_err(|e| io_err(&csv_path, e))?;
                        csv.flush().map_err(|e| io_err(&csv_path, e))?;
                        out.rows.push(row);
                        bar.inc(1);
                    }
                }
            }
        }

        // Pairs: image against image, after every variant of this dataset has run.
        for p in &exp.pairs {
            for &proj in &exp.projections {
                for &(w, h) in &exp.sizes {
                    for v in &exp.views {
                        let a = pair_dir
                            .join(sanitize(&p.test))
                            .join(format!("{}.exr", image_stem(&p.test, proj, w, h, &v.id)));
                        let b = pair_dir.join(sanitize(&p.reference)).join(format!(
                            "{}.exr",
                            image_stem(&p.reference, proj, w, h, &v.id)
                        ));
                        let (Ok(ia), Ok(ib)) = (Image::read(&a), Image::read(&b)) else {
                            continue;
                        };
                        let Ok(m) = metrics::compare(&ia, &ib) else {
                            continue;
                        };
                        let row = PairRow {
                            dataset: name.clone(),
                            tets,
                            test: p.test.clone(),
                            reference: p.reference.clone(),
                            width: w,
                            height: h,
                            view_id: v.id.clone(),
                            azimuth: v.view.azimuth,
                            elevation: v.view.elevation,
                            projection: proj.name().to_string(),
                            rmse: m.rmse,
                            psnr: m.psnr,
                            max_abs: m.max_abs,
                            diff_pixels_pct: m.diff_pixels_pct,
                            max_err_pct: m.max_err_pct,
                            avg_err_pct: m.avg_err_pct,
                        };
                        if let Some(w) = pair_csv.as_mut() {
                            let pp = opts.out.join("pairs.csv");
                            w.serialize(&row).map_err(|e| io_err(&pp, e))?;
                            w.flush().map_err(|e| io_err(&pp, e))?;
                        }
                        out.pairs.push(row);
                    }
                }
            }
        }
        let _ = std::fs::remove_dir_all(&pair_dir);
    }
    bar.finish_and_clear();
    Ok(out)
}

/// Warm-up frames, then `repeats` measured frames: the last image, the median of each stage,
/// and the fastest total.
fn measure_frames(
    r: &mut dyn render::Renderer,
    mesh: &Mesh,
    cam: &Camera,
    exp: &Experiment,
) -> Result<(Image, FrameTimes, f64)> {
    for _ in 0..exp.warmup {
        r.render(mesh, cam)?;
    }
    let mut times = Vec::with_capacity(exp.repeats);
    let mut last = None;
    for _ in 0..exp.repeats {
        let f = r.render(mesh, cam)?;
        times.push(f.times);
        last = Some(f.image);
        if INTERRUPTED.load(Ordering::Relaxed) {
            break;
        }
    }
    let med = |g: fn(&FrameTimes) -> f64| median(times.iter().map(g).collect());
    let t = FrameTimes {
        project_ms: med(|t| t.project_ms),
        sort_ms: med(|t| t.sort_ms),
        draw_ms: med(|t| t.draw_ms),
        readback_ms: med(|t| t.readback_ms),
        total_ms: med(|t| t.total_ms),
    };
    let tmin = times
        .iter()
        .map(|t| t.total_ms)
        .fold(f64::INFINITY, f64::min);
    Ok((last.expect("repeats >= 1"), t, tmin))
}

/// Median (mean of the middle two for an even count); NaN for none.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Hash of what the image depends on in the mesh: positions, tets and the active scalars.
pub fn mesh_hash(mesh: &Mesh) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(b"tetbench-mesh-v1");
    h.update(&(mesh.num_vertices() as u64).to_le_bytes());
    for p in mesh.positions() {
        for c in p.to_array() {
            h.update(&c.to_le_bytes());
        }
    }
    h.update(&(mesh.num_tets() as u64).to_le_bytes());
    for t in mesh.tets() {
        for i in t {
            h.update(&i.to_le_bytes());
        }
    }
    for s in mesh.scalars() {
        h.update(&s.to_le_bytes());
    }
    h.finalize()
}

fn tf_bytes(h: &mut blake3::Hasher, tf: &TransferFunction) {
    h.update(tf.name.as_bytes());
    match tf.range {
        Some([a, b]) => {
            h.update(&[1]);
            h.update(&a.to_le_bytes());
            h.update(&b.to_le_bytes());
        }
        None => {
            h.update(&[0]);
        }
    }
    for p in &tf.points {
        h.update(&p.s.to_le_bytes());
        for c in p.rgb {
            h.update(&c.to_le_bytes());
        }
        h.update(&p.tau.to_le_bytes());
    }
}

/// The cache file of the reference image for (mesh, view, size, projection, TF).
fn ref_path(
    opts: &RunOptions,
    mesh: &blake3::Hash,
    exp: &Experiment,
    proj: Projection,
    w: u32,
    h: u32,
    view: algorithms::camera::View,
) -> PathBuf {
    let mut x = blake3::Hasher::new();
    x.update(REFERENCE_VERSION.as_bytes());
    x.update(mesh.as_bytes());
    x.update(proj.name().as_bytes());
    x.update(&w.to_le_bytes());
    x.update(&h.to_le_bytes());
    x.update(&view.azimuth.to_le_bytes());
    x.update(&view.elevation.to_le_bytes());
    tf_bytes(&mut x, &exp.tf);
    let hex = x.finalize().to_hex();
    opts.cache_dir.join(format!("ref-{}.exr", &hex[..32]))
}

fn image_stem(label: &str, proj: Projection, w: u32, h: u32, view_id: &str) -> String {
    format!(
        "{}-{}-{w}x{h}-{}",
        sanitize(label),
        proj.name(),
        sanitize(view_id)
    )
}

/// A name safe as one path component.
pub fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn write_meta(exp: &Experiment, opts: &RunOptions) -> Result<()> {
    let p = opts.out.join("meta.txt");
    let text = format!(
        "experiment: {}\ndate: {}\nmachine: {}\nthreads: {}\ntf: {}\nrepeats: {}\nwarmup: {}\nvariants: {}\n",
        exp.name,
        crate::sysinfo::now_utc(),
        crate::sysinfo::machine(),
        rayon::current_num_threads(),
        exp.tf_name,
        exp.repeats,
        exp.warmup,
        exp.variants
            .iter()
            .map(|v| v.label.as_str())
            .collect::<Vec<_>>()
            .join(", "),
    );
    std::fs::write(&p, text).map_err(|e| io_err(&p, e))
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
