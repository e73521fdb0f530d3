//! The BCC paper's comparisons (issue 9), as two `tetbench reproduce` tables:
//!
//! - `bcc_pt` — CC against BCC at equal information (paper §4, Fig. 10): the same analytic
//!   field sampled on a `cc5`/`cc6` lattice of spacing `h` and on a BCC lattice of primary
//!   spacing `√2·h` over the same box (29.3 % fewer samples per volume), rendered by every
//!   projected-tetrahedra renderer that takes the `bcc-implicit` traversal, with it and the
//!   same transfer function; time, tets, bytes per tet and the CONVENTIONS §6 errors against a ground truth that ray-integrates the analytic
//!   field over the mesh's own domain ([`algorithms::bcc_recon::ground_truth`], `exact`
//!   integrator, fine step). Plus empty-space skipping (`bcc-implicit-skip`) on a sparse
//!   transfer function: time with and without, and whether the image is the same.
//! - `bcc_reconstruction` — ray casting regular CC and BCC volumes of the same two sizes with
//!   trilinear on CC and the four BCC schemes of §3 (paper Fig. 9: time per scheme), with the
//!   error of each against the analytic ground truth over the box.
//!
//! Fields: Marschner–Lobb (`f_M = 6`, `α = 0.25`) and a spherical shell (radius 0.6, width
//! 0.15), both with range [0, 1] on `[-1, 1]³`; transfer functions with that range fixed, so
//! both lattices map scalars alike.

use std::path::{Path, PathBuf};

use algorithms::bcc_recon::{self, BccDomain, BccVolume, CcVolume, Sampling, Scheme, Volume};
use algorithms::camera::{fibonacci_views, Camera, Projection, View};
use algorithms::glam::DVec3;
use algorithms::image::Image;
use algorithms::mesh::Aabb;
use algorithms::metrics::{compare, ImageError};
use algorithms::optics::integrator;
use algorithms::render::{self, Family, Frame, RenderOptions};
use algorithms::tf::{TfPoint, TransferFunction};
use algorithms::{Mesh, Result};
use datasets_gen::fields;
use datasets_gen::grid::{bcc_lattice, cc_lattice, Lattice, Split};

use crate::measure::{measure_each, measure_interleaved, Case, Frames};
use crate::plots::{self, TimeError};
use crate::stats::median;
use crate::table::{fixed as fmt, sci, Table};

mod pt;
mod recon;
pub use pt::pt_table;
pub use recon::recon_table;

pub const PT_ID: &str = "bcc_pt";
pub const RECON_ID: &str = "bcc_reconstruction";

type Field = fn(DVec3) -> f64;

fn shell(p: DVec3) -> f64 {
    fields::spherical_shell(p, DVec3::ZERO, 0.6, 0.15)
}

const FIELDS: [(&str, Field); 2] = [("marschner-lobb", fields::marschner_lobb), ("shell", shell)];

fn tf(name: &str, pts: &[(f64, [f64; 3], f64)]) -> TransferFunction {
    TransferFunction {
        name: name.to_string(),
        range: Some([0.0, 1.0]),
        points: pts
            .iter()
            .map(|&(s, rgb, tau)| TfPoint { s, rgb, tau })
            .collect(),
    }
}

/// The `default` preset's points with the range fixed to [0, 1].
fn dense_tf() -> TransferFunction {
    let mut t = TransferFunction::preset("default").expect("preset");
    t.range = Some([0.0, 1.0]);
    t
}

/// Transparent below s = 0.55: on the shell most of the box maps to τ = 0.
fn sparse_tf() -> TransferFunction {
    tf(
        "sparse",
        &[
            (0.0, [0.0, 0.0, 0.0], 0.0),
            (0.55, [0.2, 0.4, 1.0], 0.0),
            (0.8, [1.0, 0.6, 0.1], 20.0),
            (1.0, [1.0, 1.0, 1.0], 30.0),
        ],
    )
}

/// Sizes: CC cells per axis over `[-1, 1]³`, and the BCC primary points per axis with spacing
/// nearest `√2·h_cc` (`n − 1 = round(cells/√2)`).
struct Sizes {
    cells: usize,
    bcc_n: usize,
    image: u32,
    views: Vec<View>,
    repeats: usize,
    /// Ground-truth step (world units).
    gt_step: f64,
    /// Ray-caster step (world units).
    rc_step: f64,
}

fn sizes(quick: bool) -> Sizes {
    let cells = if quick { 16 } else { 40 };
    let bcc_n = (cells as f64 / std::f64::consts::SQRT_2).round() as usize + 1;
    let h = 2.0 / cells as f64;
    Sizes {
        cells,
        bcc_n,
        image: if quick { 64 } else { 192 },
        views: if quick {
            vec![View::new(30.0, 20.0)]
        } else {
            fibonacci_views(2)
        },
        repeats: if quick { 1 } else { 5 },
        gt_step: if quick { h / 6.0 } else { h / 10.0 },
        rc_step: h / 2.0,
    }
}

fn with_field(name: &str, p: Vec<DVec3>, t: Vec<[u32; 4]>, l: &Lattice, f: Field) -> Result<Mesh> {
    let s = fields::sample(&p, f);
    let mut m = Mesh::with_scalars(name, p, t, "f", s)?;
    m.field_data
        .insert(datasets_gen::LATTICE_KEY.into(), l.to_field_data());
    Ok(m)
}

/// The three lattice meshes of one field at equal information; with the BCC domain.
fn meshes(sz: &Sizes, f: Field) -> Result<Vec<(&'static str, Mesh, Option<BccDomain>)>> {
    let o = DVec3::splat(-1.0);
    let h = DVec3::splat(2.0 / sz.cells as f64);
    let mut v = Vec::new();
    for (name, split) in [("cc5", Split::Five), ("cc6", Split::Six)] {
        let (b, l) = cc_lattice([sz.cells; 3], split, o, h);
        v.push((name, with_field(name, b.positions, b.tets, &l, f)?, None));
    }
    let hb = DVec3::splat(2.0 / (sz.bcc_n - 1) as f64);
    let n = [sz.bcc_n; 3];
    let (p, t, l) = bcc_lattice(n, o, hb);
    let dom = BccDomain {
        n,
        origin: o,
        h: hb,
    };
    v.push(("bcc", with_field("bcc", p, t, &l, f)?, Some(dom)));
    Ok(v)
}

fn cam(bbox: &Aabb, v: View, size: u32) -> Camera {
    Camera::new(bbox, v, Projection::Ortho, size, size)
}

/// Mean of the §6 errors over views.
fn mean_err(e: &[ImageError]) -> ImageError {
    let n = e.len().max(1) as f64;
    let m = |g: fn(&ImageError) -> f64| e.iter().map(g).sum::<f64>() / n;
    let rmse = m(|x| x.rmse);
    ImageError {
        rmse,
        psnr: 20.0 * (1.0 / rmse).log10(),
        max_abs: e.iter().map(|x| x.max_abs).fold(0.0, f64::max),
        diff_pixels_pct: m(|x| x.diff_pixels_pct),
        max_err_pct: e.iter().map(|x| x.max_err_pct).fold(0.0, f64::max),
        avg_err_pct: m(|x| x.avg_err_pct),
    }
}

fn err_cols(e: &ImageError) -> Vec<String> {
    vec![
        sci(e.rmse, 3),
        fmt(e.psnr, 2),
        fmt(e.max_abs, 4),
        fmt(e.diff_pixels_pct, 2),
        fmt(e.max_err_pct, 2),
        fmt(e.avg_err_pct, 2),
    ]
}

/// An empty table with `cols` then the §6 error columns; `hw` are the hardware-dependent ones.
fn table(cols: &[&str], hw: &[&str]) -> Table {
    let errs = mean_err(&[]).fields().map(|(name, _)| name);
    let columns: Vec<String> = cols.iter().chain(&errs).map(|s| s.to_string()).collect();
    Table {
        hardware: columns.iter().map(|c| hw.contains(&c.as_str())).collect(),
        columns,
        ..Default::default()
    }
}

struct PtRun {
    times: Vec<f64>,
    sort_ms: Vec<f64>,
    draw_ms: Vec<f64>,
    images: Vec<Image>,
    bytes: isize,
    skipped: f64,
}

/// A renderer prepared for one mesh, transfer function and sort (bytes measured), ready for
/// [`time_interleaved`].
fn prepare_pt(
    renderer: &str,
    mesh: &Mesh,
    t: &TransferFunction,
    sort: Option<&str>,
) -> Result<(Box<dyn render::Renderer>, PtRun)> {
    let opts = RenderOptions {
        sort: sort.map(String::from),
        integrator: Some("partial".into()),
        ..Default::default()
    };
    let mut r = render::make(renderer, &opts)?;
    let (prep, bytes, _) = crate::measure::prepare_counted(renderer, || r.prepare(mesh, t));
    prep?;
    let run = PtRun {
        times: Vec::new(),
        sort_ms: Vec::new(),
        draw_ms: Vec::new(),
        images: Vec::new(),
        bytes,
        skipped: 0.0,
    };
    Ok((r, run))
}

/// Times every case per view: a warm-up frame each, then `repeats` rounds that render each
/// case once in turn, so that load from other processes on the machine falls on all cases
/// alike (the lattices are compared against each other).
fn time_interleaved(
    cases: &mut [(Box<dyn render::Renderer>, &Mesh, PtRun)],
    sz: &Sizes,
) -> Result<()> {
    let frames = Frames {
        warmup: 1,
        repeats: sz.repeats,
    };
    for &v in &sz.views {
        let mut timed: Vec<Case> = cases
            .iter_mut()
            .map(|(r, mesh, _)| Case {
                renderer: r.as_mut(),
                mesh,
                camera: cam(&mesh.bbox(), v, sz.image),
            })
            .collect();
        let measured = measure_interleaved(&mut timed, frames)?;
        for ((_, _, run), m) in cases.iter_mut().zip(measured) {
            run.times.push(m.times.total_ms);
            run.sort_ms.push(m.times.sort_ms);
            run.draw_ms.push(m.times.draw_ms);
            run.skipped = m
                .counters
                .iter()
                .find(|c| c.0 == "tets_skipped")
                .map_or(0.0, |c| c.1);
            run.images.push(m.image);
        }
    }
    Ok(())
}

/// The analytic ground truth for `mesh` (its own bbox, L and domain) in each view.
fn truth(
    mesh: &Mesh,
    f: Field,
    dom: Option<BccDomain>,
    t: &TransferFunction,
    sz: &Sizes,
) -> Result<Vec<Image>> {
    let bbox = mesh.bbox();
    let exact = integrator("exact", t)?;
    let map = t.scalar_map(mesh.scalar_range());
    let inside = move |p: DVec3| dom.is_none_or(|d| d.contains(p));
    sz.views
        .iter()
        .map(|&v| {
            bcc_recon::ground_truth(
                &f,
                &inside,
                &bbox,
                &cam(&bbox, v, sz.image),
                Sampling {
                    map,
                    integ: exact.as_ref(),
                    step: sz.gt_step,
                    diag: mesh.diagonal(),
                },
            )
        })
        .collect()
}

fn errors(images: &[Image], truth: &[Image]) -> Result<ImageError> {
    let e: Vec<ImageError> = images
        .iter()
        .zip(truth)
        .map(|(a, b)| compare(a, b))
        .collect::<Result<_>>()?;
    Ok(mean_err(&e))
}

/// The projected-tetrahedra renderers of the registry that take the lattice order
/// (`bcc-implicit`), the table's subject: CPU ones first.
pub fn lattice_renderers() -> Vec<&'static str> {
    let mut v: Vec<&render::RendererInfo> = render::family(Family::Pt)
        .into_iter()
        .filter(|r| r.sorts.contains(&"bcc-implicit") && r.sorts.contains(&"bcc-implicit-skip"))
        .collect();
    v.sort_by_key(|r| r.needs_gpu);
    v.into_iter().map(|r| r.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_tables_have_their_rows_and_skipping_keeps_the_image() {
        let dir = tempfile_dir();
        let (t, plots) = pt_table(true, &dir).unwrap();
        // 2 fields × 3 lattices per lattice renderer, plus 2 sparse rows per lattice on the
        // shell.
        let renderers = lattice_renderers().len();
        assert_eq!(t.rows.len(), 6 * renderers + 6);
        assert!(plots.iter().all(|p| p.exists()));
        let skip: Vec<&String> = t
            .notes
            .iter()
            .filter(|n| n.starts_with("Empty-space"))
            .collect();
        assert_eq!(skip.len(), 3);
        assert!(skip.iter().all(|n| n.contains("identical")), "{skip:?}");
        // Errors against the analytic truth are small but not zero (a real comparison).
        let rmse = t.columns.iter().position(|c| c == "rmse").unwrap();
        for r in &t.rows {
            let e: f64 = r[rmse].parse().unwrap();
            assert!(e > 1e-4 && e < 0.1, "{r:?}");
        }
        let (r, _) = recon_table(true, &dir).unwrap();
        assert_eq!(r.rows.len(), 10);
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn tempfile_dir() -> PathBuf {
        let d = std::env::temp_dir().join(format!("tetbench-bcc-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// The ground truth converges: halving the step changes the image far less than the
    /// lattice errors the tables report.
    #[test]
    fn ground_truth_is_converged() {
        let bbox = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::ONE,
        };
        let t = dense_tf();
        let exact = integrator("exact", &t).unwrap();
        let c = cam(&bbox, View::new(30.0, 20.0), 32);
        let gt = |step: f64| {
            bcc_recon::ground_truth(
                &fields::marschner_lobb,
                &|_| true,
                &bbox,
                &c,
                Sampling {
                    map: t.scalar_map((0.0, 1.0)),
                    integ: exact.as_ref(),
                    step,
                    diag: bbox.diagonal(),
                },
            )
            .unwrap()
        };
        let e = compare(&gt(0.01), &gt(0.005)).unwrap();
        assert!(e.rmse < 2e-3, "{}", e.rmse);
    }
}
