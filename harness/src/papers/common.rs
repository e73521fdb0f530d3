//! What the papers' tables share: renderers chosen from the registry by family, datasets (the
//! NASA grids when present, else their analogues), the experiment every table starts from,
//! aggregation over the views, the common notes, and the algorithm tables' paper rows.

use algorithms::render::peer::PeerFamily;
use algorithms::render::{self, Family};
use algorithms::Result;

pub(crate) use super::aggregate::*;
use super::{Ctx, Done, PaperTable};
use crate::bench::{self, Outcome};
use crate::experiment::{
    self, Config, DatasetSpec, OneOrMany, RendererSpec, RotateSpec, ViewsSpec,
};
use crate::table::Table;

// ---------------------------------------------------------------------------------------------
// Renderer choice: from the registry, so new renderers appear without a change here.

/// A renderer with wanted sorts and integrators; kept only if registered, and only with the
/// sorts/integrators it accepts.
pub(crate) fn want(name: &str, sorts: &[&str], integrators: &[&str]) -> Option<RendererSpec> {
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
pub(crate) const SOFTWARE_GPU_MAX_TETS: usize = 600_000;

pub(crate) fn software_gpu() -> bool {
    algorithms::gpu::Gpu::shared()
        .map(|g| g.info.device_type == algorithms::gpu::wgpu::DeviceType::Cpu)
        .unwrap_or(false)
}

/// Projected-tetrahedra renderers (PTINT's family, every renderer the registry files under
/// [`Family::Pt`]) with partial pre-integration. With `all_sorts`, each with the sorts its entry
/// asks the papers' algorithm tables to measure (`table_sorts`); else with its default sort.
/// GPU renderers are capped on a software adapter.
pub(crate) fn pt_family(all_sorts: bool) -> Vec<RendererSpec> {
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
pub(crate) fn ray_casters(preint_too: bool) -> Vec<RendererSpec> {
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

/// Meshes above this many tets get no row from a declared peer in the speed tables (another
/// program, whose frame time is unknown here).
pub(crate) const EXTERNAL_MAX_TETS: usize = 600_000;

/// VTK's mappers' own limits in the speed tables: `vtk-pt` and `vtk-raycast` run on every
/// dataset; a 512² frame of VTK's ZSweep mapper on llvmpipe (2 cores, VTK 9) takes about 11 s
/// at 297K tets but grows faster than the tets (140 s at spx2's 824K, cores shared), so it
/// stays under a minute up to about 300K tets (spx, blunt, comb are in; post, spx2, fuel, brain
/// are not).
pub(crate) const VTK_MAX_TETS: &[(&str, Option<usize>)] = &[
    ("vtk-pt", None),
    ("vtk-raycast", None),
    ("vtk-zsweep", Some(300_000)),
];

/// The peers that join the PT and ray-casting speed tables: every renderer the registry files
/// under [`Family::External`] — VTK's mappers and the declared peers — whose declared family is
/// `pt` or `raycasting` (an `other` peer runs only when named), with its default integrator,
/// and only those that can run here (the VTK ones need `TETBENCH_VTK_PYTHON`), so a run
/// without them is unchanged. Each is capped by [`peer_max_tets`].
pub(crate) fn external_peers() -> Vec<RendererSpec> {
    render::family(Family::External)
        .into_iter()
        .filter(|i| {
            matches!(
                render::peer_family(i),
                Some(PeerFamily::Pt | PeerFamily::RayCasting)
            )
        })
        .filter(|i| render::make(i.name, &Default::default()).is_ok())
        .filter_map(|i| want(i.name, &[], &[i.default_integrator]))
        .map(|mut r| {
            r.max_tets = peer_max_tets(&r.name);
            r
        })
        .collect()
}

/// The largest mesh a peer gets in the speed tables: VTK's mappers' own limits
/// ([`VTK_MAX_TETS`]), [`EXTERNAL_MAX_TETS`] for a declared peer.
pub(crate) fn peer_max_tets(name: &str) -> Option<usize> {
    VTK_MAX_TETS
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(Some(EXTERNAL_MAX_TETS), |&(_, m)| m)
}

/// A table note naming the peers in the run and their mesh limits, or saying how to add them.
pub(crate) fn external_note() -> String {
    let all: Vec<&str> = render::family(Family::External)
        .iter()
        .map(|i| i.name)
        .collect();
    let run: Vec<RendererSpec> = external_peers();
    if run.is_empty() {
        return format!(
            "Peers ({}) not in this run: {}; declared peers (docs/peers.md) join with --peers FILE.",
            all.join(", "),
            render::vtk::HOW_TO_ENABLE
        );
    }
    let names: Vec<&str> = run.iter().map(|r| r.name.as_str()).collect();
    let mut n = format!(
        "Peers: {} (other programs over the peer protocol: VTK's mappers, docs/vtk.md, and \
         declared peers, docs/peers.md; default integrators), measured like ours: the peer's own \
         stage times, bytes = its peak RSS.",
        names.join(", ")
    );
    let every: Vec<&str> = run
        .iter()
        .filter(|r| r.max_tets.is_none())
        .map(|r| r.name.as_str())
        .collect();
    if !every.is_empty() {
        n.push_str(&format!(" On every dataset: {}.", every.join(", ")));
    }
    for r in &run {
        if let Some(m) = r.max_tets {
            n.push_str(&format!(" {} on meshes up to {m} tets", r.name));
            n.push_str(if r.name == "vtk-zsweep" {
                " (where its 512² frame stays under a minute: about 11 s at 297K tets on llvmpipe, 140 s at 824K)."
            } else {
                "."
            });
        }
    }
    n
}

// ---------------------------------------------------------------------------------------------
// Datasets: the NASA grids when present, else their analogues; smaller meshes with --quick.

/// A paper dataset: its label, the real NASA short name (if any), its datasets-gen analogue,
/// and the tet count used with --quick (None: full size even in quick mode).
pub(crate) fn dataset(ctx: &Ctx, label: &str, quick_tets: Option<usize>) -> DatasetSpec {
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
        label: Some(label.to_string()),
        ..Default::default()
    }
}

pub(crate) fn mesh_used(cfg: &Config, label: &str) -> String {
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

pub(crate) fn rotating(ctx: &Ctx, full_frames: usize, quick_frames: usize) -> ViewsSpec {
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

pub(crate) fn base_config(ctx: &Ctx, name: &str) -> Config {
    Config {
        name: Some(name.to_string()),
        sizes: Some(vec![
            if ctx.quick { "128x128" } else { "512x512" }.to_string()
        ]),
        projection: Some(OneOrMany(vec!["ortho".into()])),
        tf: Some(experiment::TfSpec::Named("default".into())),
        repeats: Some(2),
        warmup: Some(1),
        error: Some(true),
        save_images: Some(false),
        ..Default::default()
    }
}

pub(crate) fn common_notes(ctx: &Ctx, cfg: &Config) -> Vec<String> {
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
    let analogues: Vec<&str> = cfg
        .datasets
        .iter()
        .filter(|d| d.mesh.ends_with("-like"))
        .filter_map(|d| d.label.as_deref())
        .collect();
    if !analogues.is_empty() {
        n.push(format!(
            "Not the NASA grids: {} are their datasets-gen analogues ({}), because {}.",
            analogues.join(", "),
            if ctx.quick { "--quick uses the analogues at reduced size" } else { "the grid files were not found ($TETBENCH_DATA, or shared/datasets beside the checkout)" },
            if ctx.quick { "a quick run must stay short" } else { "no data was downloaded" }
        ));
    }
    // The GPU renderers' cap on a software adapter (the external peers' caps have their own
    // note).
    let gpu_cap = cfg
        .renderers
        .iter()
        .filter(|r| render::info(&r.name).is_ok_and(|i| i.needs_gpu))
        .find_map(|r| r.max_tets);
    if let Some(cap) = gpu_cap {
        n.push(format!("The GPU adapter is a software rasteriser (see README.md): the ptint and hapt rows of the papers' direct volume rendering variants are measured on meshes up to {cap} tets only (HAPT Table 2's ISO and DVR+ISO rows on all), and their rates say what the algorithms cost on a CPU emulating a GPU, not GPU speed. Rerun on a real GPU for the other rows."));
    }
    n
}

pub(crate) fn describe_views(v: &ViewsSpec) -> String {
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
// Algorithm tables (PTINT Table 2, HAPT Tables 3 and 4): paper rows, each with the variants
// standing in for it.

/// A paper row: name, the paper's figures, variant-label patterns that stand in for it.
pub(crate) struct PaperRow {
    pub name: &'static str,
    pub values: &'static [&'static str],
    pub ours: &'static [&'static str],
}

/// Rows: each paper row with its matching variants (or none), then variants no row claims.
/// `measure` gives the measured cells of one variant.
pub(crate) fn algo_rows(
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

/// Runs an experiment table: its experiment (or why it is skipped), the bench run under
/// `DIR/raw/<id>/`, the table laid out by `build` and its plots.
pub(crate) fn run_experiment(
    t: &dyn PaperTable,
    ctx: &Ctx,
    experiment: fn(&Ctx) -> std::result::Result<Config, String>,
    build: fn(&Ctx, &Config, &Outcome) -> Table,
    plots: &dyn Fn(&Outcome, &std::path::Path) -> Result<Vec<std::path::PathBuf>>,
) -> Result<Done> {
    let cfg = match experiment(ctx) {
        Ok(c) => c,
        Err(why) => return Ok(Done::Skipped(why)),
    };
    if cfg.renderers.is_empty() {
        return Ok(Done::Skipped(
            "no renderer of its families is registered".into(),
        ));
    }
    let exp = experiment::validate(cfg.clone(), std::path::Path::new("."))?;
    let raw = ctx.out.join("raw").join(t.id());
    let mut opts = bench::RunOptions::new(&exp, &raw);
    opts.cache_dir = ctx.out.join(".cache");
    opts.title = t.id().to_string();
    opts.log = false;
    // `reproduce` regenerates its tables: the raw rows of an earlier run are replaced, unless
    // it resumes one (an experiment with image pairs cannot resume: it is measured again).
    opts.resume = ctx.resume && exp.pairs.is_empty();
    opts.force = !opts.resume;
    opts.identity = identity(&cfg);
    let o = match &ctx.sweep {
        super::Sweep::Whole => bench::run(&exp, &opts)?,
        super::Sweep::Shard(s) => {
            opts.shard = *s;
            let o = bench::run(&exp, &opts)?;
            if !o.interrupted {
                ctx.count_failed(&o.rows);
                return Ok(Done::Files(format!(
                    "shard {s}: {} rows in raw/{}/results.csv",
                    o.rows.len(),
                    t.id()
                )));
            }
            o
        }
        super::Sweep::Merge(dirs) => {
            let parts: Vec<std::path::PathBuf> =
                dirs.iter().map(|d| d.join("raw").join(t.id())).collect();
            same_experiment(ctx, experiment, &opts.identity, &parts)?;
            Outcome {
                rows: crate::merge::merge(&raw, &parts, true)?,
                ..Default::default()
            }
        }
    };
    ctx.count_failed(&o.rows);
    if o.interrupted {
        return Err(algorithms::Error::Input(format!(
            "interrupted during {}: finished rows kept in {}",
            t.id(),
            raw.join("results.csv").display()
        )));
    }
    let mut table = build(ctx, &cfg, &o);
    if let Some(n) = failed_note(&o) {
        table.notes.push(n);
    }
    table
        .notes
        .push(format!("Raw rows: `raw/{}/results.csv`.", t.id()));
    let plots = plots(&o, &ctx.out)?;
    Ok(Done::Table { table, plots })
}

/// A table's experiment as `shard.txt` records it: the hash of its whole configuration.
fn identity(cfg: &Config) -> String {
    blake3::hash(format!("{cfg:?}").as_bytes())
        .to_hex()
        .to_string()
}

/// `reproduce --merge`: every shard measured this table's experiment as this run builds it.
/// A shard of the other `--quick` setting is named as such (its rows would be laid out under
/// this run's sizes and meshes).
fn same_experiment(
    ctx: &Ctx,
    experiment: fn(&Ctx) -> std::result::Result<Config, String>,
    mine: &str,
    parts: &[std::path::PathBuf],
) -> Result<()> {
    let flipped = Ctx {
        quick: !ctx.quick,
        out: ctx.out.clone(),
        sweep: super::Sweep::Whole,
        resume: false,
        failed: Default::default(),
    };
    let other = experiment(&flipped).ok().map(|c| identity(&c));
    for p in parts {
        let Some(info) = crate::sweep::ShardInfo::read(p)? else {
            continue; // merge names it
        };
        if info.experiment == mine {
            continue;
        }
        let why = if other.as_deref() == Some(info.experiment.as_str()) {
            if ctx.quick {
                "was measured without --quick; merge it without --quick".to_string()
            } else {
                "was measured with --quick; merge it with --quick".to_string()
            }
        } else {
            "measured another version of this table's experiment (another tetbench, or other datasets present)".to_string()
        };
        return Err(algorithms::Error::Input(format!(
            "shard {}: {why}",
            p.display()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every registered PT renderer (cpu-pt-slab16 included) and ray caster is in the PT
    /// tables' experiments, with no name written in the harness.
    #[test]
    fn the_families_come_from_the_registry() {
        let pt: Vec<String> = pt_family(false).into_iter().map(|r| r.name).collect();
        for r in render::family(Family::Pt) {
            assert!(pt.iter().any(|n| n == r.name), "{} missing", r.name);
        }
        assert!(pt.iter().any(|n| n == "cpu-pt-slab16"));
        let rc: Vec<String> = ray_casters(true).into_iter().map(|r| r.name).collect();
        assert_eq!(rc, ["raycast"]);
    }

    /// The external peers reach the speed tables through their family: all of them when they
    /// can run here (TETBENCH_VTK_PYTHON set), none otherwise; capped and named in the note.
    #[test]
    fn external_peers_come_from_the_registry_when_they_can_run() {
        let ext: Vec<&str> = render::family(Family::External)
            .iter()
            .map(|i| i.name)
            .collect();
        assert_eq!(ext, ["vtk-pt", "vtk-raycast", "vtk-zsweep"]);
        let peers = external_peers();
        let enabled = render::vtk::python().is_ok();
        let names: Vec<&str> = peers.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, if enabled { ext.clone() } else { vec![] });
        for r in &peers {
            let want = (r.name == "vtk-zsweep").then_some(300_000);
            assert_eq!(r.max_tets, want, "{}", r.name);
        }
        // A declared peer (another program) keeps the general cap.
        assert_eq!(peer_max_tets("my-peer"), Some(EXTERNAL_MAX_TETS));
        let note = external_note();
        assert!(
            note.contains(if enabled {
                "vtk-raycast"
            } else {
                "TETBENCH_VTK_PYTHON"
            }),
            "{note}"
        );
    }
}
