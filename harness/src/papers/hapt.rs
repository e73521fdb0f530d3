//! The HAPT paper (Callahan et al. 2005): Table 1 (centroid order against MPVONC), Table 2
//! (sizes and rates, DVR and iso-surfaces), Table 3 (sort and draw time per algorithm on spx2)
//! and Table 4 (rates per algorithm on torso and fighter).

use algorithms::render::{self, Family};
use algorithms::Result;

use super::common::{
    base_config, common_notes, dataset, external_note, external_peers, failed_cells, measured,
    mesh_used, pt_family, ray_casters, rotating, sizes_of, variants, want, Measured,
};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::{self, Config, PairSpec, ViewsSpec};
use crate::plots;
use crate::table::{count, fixed as f, Table};

table!(
    Table1,
    "hapt-table1",
    "HAPT Table 1: image error between centroid sorting and MPVONC, and against the exact order xmpvo (views over a sphere)",
    "Image error between the centroid order and MPVONC, HAPT Table 1's metrics (on 8-bit values, CONVENTIONS §6) over views spread over a sphere, and the same against `xmpvo`, which is exact at image resolution on non-convex meshes too (MPVONC is not: see docs/sorts.md), with each order's own RMSE against the reference: how often and how much the cheap sort is wrong.",
    hapt_t1_exp,
    hapt_t1_build,
    |o: &Outcome, d: &std::path::Path| plots::pair_errors(&o.pairs, &d.join("hapt-table1-centroid_vs_mpvonc"))
);

table!(
    Table2,
    "hapt-table2",
    "HAPT Table 2: dataset sizes and frame rates, direct volume rendering and iso-surfaces (512², rotating)",
    "Dataset sizes and frame rates in direct volume rendering, with error and memory per tet, and in iso-surface modes where a renderer draws them (ISO columns, no error: the reference draws no iso-surfaces).",
    hapt_t2_exp,
    hapt_t2_build,
    |o: &Outcome, d: &std::path::Path| plots::tets_per_s_vs_size(&o.rows, &d.join("hapt-table2-tets_per_s"))
);

// HAPT Table 1.

/// A row of HAPT's Table 1: the error between centroid order and MPVONC, as printed.
struct T1Row {
    dataset: &'static str,
    max_error: &'static str,
    avg_error: &'static str,
    diff_pixels: &'static str,
}

const fn t1(
    dataset: &'static str,
    max_error: &'static str,
    avg_error: &'static str,
    diff_pixels: &'static str,
) -> T1Row {
    T1Row {
        dataset,
        max_error,
        avg_error,
        diff_pixels,
    }
}

const HAPT_T1: [T1Row; 6] = [
    t1("blunt", "1.961%", "0.4069%", "6.04%"),
    t1("post", "2.353%", "0.4245%", "33.13%"),
    t1("spx2", "1.569%", "0.3985%", "8.13%"),
    t1("delta", "5.098%", "0.5895%", "14.25%"),
    t1("torso", "1.176%", "0.3933%", "1.51%"),
    t1("fighter", "1.569%", "0.3943%", "2.02%"),
];

/// The orders HAPT Table 1 compares: the cheap one, the paper's yardstick (MPVONC, exact only
/// on convex meshes) and the exact one on non-convex meshes (xmpvo).
const T1_SORTS: [&str; 3] = ["centroid", "mpvonc", "xmpvo"];

/// The first projected-tetrahedra renderer that takes the three orders, CPU ones first: the
/// orders' images differ the same way on any PT renderer, and a CPU one is the fastest to run
/// 100 views with on a machine without a GPU.
fn t1_renderer() -> Option<&'static str> {
    let mut pt = render::family(Family::Pt);
    pt.sort_by_key(|i| i.needs_gpu);
    pt.into_iter()
        .find(|i| T1_SORTS.iter().all(|s| i.sorts.contains(s)))
        .map(|i| i.name)
}

fn hapt_t1_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let Some(r) = t1_renderer() else {
        return Err("needs a renderer with sorts `centroid`, `mpvonc` and `xmpvo` (cpu-pt, hapt); none is registered yet".into());
    };
    let mut c = base_config(ctx, "hapt-table1");
    c.datasets = HAPT_T1
        .iter()
        .map(|p| dataset(ctx, p.dataset, Some(20_000)))
        .collect();
    let spec = want(r, &T1_SORTS, &["partial"]).unwrap();
    let vars =
        experiment::expand_renderer(&spec, &experiment::default_tf(), std::path::Path::new("."))
            .map_err(|e| e.to_string())?;
    let label = |s: &str| {
        vars.iter()
            .find(|v| v.options.sort.as_deref() == Some(s))
            .map(|v| v.label.clone())
    };
    let (Some(a), Some(m), Some(x)) = (label("centroid"), label("mpvonc"), label("xmpvo")) else {
        return Err(format!("{r}: could not make the three sorts"));
    };
    // First pair: the paper's comparison (centroid against MPVONC); second: centroid against
    // the exact order.
    c.pairs = vec![
        PairSpec {
            test: a.clone(),
            reference: m,
        },
        PairSpec {
            test: a,
            reference: x,
        },
    ];
    c.renderers = vec![spec];
    // HAPT's protocol: at least 100 views over the sphere.
    c.views = ViewsSpec {
        named: vec![],
        fibonacci: if ctx.quick { 6 } else { 100 },
        rotate: None,
    };
    c.repeats = Some(1);
    c.warmup = Some(0);
    // Each order's own error against the reference, per view.
    c.error = Some(true);
    Ok(c)
}

fn hapt_t1_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for c in [
        "Dataset",
        "paper Max. Error",
        "paper Avg. Error",
        "paper Diff. Pixels",
        "mesh used",
        "# Tet",
        "views",
        "Max. Error",
        "Avg. Error",
        "Diff. Pixels",
        "vs xmpvo Max. Error",
        "vs xmpvo Avg. Error",
        "vs xmpvo Diff. Pixels",
        "centroid RMSE vs reference",
        "mpvonc RMSE vs reference",
        "xmpvo RMSE vs reference",
    ] {
        t.col(c, false);
    }
    let (paper, exact) = (cfg.pairs.first(), cfg.pairs.get(1));
    for p in &HAPT_T1 {
        let of = |pair: Option<&PairSpec>| -> Vec<&crate::rows::PairRow> {
            o.pairs
                .iter()
                .filter(|x| {
                    x.dataset == p.dataset
                        && pair.is_some_and(|q| q.test == x.test && q.reference == x.reference)
                })
                .collect()
        };
        let (ps, xs) = (of(paper), of(exact));
        if ps.is_empty() && xs.is_empty() {
            continue;
        }
        let metrics = |ps: &[&crate::rows::PairRow]| -> [String; 3] {
            if ps.is_empty() {
                return ["not measured".to_string(), String::new(), String::new()];
            }
            let n = ps.len() as f64;
            [
                format!(
                    "{:.3}%",
                    ps.iter().map(|x| x.max_err_pct).fold(0.0, f64::max)
                ),
                format!("{:.4}%", ps.iter().map(|x| x.avg_err_pct).sum::<f64>() / n),
                format!(
                    "{:.2}%",
                    ps.iter().map(|x| x.diff_pixels_pct).sum::<f64>() / n
                ),
            ]
        };
        let rm = |lab: Option<&String>| {
            lab.map_or("not measured".into(), |l| {
                measured(o, p.dataset, l).show(|a| f(a.rmse, 6))
            })
        };
        let first = ps.first().or(xs.first()).expect("a pair row");
        let [pm, pa, pd] = metrics(&ps);
        let [xm, xa, xd] = metrics(&xs);
        t.rows.push(vec![
            p.dataset.into(),
            p.max_error.into(),
            p.avg_error.into(),
            p.diff_pixels.into(),
            mesh_used(cfg, p.dataset),
            count(first.tets),
            ps.len().max(xs.len()).to_string(),
            pm,
            pa,
            pd,
            xm,
            xa,
            xd,
            rm(paper.map(|p| &p.test)),
            rm(paper.map(|p| &p.reference)),
            rm(exact.map(|p| &p.reference)),
        ]);
    }
    t.notes = common_notes(ctx, cfg);
    if let (Some(p), Some(x)) = (paper, exact) {
        t.notes.push(format!("Max. Error, Avg. Error, Diff. Pixels: `{}` against `{}` (the paper's comparison, centroid against MPVONC), image by image (CONVENTIONS §6 on 8-bit values): Max. Error = largest channel difference over all views; Avg. Error = mean over views of the mean difference of differing channels; Diff. Pixels = mean over views of the share of non-background pixels that differ. The `vs xmpvo` columns: the same metrics of `{}` against `{}`, the order that is exact at image resolution on non-convex meshes too (docs/sorts.md). RMSE vs reference: each order's own error against the exact reference, mean over the views.", p.test, p.reference, x.test, x.reference));
    }
    t
}

// HAPT Table 2.

/// Frames per second and M tet/s, as printed.
struct Rate {
    fps: &'static str,
    mtets_per_s: &'static str,
}

/// A row of HAPT's Table 2: sizes and rates in DVR, ISO and DVR+ISO.
struct T2Row {
    dataset: &'static str,
    vertices: &'static str,
    tets: &'static str,
    dvr: Rate,
    iso: Rate,
    dvr_iso: Rate,
}

impl T2Row {
    /// The paper's cells of this row.
    fn head(&self) -> Vec<String> {
        [
            self.dataset,
            self.vertices,
            self.tets,
            self.dvr.fps,
            self.dvr.mtets_per_s,
            self.iso.fps,
            self.iso.mtets_per_s,
            self.dvr_iso.fps,
            self.dvr_iso.mtets_per_s,
        ]
        .map(String::from)
        .to_vec()
    }
}

const fn t2(
    dataset: &'static str,
    vertices: &'static str,
    tets: &'static str,
    r: [&'static str; 6],
) -> T2Row {
    T2Row {
        dataset,
        vertices,
        tets,
        dvr: Rate {
            fps: r[0],
            mtets_per_s: r[1],
        },
        iso: Rate {
            fps: r[2],
            mtets_per_s: r[3],
        },
        dvr_iso: Rate {
            fps: r[4],
            mtets_per_s: r[5],
        },
    }
}

const HAPT_T2: [T2Row; 6] = [
    t2(
        "blunt",
        "40 K",
        "187 K",
        ["19.2", "3.59", "25.5", "4.78", "7.7", "1.44"],
    ),
    t2(
        "post",
        "110 K",
        "513 K",
        ["8.1", "4.15", "11.9", "6.10", "3.0", "1.51"],
    ),
    t2(
        "spx2",
        "150 K",
        "828 K",
        ["7.4", "6.11", "8.2", "6.76", "1.9", "1.57"],
    ),
    t2(
        "delta",
        "211 K",
        "1 M",
        ["4.5", "4.52", "6.0", "6.01", "1.5", "1.51"],
    ),
    t2(
        "torso",
        "168 K",
        "1.08 M",
        ["5.6", "6.08", "7.2", "7.78", "1.7", "1.82"],
    ),
    t2(
        "fighter",
        "256 K",
        "1.40 M",
        ["4.2", "5.83", "5.0", "7.06", "1.1", "1.60"],
    ),
];

/// The iso-surface modes of HAPT Table 2 and the `mode` parameter value of each.
const ISO_MODES: [(&str, &str); 2] = [("ISO", "iso"), ("DVR+ISO", "dvr+iso")];

fn hapt_t2_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "hapt-table2");
    c.datasets = HAPT_T2
        .iter()
        .map(|p| dataset(ctx, p.dataset, Some(40_000)))
        .collect();
    c.renderers = pt_family(false);
    // HAPT's ISO and DVR+ISO columns: iso-surfaces at 30% and 60% of each field's range, by
    // every PT renderer whose entry declares the `mode` and `iso` parameters. Left out of
    // --quick: lavapipe draws them slowly (the quick run must stay short).
    let iso_renderers = render::family(Family::Pt).into_iter().filter(|r| {
        ["mode", "iso"]
            .iter()
            .all(|k| r.params.iter().any(|p| p.name == *k))
    });
    for info in iso_renderers.filter(|_| !ctx.quick) {
        for (_, mode) in ISO_MODES {
            if let Some(mut r) = want(info.name, &[], &["partial"]) {
                r.params.insert("mode".into(), mode.into());
                r.params.insert("iso".into(), "30%,60%".into());
                c.renderers.push(r);
            }
        }
    }
    c.renderers.extend(ray_casters(false));
    // The other programs' renderers (VTK's mappers, declared peers) in DVR, beside ours.
    c.renderers.extend(external_peers());
    c.views = rotating(ctx, 3, 3);
    Ok(c)
}

/// The variant label without its `[params]`, and the `mode` it was given (None: DVR).
fn split_mode(label: &str) -> (&str, Option<&str>) {
    match label.split_once('[') {
        None => (label, None),
        Some((base, params)) => {
            let mode = params
                .trim_end_matches(']')
                .split(',')
                .find_map(|kv| kv.strip_prefix("mode="));
            (base, mode)
        }
    }
}

fn hapt_t2_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("Dataset", false),
        ("paper # Verts", false),
        ("paper # Tet", false),
        ("paper DVR FPS", true),
        ("paper DVR M Tet/s", true),
        ("paper ISO FPS", true),
        ("paper ISO M Tet/s", true),
        ("paper DVR+ISO FPS", true),
        ("paper DVR+ISO M Tet/s", true),
        ("mesh used", false),
        ("# Verts", false),
        ("# Tet", false),
        ("variant", false),
        ("DVR FPS", true),
        ("DVR M Tet/s", true),
        ("DVR RMSE", false),
        ("ISO FPS", true),
        ("ISO M Tet/s", true),
        ("DVR+ISO FPS", true),
        ("DVR+ISO M Tet/s", true),
        ("CPU B/tet", false),
        ("GPU B/tet", false),
    ] {
        t.col(c, hw);
    }
    // One row per variant drawn in DVR; its ISO and DVR+ISO runs (same label with a `mode`
    // parameter) fill the ISO columns of that row.
    let all = variants(o);
    let dvr: Vec<&String> = all.iter().filter(|v| split_mode(v).1.is_none()).collect();
    let with_mode = |base: &str, mode: &str| {
        all.iter()
            .find(|v| split_mode(v) == (base, Some(mode)))
            .cloned()
    };
    for p in &HAPT_T2 {
        for v in &dvr {
            let a = match measured(o, p.dataset, v) {
                Measured::Ok(a) => a,
                Measured::Failed(m) => {
                    let (vertices, tets) = sizes_of(o, p.dataset, v);
                    let mut row = p.head();
                    row.extend([
                        mesh_used(cfg, p.dataset),
                        count(vertices),
                        count(tets),
                        v.to_string(),
                    ]);
                    row.extend(failed_cells(m, 5 + 2 * ISO_MODES.len()));
                    t.rows.push(row);
                    continue;
                }
                Measured::Missing => continue,
            };
            let mut row: Vec<String> = p.head();
            row.extend([
                mesh_used(cfg, p.dataset),
                count(a.vertices),
                count(a.tets),
                v.to_string(),
                f(a.fps, 2),
                f(a.tets_per_s / 1e6, 3),
                f(a.rmse, 5),
            ]);
            for (_, mode) in ISO_MODES {
                let m =
                    with_mode(v, mode).map_or(Measured::Missing, |l| measured(o, p.dataset, &l));
                row.push(m.show(|m| f(m.fps, 2)));
                row.push(m.show(|m| f(m.tets_per_s / 1e6, 3)));
            }
            row.push(f(a.cpu_b, 1));
            row.push(f(a.gpu_b, 1));
            t.rows.push(row);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push(external_note());
    t.notes.push("ISO and DVR+ISO: iso-surfaces at 30 % and 60 % of the field's range, drawn by the renderers that take `mode` and `iso` parameters (hapt), in full runs only. They have no RMSE: the exact reference draws no iso-surfaces, and an image error against the DVR reference would measure the surfaces, not the renderer.".into());
    t.notes.push("Paper: HAPT on a Xeon E5345 with a GeForce 8800 GTX; turbjet (time-varying, 150 × 1 M tets, 17.5 fps DVR) is not reproduced.".into());
    t
}
