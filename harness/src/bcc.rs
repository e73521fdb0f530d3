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
use algorithms::{alloc, Mesh, Result};
use datasets_gen::fields;
use datasets_gen::grid::{bcc_lattice, cc_lattice, Lattice, Split};

use crate::measure::{measure_each, measure_interleaved, Case, Frames};
use crate::plots::{self, TimeError};
use crate::stats::median;
use crate::table::{fixed as fmt, sci, Table};

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
    // A throwaway prepare first, so that process-wide tables built once (Ψ) are not counted.
    render::make(renderer, &opts)?.prepare(mesh, t)?;
    let mut r = render::make(renderer, &opts)?;
    let (prep, bytes, _) = alloc::measure(|| r.prepare(mesh, t));
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

/// `bcc_pt`: CC vs BCC with projected tetrahedra, and empty-space skipping.
pub fn pt_table(quick: bool, dir: &Path) -> Result<(Table, Vec<PathBuf>)> {
    let sz = sizes(quick);
    let mut t = table(
        &[
            "lattice",
            "field",
            "renderer",
            "tf",
            "sort",
            "samples",
            "tets",
            "visible_tets_pct",
            "time_ms",
            "sort_ms",
            "draw_ms",
            "tets_per_s",
            "bytes_per_tet",
        ],
        &["time_ms", "sort_ms", "draw_ms", "tets_per_s"],
    );
    let mut pts = Vec::new();
    let mut summary: Vec<(String, String, f64, f64)> = Vec::new();
    let mut skip_notes = Vec::new();
    let dense = dense_tf();
    let sparse = sparse_tf();
    let renderers = lattice_renderers();
    // The skipping study and the summary notes use the first (a CPU one when there is one).
    let base = *renderers.first().ok_or_else(|| {
        algorithms::Error::Input("bcc_pt: no renderer takes the sort bcc-implicit".into())
    })?;
    for (fname, f) in FIELDS {
        let lattices = meshes(&sz, f)?;
        // Every lattice renderer with the dense TF; on the shell also the sparse TF without
        // and with skipping (the first renderer).
        let mut specs: Vec<(usize, &str, &TransferFunction, Option<&str>)> = Vec::new();
        for m in 0..lattices.len() {
            for &r in &renderers {
                specs.push((m, r, &dense, Some("bcc-implicit")));
            }
            if fname == "shell" {
                specs.push((m, base, &sparse, Some("bcc-implicit")));
                specs.push((m, base, &sparse, Some("bcc-implicit-skip")));
            }
        }
        let mut cases = Vec::new();
        for &(m, r, tfn, sort) in &specs {
            let (rend, run) = prepare_pt(r, &lattices[m].1, tfn, sort)?;
            cases.push((rend, &lattices[m].1, run));
        }
        time_interleaved(&mut cases, &sz)?;
        let runs: Vec<PtRun> = cases.into_iter().map(|c| c.2).collect();
        // Ground truths per (mesh, transfer function), computed once.
        let mut gts: Vec<((usize, String), Vec<Image>)> = Vec::new();
        let mut noskip: Option<(Vec<Image>, f64)> = None;
        for (&(m, rname, tfn, sort), run) in specs.iter().zip(&runs) {
            let (lname, mesh, dom) = (&lattices[m].0, &lattices[m].1, lattices[m].2);
            let key = (m, tfn.name.clone());
            if !gts.iter().any(|g| g.0 == key) {
                gts.push((key.clone(), truth(mesh, f, dom, tfn, &sz)?));
            }
            let gt = &gts.iter().find(|g| g.0 == key).expect("computed").1;
            let sort = sort.unwrap_or("default");
            {
                let e = errors(&run.images, gt)?;
                let time = median(&run.times);
                let ntets = mesh.num_tets() as f64;
                let mut row = vec![
                    lname.to_string(),
                    fname.to_string(),
                    rname.to_string(),
                    tfn.name.clone(),
                    sort.to_string(),
                    mesh.num_vertices().to_string(),
                    mesh.num_tets().to_string(),
                    fmt(100.0 * (ntets - run.skipped) / ntets, 1),
                    fmt(time, 2),
                    fmt(median(&run.sort_ms), 2),
                    fmt(median(&run.draw_ms), 2),
                    sci(ntets / (time / 1e3), 3),
                    fmt(run.bytes as f64 / ntets, 1),
                ];
                row.extend(err_cols(&e));
                t.rows.push(row);
                if tfn.name == "default" {
                    let who = if rname == base {
                        String::new()
                    } else {
                        format!(" {rname}")
                    };
                    pts.push(TimeError {
                        label: format!("{lname} {fname}{who}"),
                        rmse: e.rmse,
                        time_ms: time,
                    });
                    if rname == base {
                        summary.push((lname.to_string(), fname.to_string(), time, e.rmse));
                    }
                }
                if tfn.name == "sparse" {
                    // Per mesh: the run without skipping comes first, then the one with.
                    match noskip.take() {
                        None => noskip = Some((run.images.clone(), time)),
                        Some((imgs, t0)) => {
                            let same = imgs
                                .iter()
                                .zip(&run.images)
                                .all(|(a, b)| a.pixels == b.pixels);
                            skip_notes.push(format!(
                                "Empty-space skipping on {lname} (shell, sparse TF, {:.1} % of the tets visible): {t0:.2} ms without, {time:.2} ms with ({:.2}x); images {}.",
                                100.0 * (ntets - run.skipped) / ntets,
                                t0 / time,
                                if same { "identical (every f32 pixel)" } else { "DIFFERENT" }
                            ));
                        }
                    }
                }
            }
        }
    }
    t.notes.push(format!(
        "Equal information: CC lattices of {c}³ cells (h = 2/{c}) and a BCC lattice of {n}³ primary points (h = 2/{m} ≈ √2·2/{c}) over [-1, 1]³. Samples = mesh vertices (the BCC secondary grid reaches half a cell beyond the box, so its count is above 70.7 % of CC's).",
        c = sz.cells,
        n = sz.bcc_n,
        m = sz.bcc_n - 1
    ));
    t.notes.push(format!(
        "{}, integrator partial, sort bcc-implicit (the lattice traversal, for CC and BCC alike), {}² orthographic, {} view(s) {}, median of {} frames after a warm-up, the cases of one field rendered in turn (interleaved, so that load from other processes falls on all alike); bytes_per_tet = heap bytes the renderer's prepare retains (counting allocator) / tets.",
        renderers.join(" and "),
        sz.image,
        sz.views.len(),
        sz.views
            .iter()
            .map(|v| format!("({:.0}, {:.0})", v.azimuth, v.elevation))
            .collect::<Vec<_>>()
            .join(" "),
        sz.repeats
    ));
    t.notes.push(format!(
        "Errors: mean over views against a ground truth that ray-integrates the analytic field (not a mesh) over each mesh's own domain (box for CC, the octahedra for BCC) and with its own L, step {:.4} (h_cc/{}), `exact` integrator; max_abs and max_err_pct are maxima over views.",
        sz.gt_step,
        (2.0 / sz.cells as f64 / sz.gt_step).round()
    ));
    t.notes.push("Paper (§5, Fig. 10, timings as a chart only): \"For all tested datasets, the algorithm performs better on the BCC grid volume\"; BCC vs CC quality \"no major difference\" on Fuel.".into());
    for (fname, _) in FIELDS {
        let get = |l: &str| {
            summary
                .iter()
                .find(|s| s.0 == l && s.1 == fname)
                .map(|s| (s.2, s.3))
        };
        if let (Some(b), Some(c5), Some(c6)) = (get("bcc"), get("cc5"), get("cc6")) {
            t.notes.push(format!(
                "{fname}: BCC {:.2} ms, rmse {:.3e}; cc5 {:.2} ms, rmse {:.3e}; cc6 {:.2} ms, rmse {:.3e} → BCC is {} in time than cc5 and {} in error than the better CC.",
                b.0, b.1, c5.0, c5.1, c6.0, c6.1,
                if b.0 < c5.0 { "faster" } else { "slower" },
                if b.1 < c5.1.min(c6.1) { "lower" } else { "higher" }
            ));
        }
    }
    t.notes.extend(skip_notes);
    let plots = plots::time_vs_error(
        &pts,
        &dir.join("bcc_pt-time_vs_error"),
        &format!(
            "CC vs BCC at equal information: {} time against error",
            renderers.join(", ")
        ),
    )?;
    Ok((t, plots))
}

/// `bcc_reconstruction`: ray casting per reconstruction scheme.
pub fn recon_table(quick: bool, dir: &Path) -> Result<(Table, Vec<PathBuf>)> {
    let sz = sizes(quick);
    let mut t = table(
        &[
            "scheme",
            "lattice",
            "field",
            "samples",
            "time_ms",
            "paper_fig9_rank",
        ],
        &["time_ms"],
    );
    let o = DVec3::splat(-1.0);
    let bbox = Aabb {
        min: o,
        max: DVec3::ONE,
    };
    let diag = bbox.diagonal();
    let t_dense = dense_tf();
    let exact = integrator("exact", &t_dense)?;
    let map = t_dense.scalar_map((0.0, 1.0));
    let mut pts = Vec::new();
    // Paper Fig. 9 (chart only): bil fastest, then tril, then shtril ≈ bilspat, bary slowest.
    let rank = |s: Scheme| match s {
        Scheme::Bilinear => "1 (fastest)",
        Scheme::Trilinear => "2",
        Scheme::ShearedTrilinear | Scheme::BilinearSpatial => "3 (similar)",
        Scheme::Barycentric => "5 (slowest)",
    };
    for (fname, f) in FIELDS {
        let cc = CcVolume::sample([sz.cells + 1; 3], o, DVec3::splat(2.0 / sz.cells as f64), f);
        let bcc = BccVolume::sample(
            [sz.bcc_n; 3],
            o,
            DVec3::splat(2.0 / (sz.bcc_n - 1) as f64),
            f,
        );
        let gts: Vec<Image> = sz
            .views
            .iter()
            .map(|&v| {
                bcc_recon::ground_truth(
                    &f,
                    &|_| true,
                    &bbox,
                    &cam(&bbox, v, sz.image),
                    Sampling {
                        map,
                        integ: exact.as_ref(),
                        step: sz.gt_step,
                        diag,
                    },
                )
            })
            .collect::<Result<_>>()?;
        for scheme in Scheme::ALL {
            let (vol, samples) = if scheme == Scheme::Trilinear {
                (Volume::Cc(&cc), cc.samples())
            } else {
                (Volume::Bcc(&bcc), bcc.samples())
            };
            let mut times = Vec::new();
            let mut imgs = Vec::new();
            let frames = Frames {
                warmup: 0,
                repeats: sz.repeats,
            };
            for &v in &sz.views {
                let c = cam(&bbox, v, sz.image);
                let m = measure_each(1, frames, |_| {
                    let sampling = Sampling {
                        map,
                        integ: exact.as_ref(),
                        step: sz.rc_step,
                        diag,
                    };
                    Ok(Frame {
                        image: bcc_recon::raycast(vol, scheme, &c, sampling)?,
                        times: Default::default(),
                        counters: Vec::new(),
                    })
                })?
                .remove(0);
                // The median per view, then the median of those.
                times.push(m.wall_ms);
                imgs.push(m.image);
            }
            let e = errors(&imgs, &gts)?;
            let time = median(&times);
            let mut row = vec![
                scheme.name().to_string(),
                scheme.lattice().to_string(),
                fname.to_string(),
                samples.to_string(),
                fmt(time, 2),
                rank(scheme).to_string(),
            ];
            row.extend(err_cols(&e));
            t.rows.push(row);
            pts.push(TimeError {
                label: format!("{} {fname}", scheme.name()),
                rmse: e.rmse,
                time_ms: time,
            });
        }
    }
    t.notes.push(format!(
        "Ray casting regular volumes over [-1, 1]³: CC {c1}³ samples (h = 2/{c}), BCC {n}³ primary + {n1}³ secondary samples (h = 2/{m}); orthographic {s}², {v} view(s), step {st:.4} (h_cc/2) for tril, bilspat, bary, shtril; bil samples where the ray meets the planes (spacing h_bcc/2 ≈ h_cc/√2); each segment between samples integrated by `exact` with the `default` TF (range [0, 1]); median of {r} frames.",
        c1 = sz.cells + 1,
        c = sz.cells,
        n = sz.bcc_n,
        n1 = sz.bcc_n + 1,
        m = sz.bcc_n - 1,
        s = sz.image,
        v = sz.views.len(),
        st = sz.rc_step,
        r = sz.repeats
    ));
    t.notes.push(format!(
        "Errors against the analytic field ray-integrated over the same box at step {:.4} with `exact` (mean over views).",
        sz.gt_step
    ));
    t.notes.push("paper_fig9_rank: the order of the paper's Fig. 9 timings (a chart, no numbers in the text): bil fastest, then tril, shtril and bilspat similar and slightly slower than tril, bary slowest; the paper found shtril and bilspat best in quality on BCC, tril on CC most detailed.".into());
    let plots = plots::time_vs_error(
        &pts,
        &dir.join("bcc_reconstruction-time_vs_error"),
        "Reconstruction schemes: ray-casting time against error (BCC paper Fig. 9)",
    )?;
    Ok((t, plots))
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
