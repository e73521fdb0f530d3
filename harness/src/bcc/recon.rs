//! `bcc_reconstruction`: ray casting regular CC and BCC volumes per reconstruction scheme.

use super::*;

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
