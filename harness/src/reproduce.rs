//! `tetbench reproduce`: the experiments behind the papers' tables, as a list of table specs.
//!
//! A [`TableSpec`] names the paper's table, builds an experiment from whatever renderers the
//! registry holds (so `ptint`, `hapt`, `cpu-pt` and its sorts slot in when they land, with no
//! change here), and lays the measured rows out beside the paper's own figures. Each table is
//! written as `DIR/<id>.csv` and `DIR/<id>.md` with its plots; raw rows go to `DIR/raw/<id>/`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use algorithms::render::{self, Family};
use algorithms::{Error, Result};

use crate::bcc;
use crate::bench::{self, Outcome};
use crate::experiment::{
    self, Config, DatasetSpec, OneOrMany, PairSpec, RendererSpec, RotateSpec, ViewsSpec,
};
use crate::plots;
use crate::rows::Row;
use crate::stats;
use crate::table::{count, fixed as f, plot_notes, write_table, Table};

/// What a spec is built with.
pub struct Ctx {
    pub quick: bool,
}

/// One of the papers' tables.
pub struct TableSpec {
    pub id: &'static str,
    pub title: &'static str,
    /// The experiment, or why it cannot run with the renderers registered now.
    pub experiment: fn(&Ctx) -> std::result::Result<Config, String>,
    pub build: fn(&Ctx, &Config, &Outcome) -> Table,
    pub plots: fn(&Outcome, &Path) -> Result<Vec<PathBuf>>,
}

/// The tables `reproduce` writes, in order.
pub fn specs() -> Vec<TableSpec> {
    vec![
        TableSpec {
            id: "ptint-table1",
            title: "PTINT Table 1: data set sizes and average frame rates (rotating model, 512²)",
            experiment: ptint_t1_exp,
            build: ptint_t1_build,
            plots: |o, d| {
                let mut v = plots::tets_per_s_vs_size(&o.rows, &d.join("ptint-table1-tets_per_s"))?;
                v.extend(plots::speed_vs_error(&o.rows, &d.join("ptint-table1-speed_vs_error"))?);
                Ok(v)
            },
        },
        TableSpec {
            id: "ptint-table2",
            title: "PTINT Table 2: frame rates against other algorithms (blunt, post, 512², rotating)",
            experiment: ptint_t2_exp,
            build: ptint_t2_build,
            plots: |o, d| plots::speed_vs_error(&o.rows, &d.join("ptint-table2-speed_vs_error")),
        },
        TableSpec {
            id: "ptint-fig8",
            title: "PTINT Figure 8: frame time and K tet/s against viewport size (post)",
            experiment: ptint_fig8_exp,
            build: ptint_fig8_build,
            plots: |o, d| plots::time_vs_viewport(&o.rows, &d.join("ptint-fig8-time_vs_viewport")),
        },
        TableSpec {
            id: "hapt-table1",
            title: "HAPT Table 1: image error between centroid sorting and MPVONC (views over a sphere)",
            experiment: hapt_t1_exp,
            build: hapt_t1_build,
            plots: |o, d| plots::pair_errors(&o.pairs, &d.join("hapt-table1-centroid_vs_mpvonc")),
        },
        TableSpec {
            id: "hapt-table2",
            title: "HAPT Table 2: dataset sizes and frame rates, direct volume rendering (512², rotating)",
            experiment: hapt_t2_exp,
            build: hapt_t2_build,
            plots: |o, d| plots::tets_per_s_vs_size(&o.rows, &d.join("hapt-table2-tets_per_s")),
        },
        TableSpec {
            id: "hapt-table3",
            title: "HAPT Table 3: sort and draw time per algorithm on spx2 (828K tets, 512²)",
            experiment: hapt_t3_exp,
            build: hapt_t3_build,
            plots: |o, d| {
                let mut v = plots::stage_bars(
                    &o.rows,
                    &d.join("hapt-table3-stages"),
                    "spx2: time per stage and variant",
                )?;
                v.extend(plots::speed_vs_error(&o.rows, &d.join("hapt-table3-speed_vs_error"))?);
                Ok(v)
            },
        },
        TableSpec {
            id: "hapt-table4",
            title: "HAPT Table 4: frame rates per algorithm on torso and fighter (512²)",
            experiment: hapt_t4_exp,
            build: hapt_t4_build,
            plots: |o, d| plots::speed_vs_error(&o.rows, &d.join("hapt-table4-speed_vs_error")),
        },
    ]
}

// ---------------------------------------------------------------------------------------------
// Renderer choice: from the registry, so new renderers appear without a change here.

/// A renderer with wanted sorts and integrators; kept only if registered, and only with the
/// sorts/integrators it accepts.
fn want(name: &str, sorts: &[&str], integrators: &[&str]) -> Option<RendererSpec> {
    let info = render::info(name).ok()?;
    let pick = |want: &[&str], have: &[&str]| -> Option<Vec<String>> {
        if want.is_empty() {
            return None;
        }
        if want == ["*"] {
            return Some(vec!["*".into()]);
        }
        let v: Vec<String> = want
            .iter()
            .filter(|w| have.contains(w))
            .map(|s| s.to_string())
            .collect();
        if v.is_empty() {
            None
        } else {
            Some(v)
        }
    };
    Some(RendererSpec {
        name: name.to_string(),
        sorts: if info.sorts.is_empty() {
            None
        } else {
            pick(sorts, info.sorts)
        },
        integrators: pick(integrators, info.integrators),
        ..Default::default()
    })
}

/// The largest mesh a GPU renderer draws in a full run when the adapter is a software
/// rasteriser (lavapipe draws ~0.1 M tet/s at 512²: a 1.4 M-tet frame takes tens of seconds).
/// On a real GPU there is no limit.
const SOFTWARE_GPU_MAX_TETS: usize = 600_000;

fn software_gpu() -> bool {
    algorithms::gpu::Gpu::shared()
        .map(|g| g.info.device_type == algorithms::gpu::wgpu::DeviceType::Cpu)
        .unwrap_or(false)
}

/// Projected-tetrahedra renderers (PTINT's family, every renderer the registry files under
/// [`Family::Pt`]) with partial pre-integration. With `all_sorts`, each with the sorts its entry
/// asks the papers' algorithm tables to measure (`table_sorts`); else with its default sort.
/// GPU renderers are capped on a software adapter.
fn pt_family(all_sorts: bool) -> Vec<RendererSpec> {
    let cap = software_gpu().then_some(SOFTWARE_GPU_MAX_TETS);
    render::family(Family::Pt)
        .into_iter()
        .filter_map(|info| {
            let sorts: &[&str] = if all_sorts { info.table_sorts } else { &[] };
            let mut r = want(info.name, sorts, &["partial"])?;
            if info.needs_gpu {
                r.max_tets = cap;
            }
            Some(r)
        })
        .collect()
}

/// The ray casters (HARC's family, the exact `reference` left out) standing in for HARC
/// (normal pre-integration) and HARC PPI (partial).
fn ray_casters(preint_too: bool) -> Vec<RendererSpec> {
    let ints: &[&str] = if preint_too {
        &["partial", "preint"]
    } else {
        &["partial"]
    };
    render::family(Family::RayCasting)
        .into_iter()
        .filter(|i| i.name != "reference")
        .filter_map(|i| want(i.name, &[], ints))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Datasets: the NASA grids when present, else their analogues; smaller meshes with --quick.

/// A paper dataset: its label, the real NASA short name (if any), its datasets-gen analogue,
/// and the tet count used with --quick (None: full size even in quick mode).
fn dataset(ctx: &Ctx, label: &str, quick_tets: Option<usize>) -> DatasetSpec {
    let nasa = ["blunt", "post", "comb"].contains(&label)
        && matches!(algorithms::io::resolve_short_name(label), Some(Ok(_)));
    let (mesh, tets) = if nasa && (!ctx.quick || quick_tets.is_none()) {
        (label.to_string(), None)
    } else {
        let gen = match label {
            "blunt" | "post" | "comb" => format!("{label}-like"),
            other => other.to_string(),
        };
        (gen, if ctx.quick { quick_tets } else { None })
    };
    DatasetSpec {
        mesh,
        tets,
        scalar: None,
        split: None,
        label: Some(label.to_string()),
    }
}

fn mesh_used(cfg: &Config, label: &str) -> String {
    cfg.datasets
        .iter()
        .find(|d| d.label.as_deref() == Some(label))
        .map(|d| match d.tets {
            Some(t) => format!("{}:{t}", d.mesh),
            None if ["blunt", "post", "comb"].contains(&d.mesh.as_str()) => {
                format!("{} (NASA)", d.mesh)
            }
            None => d.mesh.clone(),
        })
        .unwrap_or_default()
}

fn rotating(ctx: &Ctx, full_frames: usize, quick_frames: usize) -> ViewsSpec {
    ViewsSpec {
        named: vec![],
        fibonacci: 0,
        rotate: Some(RotateSpec {
            frames: if ctx.quick { quick_frames } else { full_frames },
            axis: "y".into(),
            start: Some("0,15".into()),
        }),
    }
}

fn base_config(ctx: &Ctx, name: &str) -> Config {
    Config {
        name: Some(name.to_string()),
        sizes: Some(vec![
            if ctx.quick { "128x128" } else { "512x512" }.to_string()
        ]),
        projection: Some(OneOrMany(vec!["ortho".into()])),
        tf: Some("default".into()),
        repeats: Some(2),
        warmup: Some(1),
        error: Some(true),
        save_images: Some(false),
        ..Default::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Formatting and aggregation.

fn rows_of<'a>(o: &'a Outcome, dataset: &str, variant: &str) -> Vec<&'a Row> {
    o.rows
        .iter()
        .filter(|r| r.dataset == dataset && r.variant == variant && r.total_ms.is_finite())
        .collect()
}

/// Aggregates over a set of rows (views): mean frame time → fps, tet/s; mean error.
struct Agg {
    tets: usize,
    vertices: usize,
    ms: f64,
    fps: f64,
    tets_per_s: f64,
    sort_ms: f64,
    draw_ms: f64,
    rmse: f64,
    cpu_b: f64,
    gpu_b: f64,
    setup_ms: f64,
}

fn agg(rows: &[&Row]) -> Agg {
    let mean =
        |g: &dyn Fn(&Row) -> f64| stats::mean(&rows.iter().map(|r| g(r)).collect::<Vec<_>>());
    // The papers average over a rotating model: mean frame time over the views.
    let ms = mean(&|r| r.total_ms);
    let tets = rows.first().map(|r| r.tets).unwrap_or(0);
    Agg {
        tets,
        vertices: rows.first().map(|r| r.vertices).unwrap_or(0),
        ms,
        fps: 1e3 / ms,
        tets_per_s: tets as f64 / (ms * 1e-3),
        sort_ms: mean(&|r| r.sort_ms),
        draw_ms: mean(&|r| r.draw_ms),
        rmse: mean(&|r| r.rmse.unwrap_or(f64::NAN)),
        cpu_b: rows
            .first()
            .map(|r| r.cpu_bytes_per_tet)
            .unwrap_or(f64::NAN),
        gpu_b: rows
            .first()
            .map(|r| r.gpu_bytes_per_tet)
            .unwrap_or(f64::NAN),
        setup_ms: rows.first().map(|r| r.setup_ms).unwrap_or(f64::NAN),
    }
}

fn variants(o: &Outcome) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in &o.rows {
        if !v.contains(&r.variant) {
            v.push(r.variant.clone());
        }
    }
    v
}

/// `*` matches any run of characters.
pub fn glob(pattern: &str, s: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == s,
        Some((head, rest)) => {
            if !s.starts_with(head) {
                return false;
            }
            let s = &s[head.len()..];
            (0..=s.len()).any(|i| s.is_char_boundary(i) && glob(rest, &s[i..]))
        }
    }
}

fn common_notes(ctx: &Ctx, cfg: &Config) -> Vec<String> {
    let mut n = vec![
        format!(
            "Measured: {} image(s) {}, views {}, {} measured frame(s) per view after {} warm-up frame(s); fps = 1000 / mean frame time over the views (the papers' rotating model); {}",
            cfg.sizes.as_ref().map(|s| s.join(", ")).unwrap_or_default(),
            cfg.projection.as_ref().map(|p| p.0.join(", ")).unwrap_or_default(),
            describe_views(&cfg.views),
            cfg.repeats.unwrap_or(3),
            cfg.warmup.unwrap_or(1),
            if cfg.error == Some(false) {
                "no image was compared with the exact reference in this run (— in the RMSE columns)."
            } else {
                "errors are RMSE against the `reference` renderer (exact integrator)."
            }
        ),
        "CPU B/tet: heap bytes the renderer keeps after `prepare` (counting allocator); GPU B/tet: the renderer's buffers and textures.".into(),
    ];
    if ctx.quick {
        n.push("`--quick`: smaller meshes (see 'mesh used'), smaller images and fewer views than the paper; rates are not comparable to the paper's at face value.".into());
    }
    if let Some(cap) = cfg.renderers.iter().find_map(|r| r.max_tets) {
        n.push(format!("The GPU adapter is a software rasteriser (see README.md): the ptint and hapt rows of the papers' direct volume rendering variants are measured on meshes up to {cap} tets only (HAPT Table 2's ISO and DVR+ISO rows on all), and their rates say what the algorithms cost on a CPU emulating a GPU, not GPU speed. Rerun on a real GPU for the other rows."));
    }
    n
}

fn describe_views(v: &ViewsSpec) -> String {
    let mut s = Vec::new();
    if !v.named.is_empty() {
        s.push(v.named.join(" "));
    }
    if v.fibonacci > 0 {
        s.push(format!("{} Fibonacci views over the sphere", v.fibonacci));
    }
    if let Some(r) = &v.rotate {
        s.push(format!(
            "{} frames of a rotation about {} from {}",
            r.frames,
            r.axis,
            r.start.as_deref().unwrap_or("0,0")
        ));
    }
    s.join(", ")
}

// ---------------------------------------------------------------------------------------------
// PTINT Table 1.

/// (label, vertices, tets, fps, K tet/s) from the paper.
const PTINT_T1: [(&str, &str, &str, &str, &str); 7] = [
    ("spx", "2.9 K", "13 K", "95.32", "1233.2"),
    ("blunt", "40 K", "187 K", "11.30", "2119.7"),
    ("comb", "47 K", "215 K", "9.32", "2005.4"),
    ("post", "110 K", "513 K", "4.49", "2384.4"),
    ("spx2", "150 K", "828 K", "3.04", "2526.9"),
    ("fuel", "262 K", "1.5 M", "1.49", "2246.0"),
    ("brain", "950 K", "5.5 M", "0.46", "2560.8"),
];

fn ptint_t1_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "ptint-table1");
    let q: [Option<usize>; 7] = [
        None,
        Some(40_000),
        Some(40_000),
        Some(60_000),
        Some(60_000),
        Some(60_000),
        Some(60_000),
    ];
    c.datasets = PTINT_T1
        .iter()
        .zip(q)
        .map(|(p, q)| dataset(ctx, p.0, q))
        .collect();
    c.renderers = pt_family(false);
    c.renderers.extend(ray_casters(false));
    c.views = rotating(ctx, 3, 3);
    Ok(c)
}

fn ptint_t1_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("Dataset", false),
        ("paper # Vertices", false),
        ("paper # Tet", false),
        ("paper fps", true),
        ("paper K tet/s", true),
        ("mesh used", false),
        ("# Vertices", false),
        ("# Tet", false),
        ("variant", false),
        ("fps", true),
        ("K tet/s", true),
        ("RMSE", false),
        ("CPU B/tet", false),
        ("GPU B/tet", false),
        ("setup ms", true),
    ] {
        t.col(c, hw);
    }
    for p in PTINT_T1 {
        for v in variants(o) {
            let rs = rows_of(o, p.0, &v);
            if rs.is_empty() {
                continue;
            }
            let a = agg(&rs);
            t.rows.push(vec![
                p.0.into(),
                p.1.into(),
                p.2.into(),
                p.3.into(),
                p.4.into(),
                mesh_used(cfg, p.0),
                count(a.vertices),
                count(a.tets),
                v.clone(),
                f(a.fps, 2),
                f(a.tets_per_s / 1e3, 1),
                f(a.rmse, 5),
                f(a.cpu_b, 1),
                f(a.gpu_b, 1),
                f(a.setup_ms, 0),
            ]);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push("Paper: PTINT on a Pentium IV 3.6 GHz with a GeForce 6800 (GPU); 512² viewport, rotating model; its 20 bytes/tet is GPU memory.".into());
    t
}

// ---------------------------------------------------------------------------------------------
// Algorithm tables (PTINT Table 2, HAPT Tables 3 and 4): paper rows, each with the variants
// standing in for it.

/// A paper row: name, the paper's figures, variant-label patterns that stand in for it.
struct PaperRow {
    name: &'static str,
    values: &'static [&'static str],
    ours: &'static [&'static str],
}

/// Rows: each paper row with its matching variants (or none), then variants no row claims.
/// `measure` gives the measured cells of one variant.
fn algo_rows(
    paper: &[PaperRow],
    paper_cols: usize,
    vars: &[String],
    measure: &dyn Fn(&str) -> Vec<String>,
    measured_cols: usize,
) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut claimed = vec![false; vars.len()];
    for p in paper {
        let mine: Vec<usize> = (0..vars.len())
            .filter(|&i| p.ours.iter().any(|pat| glob(pat, &vars[i])))
            .collect();
        let head = |r: &mut Vec<String>| {
            r.push(p.name.to_string());
            r.extend(p.values.iter().map(|s| s.to_string()));
        };
        if mine.is_empty() {
            let mut r = Vec::new();
            head(&mut r);
            // Registered but without rows (e.g. a GPU renderer capped on a software adapter)
            // is not the same as not implemented.
            let registered = p.ours.iter().any(|pat| {
                let name = pat.split(['/', '*']).next().unwrap_or("");
                !name.is_empty() && render::info(name).is_ok()
            });
            r.push(if registered {
                "— (not measured in this run)".into()
            } else {
                "— (not implemented)".into()
            });
            r.extend(std::iter::repeat_n("—".to_string(), measured_cols));
            out.push(r);
        }
        for i in mine {
            claimed[i] = true;
            let mut r = Vec::new();
            head(&mut r);
            r.push(vars[i].clone());
            r.extend(measure(&vars[i]));
            out.push(r);
        }
    }
    for (i, v) in vars.iter().enumerate() {
        if !claimed[i] {
            let mut r = vec!["(no paper row)".to_string()];
            r.extend(std::iter::repeat_n("—".to_string(), paper_cols));
            r.push(v.clone());
            r.extend(measure(v));
            out.push(r);
        }
    }
    out
}

const PTINT_T2: &[PaperRow] = &[
    PaperRow {
        name: "GPU CP for Int. VR (PTINT)",
        values: &["11.30", "4.49"],
        ours: &["ptint*", "cpu-pt*"],
    },
    PaperRow {
        name: "GATOR",
        values: &["4.07", "1.51"],
        ours: &[],
    },
    PaperRow {
        name: "HARC",
        values: &["4.47", "8.63"],
        ours: &["raycast/preint"],
    },
    PaperRow {
        name: "HARC PPI",
        values: &["4.94", "5.93"],
        ours: &["raycast/partial"],
    },
    PaperRow {
        name: "VICP",
        values: &["5.20", "1.93"],
        ours: &[],
    },
];

fn ptint_t2_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "ptint-table2");
    c.datasets = vec![
        dataset(ctx, "blunt", Some(40_000)),
        dataset(ctx, "post", Some(60_000)),
    ];
    c.renderers = pt_family(false);
    c.renderers.extend(ray_casters(true));
    c.views = rotating(ctx, 3, 3);
    Ok(c)
}

fn ptint_t2_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("Algorithm (paper)", false),
        ("paper Blunt fps", true),
        ("paper Post fps", true),
        ("our variant", false),
        ("Blunt fps", true),
        ("Post fps", true),
        ("Blunt K tet/s", true),
        ("Post K tet/s", true),
        ("Blunt RMSE", false),
        ("Post RMSE", false),
        ("CPU B/tet (post)", false),
        ("GPU B/tet (post)", false),
    ] {
        t.col(c, hw);
    }
    let m = |v: &str| {
        let b = agg(&rows_of(o, "blunt", v));
        let p = agg(&rows_of(o, "post", v));
        vec![
            f(b.fps, 2),
            f(p.fps, 2),
            f(b.tets_per_s / 1e3, 1),
            f(p.tets_per_s / 1e3, 1),
            f(b.rmse, 5),
            f(p.rmse, 5),
            f(p.cpu_b, 1),
            f(p.gpu_b, 1),
        ]
    };
    t.rows = algo_rows(PTINT_T2, 2, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push("Stand-ins: the CPU ray caster `raycast` for HARC (with `preint`) and HARC PPI (with `partial`); `cpu-pt`/`ptint` for PTINT. The paper's bytes/tet: PTINT 20, HARC PPI 96, HARC 144 (GPU).".into());
    t.notes.push(format!(
        "Blunt mesh used: {}; post mesh used: {}.",
        mesh_used(cfg, "blunt"),
        mesh_used(cfg, "post")
    ));
    t
}

// ---------------------------------------------------------------------------------------------
// PTINT Figure 8.

fn ptint_fig8_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "ptint-fig8");
    c.datasets = vec![dataset(ctx, "post", Some(60_000))];
    c.sizes = Some(
        if ctx.quick {
            vec!["64x64", "128x128", "256x256"]
        } else {
            vec!["128x128", "256x256", "512x512", "768x768", "1024x1024"]
        }
        .into_iter()
        .map(String::from)
        .collect(),
    );
    c.renderers = pt_family(false);
    c.renderers.extend(ray_casters(false));
    c.views = rotating(ctx, 2, 2);
    Ok(c)
}

fn ptint_fig8_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("viewport", false),
        ("paper K tet/s", true),
        ("variant", false),
        ("ms per frame", true),
        ("fps", true),
        ("K tet/s", true),
        ("RMSE", false),
    ] {
        t.col(c, hw);
    }
    let mut sizes: Vec<(u32, u32)> = Vec::new();
    for r in &o.rows {
        if !sizes.contains(&(r.width, r.height)) {
            sizes.push((r.width, r.height));
        }
    }
    for (w, h) in sizes {
        for v in variants(o) {
            let rs: Vec<&Row> = o
                .rows
                .iter()
                .filter(|r| {
                    r.variant == v && r.width == w && r.height == h && r.total_ms.is_finite()
                })
                .collect();
            if rs.is_empty() {
                continue;
            }
            let a = agg(&rs);
            t.rows.push(vec![
                format!("{w}x{h}"),
                if (w, h) == (512, 512) {
                    "2384.4 (Table 1)".into()
                } else {
                    "—".into()
                },
                v.clone(),
                f(a.ms, 2),
                f(a.fps, 2),
                f(a.tets_per_s / 1e3, 1),
                f(a.rmse, 5),
            ]);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push(format!("Mesh used: {}. The paper's Figure 8 (K tet/s over animation time for several resolutions on post) is not in the text we have; its Table 1 gives 2384.4 K tet/s for post at 512².", mesh_used(cfg, "post")));
    t
}

// ---------------------------------------------------------------------------------------------
// HAPT Table 1.

const HAPT_T1: [(&str, &str, &str, &str); 6] = [
    ("blunt", "1.961%", "0.4069%", "6.04%"),
    ("post", "2.353%", "0.4245%", "33.13%"),
    ("spx2", "1.569%", "0.3985%", "8.13%"),
    ("delta", "5.098%", "0.5895%", "14.25%"),
    ("torso", "1.176%", "0.3933%", "1.51%"),
    ("fighter", "1.569%", "0.3943%", "2.02%"),
];

/// The first projected-tetrahedra renderer that takes both `centroid` and `mpvonc`, CPU ones
/// first: the two orders' images differ the same way on any PT renderer, and a CPU one is the
/// fastest to run 100 views with on a machine without a GPU.
fn centroid_mpvonc_renderer() -> Option<&'static str> {
    let mut pt = render::family(Family::Pt);
    pt.sort_by_key(|i| i.needs_gpu);
    pt.into_iter()
        .find(|i| i.sorts.contains(&"centroid") && i.sorts.contains(&"mpvonc"))
        .map(|i| i.name)
}

fn hapt_t1_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let Some(r) = centroid_mpvonc_renderer() else {
        return Err("needs a renderer with sorts `centroid` and `mpvonc` (cpu-pt, hapt); none is registered yet".into());
    };
    let mut c = base_config(ctx, "hapt-table1");
    c.datasets = HAPT_T1
        .iter()
        .map(|p| dataset(ctx, p.0, Some(20_000)))
        .collect();
    let spec = want(r, &["centroid", "mpvonc"], &["partial"]).unwrap();
    let vars = experiment::expand_renderer(&spec).map_err(|e| e.to_string())?;
    let label = |s: &str| {
        vars.iter()
            .find(|v| v.options.sort.as_deref() == Some(s))
            .map(|v| v.label.clone())
    };
    let (Some(a), Some(b)) = (label("centroid"), label("mpvonc")) else {
        return Err(format!("{r}: could not make both sorts"));
    };
    c.pairs = vec![PairSpec {
        test: a,
        reference: b,
    }];
    c.renderers = vec![spec];
    c.views = ViewsSpec {
        named: vec![],
        fibonacci: if ctx.quick { 6 } else { 50 },
        rotate: None,
    };
    c.repeats = Some(1);
    c.warmup = Some(0);
    // The table is the error between the two orders. In a full run (50 views of six meshes
    // at 512²) an exact reference per view would cost more than everything else together;
    // the other tables give each order's error against the reference.
    c.error = Some(ctx.quick);
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
        "centroid RMSE vs reference",
        "mpvonc RMSE vs reference",
    ] {
        t.col(c, false);
    }
    let pair = cfg.pairs.first();
    for p in HAPT_T1 {
        let ps: Vec<_> = o.pairs.iter().filter(|x| x.dataset == p.0).collect();
        if ps.is_empty() {
            continue;
        }
        let n = ps.len() as f64;
        let rm = |lab: Option<&String>| {
            lab.map(|l| f(agg(&rows_of(o, p.0, l)).rmse, 5))
                .unwrap_or_else(|| "—".into())
        };
        t.rows.push(vec![
            p.0.into(),
            p.1.into(),
            p.2.into(),
            p.3.into(),
            mesh_used(cfg, p.0),
            count(ps[0].tets),
            ps.len().to_string(),
            format!(
                "{:.3}%",
                ps.iter().map(|x| x.max_err_pct).fold(0.0, f64::max)
            ),
            format!("{:.4}%", ps.iter().map(|x| x.avg_err_pct).sum::<f64>() / n),
            format!(
                "{:.2}%",
                ps.iter().map(|x| x.diff_pixels_pct).sum::<f64>() / n
            ),
            rm(pair.map(|p| &p.test)),
            rm(pair.map(|p| &p.reference)),
        ]);
    }
    t.notes = common_notes(ctx, cfg);
    if let Some(p) = pair {
        t.notes.push(format!("Test `{}` against `{}` image by image (CONVENTIONS §6 on 8-bit values): Max. Error = largest channel difference over all views; Avg. Error = mean over views of the mean difference of differing channels; Diff. Pixels = mean over views of the share of non-background pixels that differ.", p.test, p.reference));
    }
    t
}

// ---------------------------------------------------------------------------------------------
// HAPT Table 2.

/// (label, verts, tets, DVR fps, DVR M tet/s, ISO fps, ISO M, DVR+ISO fps, DVR+ISO M).
/// A row of the paper's Table 2.
type HaptT2Row = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
);

const HAPT_T2: [HaptT2Row; 6] = [
    (
        "blunt", "40 K", "187 K", "19.2", "3.59", "25.5", "4.78", "7.7", "1.44",
    ),
    (
        "post", "110 K", "513 K", "8.1", "4.15", "11.9", "6.10", "3.0", "1.51",
    ),
    (
        "spx2", "150 K", "828 K", "7.4", "6.11", "8.2", "6.76", "1.9", "1.57",
    ),
    (
        "delta", "211 K", "1 M", "4.5", "4.52", "6.0", "6.01", "1.5", "1.51",
    ),
    (
        "torso", "168 K", "1.08 M", "5.6", "6.08", "7.2", "7.78", "1.7", "1.82",
    ),
    (
        "fighter", "256 K", "1.40 M", "4.2", "5.83", "5.0", "7.06", "1.1", "1.60",
    ),
];

fn hapt_t2_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "hapt-table2");
    c.datasets = HAPT_T2
        .iter()
        .map(|p| dataset(ctx, p.0, Some(40_000)))
        .collect();
    c.renderers = pt_family(false);
    // HAPT's ISO and DVR+ISO columns: iso-surfaces at 30% and 60% of each field's range.
    // Left out of --quick: lavapipe draws them slowly (the quick run must stay short).
    for mode in ["iso", "dvr+iso"].into_iter().filter(|_| !ctx.quick) {
        if let Some(mut r) = want("hapt", &[], &["partial"]) {
            r.params.insert("mode".into(), mode.into());
            r.params.insert("iso".into(), "30%,60%".into());
            c.renderers.push(r);
        }
    }
    c.renderers.extend(ray_casters(false));
    c.views = rotating(ctx, 3, 3);
    Ok(c)
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
        ("RMSE", false),
        ("CPU B/tet", false),
        ("GPU B/tet", false),
        ("mode (DVR, ISO, DVR+ISO)", false),
    ] {
        t.col(c, hw);
    }
    for p in HAPT_T2 {
        for v in variants(o) {
            let rs = rows_of(o, p.0, &v);
            if rs.is_empty() {
                continue;
            }
            let a = agg(&rs);
            t.rows.push(vec![
                p.0.into(),
                p.1.into(),
                p.2.into(),
                p.3.into(),
                p.4.into(),
                p.5.into(),
                p.6.into(),
                p.7.into(),
                p.8.into(),
                mesh_used(cfg, p.0),
                count(a.vertices),
                count(a.tets),
                v.clone(),
                f(a.fps, 2),
                f(a.tets_per_s / 1e6, 3),
                f(a.rmse, 5),
                f(a.cpu_b, 1),
                f(a.gpu_b, 1),
                if v.contains("mode=iso") {
                    "ISO (the FPS columns)".into()
                } else if v.contains("mode=dvr+iso") {
                    "DVR+ISO (the FPS columns)".into()
                } else {
                    "DVR".into()
                },
            ]);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push("Paper: HAPT on a Xeon E5345 with a GeForce 8800 GTX; turbjet (time-varying, 150 × 1 M tets, 17.5 fps DVR) is not reproduced.".into());
    t
}

// ---------------------------------------------------------------------------------------------
// HAPT Tables 3 and 4.

const HAPT_T3: &[PaperRow] = &[
    PaperRow {
        name: "HAPT Q (GPU quicksort)",
        values: &["0.03", "0.09", "7.4", "6.11"],
        ours: &["hapt/gpu-radix*"],
    },
    PaperRow {
        name: "HAPT B (GPU bitonic)",
        values: &["0.04", "0.09", "6.9", "5.73"],
        ours: &["hapt/gpu-bitonic*"],
    },
    PaperRow {
        name: "HAPT S (CPU STL sort)",
        values: &["0.08", "0.09", "5.4", "4.50"],
        ours: &[
            "hapt/centroid*",
            "cpu-pt/centroid/*",
            "cpu-pt/centroid-par/*",
            "cpu-pt/centroid-radix/*",
            "cpu-pt/bucket*",
        ],
    },
    PaperRow {
        name: "HAPT M (MPVONC)",
        values: &["0.13", "0.09", "4.4", "3.61"],
        ours: &["hapt/mpvonc*", "cpu-pt/mpvonc*"],
    },
    PaperRow {
        name: "HAVS k=2",
        values: &["0.09", "0.11", "5.0", "4.14"],
        ours: &[],
    },
    PaperRow {
        name: "HAVS k=6",
        values: &["0.09", "0.12", "4.7", "3.94"],
        ours: &[],
    },
    PaperRow {
        name: "PTINT",
        values: &["0.19", "0.20", "2.4", "2.06"],
        ours: &["ptint*"],
    },
    PaperRow {
        name: "GATOR",
        values: &["0.08", "0.83", "1.1", "0.93"],
        ours: &[],
    },
    PaperRow {
        name: "HARC n (pre-integration)",
        values: &["n/a", "0.22", "4.6", "3.82"],
        ours: &["raycast/preint"],
    },
    PaperRow {
        name: "HARC p (partial pre-int.)",
        values: &["n/a", "0.28", "3.5", "2.90"],
        ours: &["raycast/partial"],
    },
];

fn algo_renderers() -> Vec<RendererSpec> {
    let mut r = pt_family(true);
    r.extend(ray_casters(true));
    r
}

fn hapt_t3_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "hapt-table3");
    c.datasets = vec![dataset(ctx, "spx2", Some(60_000))];
    c.renderers = algo_renderers();
    c.views = rotating(ctx, 3, 3);
    Ok(c)
}

fn hapt_t3_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("Algorithm (paper)", false),
        ("paper Sort s", true),
        ("paper Draw s", true),
        ("paper FPS", true),
        ("paper M Tet/s", true),
        ("our variant", false),
        ("Sort s", true),
        ("Draw s", true),
        ("Total s", true),
        ("FPS", true),
        ("M Tet/s", true),
        ("RMSE", false),
        ("CPU B/tet", false),
        ("GPU B/tet", false),
    ] {
        t.col(c, hw);
    }
    let m = |v: &str| {
        let a = agg(&rows_of(o, "spx2", v));
        vec![
            f(a.sort_ms / 1e3, 4),
            f(a.draw_ms / 1e3, 4),
            f(a.ms / 1e3, 4),
            f(a.fps, 2),
            f(a.tets_per_s / 1e6, 3),
            f(a.rmse, 5),
            f(a.cpu_b, 1),
            f(a.gpu_b, 1),
        ]
    };
    t.rows = algo_rows(HAPT_T3, 4, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push(format!("Mesh used: {}. Sort and draw are the renderers' own stage times (a ray caster has no sort stage: 0).", mesh_used(cfg, "spx2")));
    t
}

const HAPT_T4: &[PaperRow] = &[
    PaperRow {
        name: "HAPT Q",
        values: &["5.6", "6.08", "4.2", "5.83"],
        ours: &["hapt/gpu-radix*"],
    },
    PaperRow {
        name: "HAPT B",
        values: &["4.3", "4.68", "3.6", "5.09"],
        ours: &["hapt/gpu-bitonic*"],
    },
    PaperRow {
        name: "HAPT S",
        values: &["3.9", "4.25", "2.9", "4.10"],
        ours: &[
            "hapt/centroid*",
            "cpu-pt/centroid/*",
            "cpu-pt/centroid-par/*",
            "cpu-pt/centroid-radix/*",
            "cpu-pt/bucket*",
        ],
    },
    PaperRow {
        name: "HAPT M",
        values: &["1.6", "1.73", "1.2", "1.62"],
        ours: &["hapt/mpvonc*", "cpu-pt/mpvonc*"],
    },
    PaperRow {
        name: "HAVS k=2",
        values: &["3.7", "4.01", "2.9", "4.12"],
        ours: &[],
    },
    PaperRow {
        name: "HAVS k=6",
        values: &["3.3", "3.60", "2.7", "3.89"],
        ours: &[],
    },
    PaperRow {
        name: "PTINT",
        values: &["1.3", "1.47", "0.9", "1.31"],
        ours: &["ptint*"],
    },
    PaperRow {
        name: "GATOR",
        values: &["0.7", "0.76", "0.4", "0.56"],
        ours: &[],
    },
    PaperRow {
        name: "HARC n",
        values: &["4.8", "5.19", "3.8", "5.33"],
        ours: &["raycast/preint"],
    },
    PaperRow {
        name: "HARC p",
        values: &["3.9", "4.22", "3.0", "4.21"],
        ours: &["raycast/partial"],
    },
];

fn hapt_t4_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "hapt-table4");
    c.datasets = vec![
        dataset(ctx, "torso", Some(40_000)),
        dataset(ctx, "fighter", Some(40_000)),
    ];
    c.renderers = algo_renderers();
    c.views = rotating(ctx, 3, 3);
    Ok(c)
}

fn hapt_t4_build(ctx: &Ctx, cfg: &Config, o: &Outcome) -> Table {
    let mut t = Table::default();
    for (c, hw) in [
        ("Algorithm (paper)", false),
        ("paper torso FPS", true),
        ("paper torso M Tet/s", true),
        ("paper fighter FPS", true),
        ("paper fighter M Tet/s", true),
        ("our variant", false),
        ("torso FPS", true),
        ("torso M Tet/s", true),
        ("fighter FPS", true),
        ("fighter M Tet/s", true),
        ("torso RMSE", false),
        ("fighter RMSE", false),
        ("CPU B/tet (fighter)", false),
        ("GPU B/tet (fighter)", false),
    ] {
        t.col(c, hw);
    }
    let m = |v: &str| {
        let a = agg(&rows_of(o, "torso", v));
        let b = agg(&rows_of(o, "fighter", v));
        vec![
            f(a.fps, 2),
            f(a.tets_per_s / 1e6, 3),
            f(b.fps, 2),
            f(b.tets_per_s / 1e6, 3),
            f(a.rmse, 5),
            f(b.rmse, 5),
            f(b.cpu_b, 1),
            f(b.gpu_b, 1),
        ]
    };
    t.rows = algo_rows(HAPT_T4, 4, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push(format!(
        "Meshes used: torso {}, fighter {}.",
        mesh_used(cfg, "torso"),
        mesh_used(cfg, "fighter")
    ));
    t
}

// ---------------------------------------------------------------------------------------------

/// Runs every table (or those in `only`), writing tables, plots and `DIR/README.md`.
/// The id under which `--only` selects the JBU experiment (written as `jbu.csv`, `jbu.md`).
pub const JBU_ID: &str = "jbu";

/// What a table measures and how to read it, for `DIR/README.md`.
fn about(id: &str) -> &'static str {
    match id {
        "ptint-table1" => "Frame rate and tet/s of every projected-tetrahedra renderer (partial pre-integration) and the ray caster on the papers' datasets, the model rotating about the vertical axis. Each row carries its RMSE against the exact reference and its bytes per tet. Compare tet/s across rows of one run, not with the paper's 2006 GPU.",
        "ptint-table2" => "The same frame rates on blunt and post beside PTINT's competitors; our ray caster stands in for HARC (partial and full pre-integration). Rows without a counterpart here (GATOR, VICP) keep only the paper's figures.",
        "ptint-fig8" => "Frame time and K tet/s against the viewport size on post: how much of each renderer's time is per pixel (rasterisation, integration) and how much per tet (projection, sort).",
        "hapt-table1" => "Image error between the centroid order and MPVONC, HAPT Table 1's metrics (CONVENTIONS §6, on 8-bit values) over views spread over a sphere: how often and how much the cheap sort is wrong. Large maxima on non-convex meshes can come from MPVONC's own limitation there (see docs/conventions.md).",
        "hapt-table2" => "Dataset sizes and frame rates in direct volume rendering (and iso-surfaces where a renderer draws them), rotating, with error and memory per tet.",
        "hapt-table3" => "Sort and draw time per variant on the spx2 analogue: where each algorithm spends its frame (stacked bars), with the error each order costs.",
        "hapt-table4" => "Frame rates per variant on the torso and fighter analogues (1.1M and 1.4M tets).",
        JBU_ID => "Joint bilateral upsampling: time per rendering resolution (JBU Fig. 3/4) and RMSE of bilateral against linear upsampling (Fig. 5), for the ray caster and cpu-pt.",
        bcc::PT_ID => "CC against BCC sampling at equal information, rendered by projected tetrahedra with the implicit BCC order; error against a ground truth integrated from the analytic field.",
        bcc::RECON_ID => "Reconstruction schemes for ray casting a regular BCC volume against trilinear on CC: time and error per scheme (BCC paper Fig. 9).",
        _ => "",
    }
}

/// The status line of one table in `DIR/README.md`; kept in `DIR/raw/<id>/status.md` so that a
/// later `--only` run rewrites the README without losing the tables it did not rerun.
fn status_path(out: &Path, id: &str) -> PathBuf {
    out.join("raw").join(id).join("status.md")
}

fn write_status(out: &Path, id: &str, line: &str) -> Result<()> {
    let p = status_path(out, id);
    if let Some(d) = p.parent() {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    std::fs::write(&p, line).map_err(|e| Error::io(&p, e))
}

/// The GPU adapter the GPU renderers use, when one of them is registered and an adapter exists.
fn gpu_line() -> Option<String> {
    let gpu_renderers: Vec<&str> = render::REGISTRY
        .iter()
        .filter(|r| r.needs_gpu)
        .map(|r| r.name)
        .collect();
    if gpu_renderers.is_empty() {
        return None;
    }
    Some(match algorithms::gpu::Gpu::shared() {
        Ok(g) => format!(
            "{} ({}; render target {:?}){}",
            algorithms::gpu::describe(&g.info),
            gpu_renderers.join(", "),
            g.target_format,
            if g.info.device_type == algorithms::gpu::wgpu::DeviceType::Cpu {
                " — a software rasteriser: GPU rows measure correctness and relative cost, not GPU speed"
            } else {
                ""
            }
        ),
        Err(e) => format!("none ({e})"),
    })
}

pub fn run(quick: bool, out: &Path, only: &[String]) -> Result<()> {
    let ctx = Ctx { quick };
    let all = specs();
    for o in only {
        if o != JBU_ID && o != bcc::PT_ID && o != bcc::RECON_ID && !all.iter().any(|s| s.id == o) {
            return Err(Error::Input(format!(
                "--only {o}: no such table (tables: {}, {JBU_ID}, {}, {})",
                all.iter().map(|s| s.id).collect::<Vec<_>>().join(", "),
                bcc::PT_ID,
                bcc::RECON_ID
            )));
        }
    }
    let selected = |id: &str| only.is_empty() || only.iter().any(|o| o == id);
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let machine = crate::sysinfo::machine();
    let date = crate::sysinfo::now_utc();
    let started = Instant::now();
    let cache = out.join(".cache");
    for spec in all.iter().filter(|s| selected(s.id)) {
        let cfg = match (spec.experiment)(&ctx) {
            Ok(c) => c,
            Err(why) => {
                eprintln!("tetbench: {}: skipped: {why}", spec.id);
                write_status(out, spec.id, &format!("skipped: {why} ({date})"))?;
                continue;
            }
        };
        if cfg.renderers.is_empty() {
            write_status(
                out,
                spec.id,
                &format!("skipped: no renderer registered ({date})"),
            )?;
            continue;
        }
        let exp = experiment::validate(cfg.clone(), Path::new("."))?;
        let raw = out.join("raw").join(spec.id);
        let mut opts = bench::RunOptions::new(&exp, &raw);
        opts.cache_dir = cache.clone();
        opts.title = spec.id.to_string();
        let t0 = Instant::now();
        let o = bench::run(&exp, &opts)?;
        if o.interrupted {
            return Err(Error::Input(format!(
                "interrupted during {}: finished rows kept in {}",
                spec.id,
                raw.join("results.csv").display()
            )));
        }
        let mut table = (spec.build)(&ctx, &cfg, &o);
        table.id = spec.id.to_string();
        table.title = spec.title.to_string();
        let secs = t0.elapsed().as_secs_f64();
        table.notes.push(format!(
            "Raw rows: `raw/{}/results.csv`; this table took {secs:.0} s to measure.",
            spec.id
        ));
        let plots = (spec.plots)(&o, out)?;
        plot_notes(&mut table, &plots);
        write_table(&table, out, &machine, &date)?;
        println!(
            "table: {} ({} rows, {secs:.0} s)",
            out.join(format!("{}.md", spec.id)).display(),
            table.rows.len()
        );
        write_status(
            out,
            spec.id,
            &format!(
                "[{0}.md]({0}.md), [{0}.csv]({0}.csv): {1} rows, {2:.0} s ({date}{3})",
                spec.id,
                table.rows.len(),
                secs,
                if quick { ", --quick" } else { "" }
            ),
        )?;
    }
    if selected(JBU_ID) {
        // The JBU paper's Fig. 3/4 and 5: its own experiment, with its own table layout.
        let t0 = Instant::now();
        crate::jbu::run(&crate::jbu::Plan::new(quick), out)?;
        write_status(
            out,
            JBU_ID,
            &format!(
                "[{JBU_ID}.csv]({JBU_ID}.csv) and the `{JBU_ID}_time_*.svg` (Fig. 3/4), `{JBU_ID}_rmse_*.svg` (Fig. 5) plots: {:.0} s ({date}{})",
                t0.elapsed().as_secs_f64(),
                if quick { ", --quick" } else { "" }
            ),
        )?;
    }
    // The BCC paper's comparisons (issue 9): their own experiments (analytic fields and ground
    // truth, regular-volume ray casting), laid out as tables like the others.
    type BccTable = fn(bool, &Path) -> Result<(Table, Vec<PathBuf>)>;
    let bcc_tables: [(&str, &str, BccTable); 2] = [
        (
            bcc::PT_ID,
            "BCC paper §4 / Fig. 10: CC vs BCC at equal information with projected tetrahedra (cpu-pt, bcc-implicit), and empty-space skipping",
            bcc::pt_table,
        ),
        (
            bcc::RECON_ID,
            "BCC paper §3 / Fig. 9: ray casting with trilinear on CC and bil, bilspat, bary, shtril on BCC, time and error",
            bcc::recon_table,
        ),
    ];
    for &(id, title, build) in &bcc_tables {
        if !selected(id) {
            continue;
        }
        let t0 = Instant::now();
        let (mut table, plots) = build(quick, out)?;
        table.id = id.to_string();
        table.title = title.to_string();
        let secs = t0.elapsed().as_secs_f64();
        table
            .notes
            .push(format!("This table took {secs:.0} s to measure."));
        plot_notes(&mut table, &plots);
        write_table(&table, out, &machine, &date)?;
        println!(
            "table: {} ({} rows, {secs:.0} s)",
            out.join(format!("{id}.md")).display(),
            table.rows.len()
        );
        write_status(
            out,
            id,
            &format!(
                "[{id}.md]({id}.md), [{id}.csv]({id}.csv): {} rows, {secs:.0} s ({date}{})",
                table.rows.len(),
                if quick { ", --quick" } else { "" }
            ),
        )?;
    }
    let total = started.elapsed().as_secs_f64();

    // The README lists every table: this run's and, after an `--only` run, the earlier ones.
    let mut readme = format!(
        "# tetbench reproduce{}\n\n- machine: {machine}\n- threads: {}\n",
        if quick { " --quick" } else { "" },
        rayon::current_num_threads(),
    );
    if let Some(g) = gpu_line() {
        let _ = writeln!(readme, "- GPU adapter: {g}");
    }
    let _ = writeln!(
        readme,
        "- last run: {date}{}, {total:.0} s\n- renderers registered: {}\n\nEach table is a `.md` laid out like the paper's table, with the paper's own figures in the `paper …` columns, and a `.csv` of the same rows; the raw measurements (one row per frame and view, every row with its error against the exact reference and its bytes per tet) are in `raw/<table>/results.csv`. Columns marked † depend on the hardware (times and rates); sizes, errors and bytes per tet do not. The papers' GPU timings come from 2006–2010 hardware: compare rates between rows of one run, not with the paper.\n\n| table | what it measures | status |\n| --- | --- | --- |",
        if only.is_empty() {
            String::new()
        } else {
            format!(" (--only {})", only.join(","))
        },
        render::names().join(", ")
    );
    let ids: Vec<(&str, &str)> = all
        .iter()
        .map(|s| (s.id, s.title))
        .chain([(JBU_ID, "JBU Fig. 3/4 and Fig. 5")])
        .chain(bcc_tables.iter().map(|&(id, title, _)| (id, title)))
        .collect();
    for (id, title) in ids {
        let status = std::fs::read_to_string(status_path(out, id))
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "not run yet".into());
        let what = match about(id) {
            "" => title.to_string(),
            a => format!("**{title}.** {a}"),
        };
        let _ = writeln!(readme, "| {id} | {what} | {status} |");
    }
    let rp = out.join("README.md");
    std::fs::write(&rp, readme).map_err(|e| Error::io(&rp, e))?;
    println!("wall_time_s: {total:.1}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glob_matches() {
        assert!(glob("cpu-pt/centroid/*", "cpu-pt/centroid/partial"));
        assert!(!glob("cpu-pt/centroid/*", "cpu-pt/centroid-radix/partial"));
        assert!(glob("ptint*", "ptint/partial"));
        assert!(glob("raycast/preint", "raycast/preint"));
    }
}
