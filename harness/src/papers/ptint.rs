//! The PTINT paper (Marroquim et al. 2006): Table 1 (data set sizes and frame rates), Table 2
//! (against other algorithms) and Figure 8 (time against viewport size).

use algorithms::Result;

use super::common::{
    agg, algo_rows, base_config, common_notes, dataset, external_note, external_peers,
    failed_cells, failure, measured, mesh_used, pt_family, ray_casters, rotating, sizes_of,
    variants, Measured, PaperRow,
};
use super::{Ctx, Done, PaperTable};
use crate::bench::Outcome;
use crate::experiment::Config;
use crate::plots;
use crate::rows::Row;
use crate::table::{count, fixed as f, Table};

table!(
    Table1,
    "ptint-table1",
    "PTINT Table 1: data set sizes and average frame rates (rotating model, 512²)",
    "Frame rate and tet/s of every projected-tetrahedra renderer (partial pre-integration) and the ray caster on the papers' datasets, the model rotating about the vertical axis. Each row carries its RMSE against the exact reference and its bytes per tet. Compare tet/s across rows of one run, not with the paper's 2006 GPU.",
    ptint_t1_exp,
    ptint_t1_build,
    |o: &Outcome, d: &std::path::Path| {
        let mut v = plots::tets_per_s_vs_size(&o.rows, &d.join("ptint-table1-tets_per_s"))?;
        v.extend(plots::speed_vs_error(&o.rows, &d.join("ptint-table1-speed_vs_error"))?);
        Ok(v)
    }
);

table!(
    Table2,
    "ptint-table2",
    "PTINT Table 2: frame rates against other algorithms (blunt, post, 512², rotating)",
    "The same frame rates on blunt and post beside PTINT's competitors; our ray caster stands in for HARC (partial and full pre-integration). Rows without a counterpart here (GATOR, VICP) keep only the paper's figures.",
    ptint_t2_exp,
    ptint_t2_build,
    |o: &Outcome, d: &std::path::Path| plots::speed_vs_error(&o.rows, &d.join("ptint-table2-speed_vs_error"))
);

table!(
    Fig8,
    "ptint-fig8",
    "PTINT Figure 8: frame time and K tet/s against viewport size (post)",
    "Frame time and K tet/s against the viewport size on post: how much of each renderer's time is per pixel (rasterisation, integration) and how much per tet (projection, sort).",
    ptint_fig8_exp,
    ptint_fig8_build,
    |o: &Outcome, d: &std::path::Path| plots::time_vs_viewport(&o.rows, &d.join("ptint-fig8-time_vs_viewport"))
);

// PTINT Table 1.

/// A row of PTINT's Table 1, as printed.
struct T1Row {
    dataset: &'static str,
    vertices: &'static str,
    tets: &'static str,
    fps: &'static str,
    ktets_per_s: &'static str,
    /// Tets of the analogue used with `--quick` (None: full size even then).
    quick_tets: Option<usize>,
}

const fn t1(
    dataset: &'static str,
    vertices: &'static str,
    tets: &'static str,
    fps: &'static str,
    ktets_per_s: &'static str,
    quick_tets: Option<usize>,
) -> T1Row {
    T1Row {
        dataset,
        vertices,
        tets,
        fps,
        ktets_per_s,
        quick_tets,
    }
}

const PTINT_T1: [T1Row; 7] = [
    t1("spx", "2.9 K", "13 K", "95.32", "1233.2", None),
    t1("blunt", "40 K", "187 K", "11.30", "2119.7", Some(40_000)),
    t1("comb", "47 K", "215 K", "9.32", "2005.4", Some(40_000)),
    t1("post", "110 K", "513 K", "4.49", "2384.4", Some(60_000)),
    t1("spx2", "150 K", "828 K", "3.04", "2526.9", Some(60_000)),
    t1("fuel", "262 K", "1.5 M", "1.49", "2246.0", Some(60_000)),
    t1("brain", "950 K", "5.5 M", "0.46", "2560.8", Some(60_000)),
];

fn ptint_t1_exp(ctx: &Ctx) -> std::result::Result<Config, String> {
    let mut c = base_config(ctx, "ptint-table1");
    c.datasets = PTINT_T1
        .iter()
        .map(|p| dataset(ctx, p.dataset, p.quick_tets))
        .collect();
    c.renderers = pt_family(false);
    c.renderers.extend(ray_casters(false));
    c.renderers.extend(external_peers());
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
    for p in &PTINT_T1 {
        for v in variants(o) {
            let head = |(vertices, tets): (usize, usize)| -> Vec<String> {
                vec![
                    p.dataset.into(),
                    p.vertices.into(),
                    p.tets.into(),
                    p.fps.into(),
                    p.ktets_per_s.into(),
                    mesh_used(cfg, p.dataset),
                    count(vertices),
                    count(tets),
                    v.clone(),
                ]
            };
            let a = match measured(o, p.dataset, &v) {
                Measured::Ok(a) => a,
                Measured::Failed(m) => {
                    let mut row = head(sizes_of(o, p.dataset, &v));
                    row.extend(failed_cells(m, 6));
                    t.rows.push(row);
                    continue;
                }
                Measured::Missing => continue,
            };
            let mut row = head((a.vertices, a.tets));
            row.extend([
                f(a.fps, 2),
                f(a.tets_per_s / 1e3, 1),
                f(a.rmse, 5),
                f(a.cpu_b, 1),
                f(a.gpu_b, 1),
                f(a.setup_ms, 0),
            ]);
            t.rows.push(row);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push(external_note());
    t.notes.push("Paper: PTINT on a Pentium IV 3.6 GHz with a GeForce 6800 (GPU); 512² viewport, rotating model; its 20 bytes/tet is GPU memory.".into());
    t
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
    c.renderers.extend(external_peers());
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
        let b = measured(o, "blunt", v);
        let p = measured(o, "post", v);
        vec![
            b.show(|b| f(b.fps, 2)),
            p.show(|p| f(p.fps, 2)),
            b.show(|b| f(b.tets_per_s / 1e3, 1)),
            p.show(|p| f(p.tets_per_s / 1e3, 1)),
            b.show(|b| f(b.rmse, 5)),
            p.show(|p| f(p.rmse, 5)),
            p.show(|p| f(p.cpu_b, 1)),
            p.show(|p| f(p.gpu_b, 1)),
        ]
    };
    t.rows = algo_rows(PTINT_T2, 2, &variants(o), &m, 8);
    t.notes = common_notes(ctx, cfg);
    t.notes.push(external_note());
    t.notes.push("Stand-ins: the CPU ray caster `raycast` for HARC (with `preint`) and HARC PPI (with `partial`); `cpu-pt`/`ptint` for PTINT. The paper's bytes/tet: PTINT 20, HARC PPI 96, HARC 144 (GPU).".into());
    t.notes.push(format!(
        "Blunt mesh used: {}; post mesh used: {}.",
        mesh_used(cfg, "blunt"),
        mesh_used(cfg, "post")
    ));
    t
}

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
            let mut row = vec![
                format!("{w}x{h}"),
                if (w, h) == (512, 512) {
                    "2384.4 (Table 1)".into()
                } else {
                    "—".into()
                },
                v.clone(),
            ];
            if rs.is_empty() {
                let Some(m) = failure(o, |r| r.variant == v && r.width == w && r.height == h)
                else {
                    continue;
                };
                row.extend(failed_cells(m, 4));
            } else {
                let a = agg(&rs);
                row.extend([
                    f(a.ms, 2),
                    f(a.fps, 2),
                    f(a.tets_per_s / 1e3, 1),
                    f(a.rmse, 5),
                ]);
            }
            t.rows.push(row);
        }
    }
    t.notes = common_notes(ctx, cfg);
    t.notes.push(format!("Mesh used: {}. The paper's Figure 8 (K tet/s over animation time for several resolutions on post) is not in the text we have; its Table 1 gives 2384.4 K tet/s for post at 512².", mesh_used(cfg, "post")));
    t
}
