//! Bar charts: image error per dataset (pairs) and stacked stage times per variant.

use super::*;

/// Horizontal bars: groups (label, [(segment name, value)]) stacked or side by side.
struct Bars {
    title: String,
    xdesc: String,
    segments: Vec<String>,
    groups: Vec<(String, Vec<f64>)>,
    stacked: bool,
}

/// Pairwise error per dataset (HAPT Table 1): max error % (max over views), average error %
/// and different pixels % (means over views).
pub fn pair_errors(pairs: &[PairRow], stem: &Path) -> Result<Vec<PathBuf>> {
    if pairs.is_empty() {
        return Ok(Vec::new());
    }
    let mut groups = Vec::new();
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for p in pairs {
        let k = (p.dataset.clone(), p.test.clone(), p.reference.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let multi = keys
        .iter()
        .map(|k| (&k.1, &k.2))
        .collect::<std::collections::BTreeSet<_>>()
        .len()
        > 1;
    for k in &keys {
        let ps: Vec<&PairRow> = pairs
            .iter()
            .filter(|p| p.dataset == k.0 && p.test == k.1 && p.reference == k.2)
            .collect();
        let n = ps.len() as f64;
        let label = if multi {
            format!("{} ({} vs {})", k.0, k.1, k.2)
        } else {
            k.0.clone()
        };
        groups.push((
            label,
            vec![
                ps.iter().map(|p| p.max_err_pct).fold(0.0, f64::max),
                ps.iter().map(|p| p.avg_err_pct).sum::<f64>() / n,
                ps.iter().map(|p| p.diff_pixels_pct).sum::<f64>() / n,
            ],
        ));
    }
    let title = if multi {
        "Image error between variants".to_string()
    } else {
        format!("{} against {}", keys[0].1, keys[0].2)
    };
    let bars = Bars {
        title,
        xdesc: "percent".into(),
        segments: vec![
            "max error % (max over views)".into(),
            "avg error % (of differing channels)".into(),
            "different pixels % (mean over views)".into(),
        ],
        groups,
        stacked: false,
    };
    Ok(draw_both!(stem, draw_bars, &bars))
}

/// Stacked stage times per variant (project, sort, draw, readback, other), medians in ms.
pub fn stage_bars(rows: &[Row], stem: &Path, title: &str) -> Result<Vec<PathBuf>> {
    let mut groups = Vec::new();
    for (label, rs) in group(ok_rows(rows), |r| r.variant.clone()) {
        let m = |f: fn(&Row) -> f64| median(&rs.iter().map(|r| f(r)).collect::<Vec<_>>());
        let (p, s, d, rb, t) = (
            m(|r| r.project_ms),
            m(|r| r.sort_ms),
            m(|r| r.draw_ms),
            m(|r| r.readback_ms),
            m(|r| r.total_ms),
        );
        let other = (t - p - s - d - rb).max(0.0);
        groups.push((label, vec![p, s, d, rb, other]));
    }
    if groups.is_empty() {
        return Ok(Vec::new());
    }
    let bars = Bars {
        title: title.to_string(),
        xdesc: "ms per frame (median)".into(),
        segments: ["project", "sort", "draw", "readback", "other"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        groups,
        stacked: true,
    };
    Ok(draw_both!(stem, draw_bars, &bars))
}

fn draw_bars<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, b: &Bars) -> PResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let n = b.groups.len();
    let k = b.segments.len();
    let xmax = b
        .groups
        .iter()
        .map(|(_, v)| {
            if b.stacked {
                v.iter().sum::<f64>()
            } else {
                v.iter().cloned().fold(0.0, f64::max)
            }
        })
        .fold(0.0, f64::max)
        .max(1e-9)
        * 1.6;
    let mut chart = ChartBuilder::on(&root)
        .caption(&b.title, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(20)
        .build_cartesian_2d(0.0..xmax, 0.0..n as f64)?;
    chart
        .configure_mesh()
        .x_desc(b.xdesc.as_str())
        .y_labels(0)
        .disable_y_mesh()
        .draw()?;
    for (s, name) in b.segments.iter().enumerate() {
        let c = color(s);
        let rects: Vec<Rectangle<(f64, f64)>> = b
            .groups
            .iter()
            .enumerate()
            .filter_map(|(g, (_, v))| {
                let y = (n - 1 - g) as f64;
                if b.stacked {
                    let x0: f64 = v[..s].iter().sum();
                    let x1 = x0 + v[s];
                    (v[s] > 0.0).then(|| Rectangle::new([(x0, y + 0.2), (x1, y + 0.8)], c.filled()))
                } else {
                    let h = 0.6 / k as f64;
                    let y0 = y + 0.2 + h * (k - 1 - s) as f64;
                    Some(Rectangle::new([(0.0, y0), (v[s], y0 + h)], c.filled()))
                }
            })
            .collect();
        chart
            .draw_series(rects)?
            .label(name.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], c.filled()));
    }
    let texts: Vec<Text<(f64, f64), String>> = b
        .groups
        .iter()
        .enumerate()
        .map(|(g, (label, v))| {
            let y = (n - 1 - g) as f64 + 0.6;
            let end = if b.stacked {
                v.iter().sum::<f64>()
            } else {
                v.iter().cloned().fold(0.0, f64::max)
            };
            let what = if b.stacked {
                format!("{label}  {end:.2} ms")
            } else {
                label.clone()
            };
            Text::new(what, (end + xmax * 0.01, y), ("sans-serif", 15).into_font())
        })
        .collect();
    chart.draw_series(texts)?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    root.present()?;
    Ok(())
}
