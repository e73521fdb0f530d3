//! One cell of a sweep (a projection, a size and a view: [`Cell`]), a variant made and prepared
//! on one mesh ([`Prepared`]), and one measurement of it ([`measure_cell`]), isolated so that a
//! panicking renderer costs one failed row, not the sweep.

use std::path::Path;
use std::time::Instant;

use algorithms::camera::{Camera, Projection};
use algorithms::image::Image;
use algorithms::mesh::Aabb;
use algorithms::render::{self, Description, Renderer};
use algorithms::{metrics, util::alloc, Error, Mesh, Result, TransferFunction};

use crate::experiment::{Experiment, Variant, ViewItem};
use crate::measure::{self, Frames};
use crate::rows::Row;

/// One cell of the sweep: a projection, an image size and a view.
#[derive(Debug, Clone)]
pub struct Cell<'a> {
    pub projection: Projection,
    pub size: (u32, u32),
    pub view: &'a ViewItem,
}

/// Every cell of an experiment, in the order they run (projection, size, view).
pub fn cells(exp: &Experiment) -> Vec<Cell<'_>> {
    let mut v = Vec::new();
    for &projection in &exp.projections {
        for &size in &exp.sizes {
            for view in &exp.views {
                v.push(Cell {
                    projection,
                    size,
                    view,
                });
            }
        }
    }
    v
}

/// One variant made and prepared for one mesh, with the row fields every cell shares.
pub struct Prepared {
    renderer: Box<dyn Renderer>,
    /// The mesh as the renderer saw it (a fresh clone: derived data it needs is counted).
    mesh: Mesh,
    /// `prepare`'s error, reported in every row of the variant.
    failed: Option<String>,
    base: Row,
    /// The box the camera frames (the mesh's bounding box unless the dataset says otherwise).
    frame: Aabb,
}

impl Prepared {
    /// Makes the variant's renderer and prepares it, timing setup and counting its heap bytes.
    /// Its cameras frame `frame`; a peer's log (its stderr) goes to `log_dir/<renderer>.log`.
    pub fn new(
        exp: &Experiment,
        var: &Variant,
        dataset: &str,
        mesh: &Mesh,
        frame: Aabb,
        log_dir: Option<&Path>,
    ) -> Result<Self> {
        let mut renderer: Box<dyn Renderer> = match &var.unavailable {
            Some(why) => Box::new(Unavailable {
                name: var.renderer.clone(),
                why: why.clone(),
            }),
            None => {
                let mut o = var.options.clone();
                o.log_dir = log_dir.map(Path::to_path_buf);
                render::make(&var.renderer, &o)?
            }
        };
        let fresh = mesh.clone();
        let t0 = Instant::now();
        let (prep, bytes, peak) = measure::prepare_counted(&var.renderer, || {
            isolated(|| renderer.prepare(&fresh, &var.tf))
        });
        let setup_ms = t0.elapsed().as_secs_f64() * 1e3;
        let tets = mesh.num_tets() as f64;
        let per_tet = |b: isize| {
            if alloc::is_counting() {
                b as f64 / tets
            } else {
                f64::NAN
            }
        };
        let base = Row {
            dataset: dataset.to_string(),
            tets: mesh.num_tets(),
            vertices: mesh.num_vertices(),
            renderer: var.renderer.clone(),
            sort: var.sort.clone(),
            integrator: var.integrator.clone(),
            variant: var.label.clone(),
            tf: var.tf_name.clone(),
            reference: if exp.error {
                var.yardstick.label()
            } else {
                String::new()
            },
            repeats: exp.repeats,
            warmup: exp.warmup,
            threads: rayon::current_num_threads(),
            device: renderer.describe().device,
            setup_ms,
            cpu_bytes_per_tet: per_tet(bytes),
            cpu_peak_bytes_per_tet: per_tet(peak),
            gpu_bytes_per_tet: renderer.memory().gpu_bytes as f64 / tets,
            ..Default::default()
        };
        Ok(Prepared {
            renderer,
            mesh: fresh,
            failed: prep.err().map(|e| format!("prepare: {e}")),
            base,
            frame,
        })
    }
}

/// An `optional` renderer that cannot run here: its `prepare` fails with the reason, so each of
/// its rows is a failed row that says why (see `RendererSpec::optional`).
struct Unavailable {
    name: String,
    why: String,
}

impl Renderer for Unavailable {
    fn describe(&self) -> Description {
        Description::cpu(&self.name, "", "")
    }
    fn prepare(&mut self, _: &Mesh, _: &TransferFunction) -> Result<()> {
        Err(Error::Input(format!(
            "not run on this machine: {}",
            self.why
        )))
    }
    fn render(&mut self, _: &Mesh, _: &Camera) -> Result<algorithms::render::Frame> {
        Err(Error::Input(format!(
            "not run on this machine: {}",
            self.why
        )))
    }
}

/// Test-only: `TETBENCH_TEST_PANIC=VARIANT@VIEW_ID` makes the renderer of that one cell panic
/// inside `render`, to prove that a panicking renderer costs one failed row, not the sweep
/// (cells separated by `;`, as labels hold commas; `VARIANT@*` for all of a variant's views).
/// Not for users; it is set only by the harness's tests.
pub const TEST_PANIC_ENV: &str = "TETBENCH_TEST_PANIC";

/// A renderer that panics when it renders (see [`TEST_PANIC_ENV`]).
struct TestPanic<'a>(&'a mut dyn Renderer);

impl Renderer for TestPanic<'_> {
    fn describe(&self) -> Description {
        Description {
            sort: String::new(),
            device: "cpu".into(),
            ..self.0.describe()
        }
    }
    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.0.prepare(mesh, tf)
    }
    fn render(&mut self, _: &Mesh, _: &Camera) -> Result<algorithms::render::Frame> {
        panic!("test-only renderer panic ({TEST_PANIC_ENV})")
    }
}

/// Runs `f`, turning a panic inside it (a renderer's bug, a GPU device lost that wgpu reports
/// by panicking) into an error carrying the panic's message, so one measurement fails alone.
pub fn isolated<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(Error::Internal(format!("panicked: {msg}")))
        }
    }
}

/// The row fields of `cell` for variant `p`, before measuring.
fn cell_row(p: &Prepared, cell: &Cell) -> Row {
    let (w, h) = cell.size;
    let mut row = p.base.clone();
    row.width = w;
    row.height = h;
    row.view_id = cell.view.id.clone();
    row.azimuth = cell.view.view.azimuth;
    row.elevation = cell.view.view.elevation;
    row.projection = cell.projection.name().to_string();
    row
}

fn cell_camera(p: &Prepared, cell: &Cell) -> Camera {
    let (w, h) = cell.size;
    Camera::new(&p.frame, cell.view.view, cell.projection, w, h)
}

/// Whether [`TEST_PANIC_ENV`] asks variant `p` to panic in `cell`.
fn test_panic(p: &Prepared, cell: &Cell) -> bool {
    let label = format!("{}@{}", p.base.variant, cell.view.id);
    std::env::var(TEST_PANIC_ENV).is_ok_and(|v| {
        v.split(';')
            .any(|c| c == label || c.strip_suffix("@*") == Some(p.base.variant.as_str()))
    })
}

/// Renders one frame of `p`, a panic turned into an error.
fn frame(p: &mut Prepared, cam: &Camera, panic: bool) -> Result<algorithms::render::Frame> {
    let renderer = p.renderer.as_mut();
    let mesh = &p.mesh;
    isolated(|| {
        if panic {
            TestPanic(renderer).render(mesh, cam)
        } else {
            renderer.render(mesh, cam)
        }
    })
}

/// The yardstick image a measurement's error is taken against (see `bench::yardsticks`): its
/// file, or why there is none.
pub type RefImage<'a> = std::result::Result<&'a Path, &'a str>;

/// Measures one cell: the row (a failed frame is a row with NaN times and the error as its
/// note) and, when the frames ran, the last image. With `reference`, the error against it.
pub fn measure_cell(
    exp: &Experiment,
    p: &mut Prepared,
    cell: &Cell,
    reference: Option<RefImage>,
) -> Result<(Row, Option<Image>)> {
    let row = cell_row(p, cell);
    let result = match &p.failed {
        Some(e) => Err(Error::Input(e.clone())),
        None => {
            let cam = cell_camera(p, cell);
            let frames = Frames {
                warmup: exp.warmup,
                repeats: exp.repeats,
            };
            let panic = test_panic(p, cell);
            let renderer = p.renderer.as_mut();
            let mesh = &p.mesh;
            isolated(|| {
                if panic {
                    let mut r = TestPanic(renderer);
                    return measure::measure(&mut r, mesh, &cam, frames);
                }
                measure::measure(renderer, mesh, &cam, frames)
            })
        }
    };
    finish_row(row, result, p, reference)
}

/// Measures one cell for several variants at once, interleaved (the experiment key
/// `interleave`): warm-up rounds, then measured rounds, each rendering every variant once in
/// turn ([`measure::measure_rounds`]). A variant whose `prepare` or frame fails gets a failed
/// row; the others are measured all the same. `turn(variant, t)` is called before each frame,
/// in the order they run. The rows come back in the order of `ps`, each with the error against
/// its own yardstick in `references` (parallel to `ps`).
pub fn measure_cell_interleaved(
    exp: &Experiment,
    ps: &mut [&mut Prepared],
    cell: &Cell,
    references: &[Option<RefImage>],
    mut turn: impl FnMut(&str, measure::Turn),
) -> Result<Vec<(Row, Option<Image>)>> {
    let live: Vec<usize> = (0..ps.len()).filter(|&i| ps[i].failed.is_none()).collect();
    let labels: Vec<String> = live.iter().map(|&i| ps[i].base.variant.clone()).collect();
    let cams: Vec<Camera> = live.iter().map(|&i| cell_camera(ps[i], cell)).collect();
    let panics: Vec<bool> = live.iter().map(|&i| test_panic(ps[i], cell)).collect();
    let frames = Frames {
        warmup: exp.warmup,
        repeats: exp.repeats,
    };
    let mut results = measure::measure_rounds(
        live.len(),
        frames,
        |k| frame(ps[live[k]], &cams[k], panics[k]),
        |t| turn(&labels[t.case], t),
    )
    .into_iter();
    let mut out = Vec::with_capacity(ps.len());
    for (i, p) in ps.iter_mut().enumerate() {
        let reference = references.get(i).copied().flatten();
        let row = cell_row(p, cell);
        let result = match &p.failed {
            Some(e) => Err(Error::Input(e.clone())),
            None => results
                .next()
                .unwrap_or_else(|| Err(Error::Internal("measure_rounds: a case lost".into()))),
        };
        out.push(finish_row(row, result, p, reference)?);
    }
    Ok(out)
}

/// Fills `row` from the measured frames (or marks it failed with the error as its note).
fn finish_row(
    mut row: Row,
    result: Result<measure::Measured>,
    p: &Prepared,
    reference: Option<RefImage>,
) -> Result<(Row, Option<Image>)> {
    let m = match result {
        Ok(m) => m,
        Err(e) => {
            for t in [
                &mut row.project_ms,
                &mut row.sort_ms,
                &mut row.draw_ms,
                &mut row.readback_ms,
                &mut row.total_ms,
                &mut row.total_min_ms,
                &mut row.wall_ms,
                &mut row.fps,
                &mut row.tets_per_s,
            ] {
                *t = f64::NAN;
            }
            row.note = e.to_string().replace(['\n', '\r'], " ");
            return Ok((row, None));
        }
    };
    let t = m.times;
    row.project_ms = t.project_ms;
    row.sort_ms = t.sort_ms;
    row.draw_ms = t.draw_ms;
    row.readback_ms = t.readback_ms;
    row.total_ms = t.total_ms;
    row.total_min_ms = m.total_min_ms;
    row.fps = 1e3 / t.total_ms.max(1e-9);
    row.tets_per_s = row.tets as f64 / (t.total_ms.max(1e-9) * 1e-3);
    row.wall_ms = m.wall_ms;
    row.non_finite_pixels = m.image.non_finite_pixels();
    row.image_hash = super::image_hash(&m.image);
    row.counters = crate::rows::format_counters(&m.counters);
    // A peer's bytes are its process group's peak RSS (and the GPU bytes it reports), known
    // after the frames.
    let memory = p.renderer.memory();
    if let Some(b) = memory.external_bytes {
        row.cpu_bytes_per_tet = b as f64 / row.tets.max(1) as f64;
        row.cpu_peak_bytes_per_tet = row.cpu_bytes_per_tet;
        row.gpu_bytes_per_tet = memory.gpu_bytes as f64 / row.tets.max(1) as f64;
    }
    let yardstick = match reference {
        None => None,
        Some(Ok(rp)) => match super::yardsticks::read_entry(rp) {
            Ok(img) => Some(img),
            Err(e) => {
                row.note = format!("reference: {e}");
                None
            }
        },
        Some(Err(why)) => {
            row.note = format!("reference: {why}");
            None
        }
    };
    if let Some(ri) = &yardstick {
        match metrics::compare(&m.image, ri) {
            Ok(e) => {
                row.rmse = Some(e.rmse);
                row.psnr = Some(e.psnr);
                row.max_abs = Some(e.max_abs);
                row.diff_pixels_pct = Some(e.diff_pixels_pct);
                row.max_err_pct = Some(e.max_err_pct);
                row.avg_err_pct = Some(e.avg_err_pct);
            }
            Err(e) => row.note = format!("compare: {e}"),
        }
    }
    Ok((row, Some(m.image)))
}
