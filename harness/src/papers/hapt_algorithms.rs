//! The HAPT paper's algorithm tables: Table 3 (sort and draw time per algorithm on spx2) and
//! Table 4 (frame rates per algorithm on torso and fighter), each paper row beside the
//! variants that stand in for it.

use algorithms::Result;

use super::common::{
    algo_rows, base_config, common_notes, dataset, external_note, external_peers, measured,
    mesh_used, pt_family, ray_casters, rotating, variants, PaperRow,
};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::{Config, RendererSpec};
use crate::plots;
use crate::table::{fixed as f, Table};

table!(
    Table3,
    "hapt-table3",
    "HAPT Table 3: sort and draw time per algorithm on spx2 (828K tets, 512²)",
    "Sort and draw time per variant on the spx2 analogue: where each algorithm spends its frame (stacked bars), with the error each order costs.",
    hapt_t3_exp,
    hapt_t3_build,
    |o: &Outcome, d: &std::path::Path| {
        let mut v = plots::stage_bars(&o.rows, &d.join("hapt-table3-stages"), "spx2: time per stage and variant")?;
        v.extend(plots::speed_vs_error(&o.rows, &d.join("hapt-table3-speed_vs_error"))?);
        Ok(v)
    }
);

table!(
    Table4,
    "hapt-table4",
    "HAPT Table 4: frame rates per algorithm on torso and fighter (512²)",
    "Frame rates per variant on the torso and fighter analogues (1.1M and 1.4M tets).",
    hapt_t4_exp,
    hapt_t4_build,
    |o: &Outcome, d: &std::path::Path| plots::speed_vs_error(
        &o.rows,
        &d.join("hapt-table4-speed_vs_error")
    )
);

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
    r.extend(external_peers());
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
        let a = measured(o, "spx2", v);
        vec![
            a.show(|a| f(a.sort_ms / 1e3, 4)),
            a.show(|a| f(a.draw_ms / 1e3, 4)),
            a.show(|a| f(a.ms / 1e3, 4)),
            a.show(|a| f(a.fps, 2)),
            a.show(|a| f(a.tets_per_s / 1e6, 3)),
            a.show(|a| f(a.rmse, 5)),
            a.show(|a| f(a.cpu_b, 1)),
            a.show(|a| f(a.gpu_b, 1)),
        ]
    };
    t.rows = algo_rows(HAPT_T3, 4, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push(external_note());
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
        let a = measured(o, "torso", v);
        let b = measured(o, "fighter", v);
        vec![
            a.show(|a| f(a.fps, 2)),
            a.show(|a| f(a.tets_per_s / 1e6, 3)),
            b.show(|b| f(b.fps, 2)),
            b.show(|b| f(b.tets_per_s / 1e6, 3)),
            a.show(|a| f(a.rmse, 5)),
            b.show(|b| f(b.rmse, 5)),
            b.show(|b| f(b.cpu_b, 1)),
            b.show(|b| f(b.gpu_b, 1)),
        ]
    };
    t.rows = algo_rows(HAPT_T4, 4, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push(external_note());
    t.notes.push(format!(
        "Meshes used: torso {}, fighter {}.",
        mesh_used(cfg, "torso"),
        mesh_used(cfg, "fighter")
    ));
    t
}
