//! Plots (plotters, PNG and SVG) from measured rows: speed against error with the Pareto front,
//! tet/s against mesh size (log–log, fitted exponent), time against viewport size, pairwise
//! error per dataset (centroid vs MPVONC) and stacked stage bars per variant.
//!
//! Each function writes `STEM.png` and `STEM.svg` and returns their paths, or nothing when the
//! rows do not hold what the plot needs (e.g. one mesh size only).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use crate::rows::{PairRow, Row};
use crate::stats::median;

type PResult = std::result::Result<(), Box<dyn std::error::Error>>;

const SIZE: (u32, u32) = (960, 640);

/// `DIR/.STEM.tmp<pid>@<host>.EXT`: a hidden sibling with the same extension (the backends
/// pick the format from it); `sweep::clean_stale_tmp` removes those a killed run left.
fn tmp_sibling(p: &Path) -> PathBuf {
    let ext = p.extension().unwrap_or_default().to_string_lossy();
    algorithms::io::files::temp_name(p, Some(&ext))
}

fn plot_err(p: &Path, e: Box<dyn std::error::Error>) -> Error {
    // Almost always the file system (a full disk): one line naming the file.
    Error::Io(format!("{}: {e}", p.display()))
}

macro_rules! draw_both {
    ($stem:expr, $func:ident, $($arg:expr),*) => {{
        let png = PathBuf::from(format!("{}.png", $stem.display()));
        let svg = PathBuf::from(format!("{}.svg", $stem.display()));
        // Drawn into hidden temporary siblings and renamed into place: a failure (a full
        // disk) never leaves a cut plot.
        let (tpng, tsvg) = (tmp_sibling(&png), tmp_sibling(&svg));
        let drawn = (|| -> Result<()> {
            {
                let root = BitMapBackend::new(&tpng, SIZE).into_drawing_area();
                $func(root, $($arg),*).map_err(|e| plot_err(&png, e))?;
            }
            {
                let root = SVGBackend::new(&tsvg, SIZE).into_drawing_area();
                $func(root, $($arg),*).map_err(|e| plot_err(&svg, e))?;
            }
            std::fs::rename(&tpng, &png).map_err(|e| Error::io(&png, e))?;
            std::fs::rename(&tsvg, &svg).map_err(|e| Error::io(&svg, e))
        })();
        if let Err(e) = drawn {
            let _ = std::fs::remove_file(&tpng);
            let _ = std::fs::remove_file(&tsvg);
            return Err(e);
        }
        vec![png, svg]
    }};
}

mod bars;
mod lines;
pub use bars::{pair_errors, stage_bars};
pub use lines::lines_loglog;

fn color(i: usize) -> RGBColor {
    const C: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    C[i % C.len()]
}

fn ok_rows(rows: &[Row]) -> impl Iterator<Item = &Row> {
    rows.iter().filter(|r| r.total_ms.is_finite())
}

/// Groups rows by a key, keeping first-seen order.
fn group<'a, K: Ord + Clone>(
    rows: impl Iterator<Item = &'a Row>,
    key: impl Fn(&Row) -> K,
) -> Vec<(K, Vec<&'a Row>)> {
    let mut order: Vec<K> = Vec::new();
    let mut m: BTreeMap<K, Vec<&Row>> = BTreeMap::new();
    for r in rows {
        let k = key(r);
        if !m.contains_key(&k) {
            order.push(k.clone());
        }
        m.entry(k).or_default().push(r);
    }
    order
        .into_iter()
        .map(|k| {
            let v = m.remove(&k).unwrap();
            (k, v)
        })
        .collect()
}

/// A point of the speed–error plot: variant, error (mean RMSE), speed (median M tet/s).
#[derive(Clone, Debug)]
pub struct SpeedError {
    pub label: String,
    pub rmse: f64,
    pub mtets: f64,
}

/// Indices of the Pareto-optimal points (lower error and higher speed are better).
pub fn pareto_front(pts: &[SpeedError]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..pts.len()).collect();
    idx.sort_by(|&a, &b| {
        pts[a]
            .rmse
            .total_cmp(&pts[b].rmse)
            .then(pts[b].mtets.total_cmp(&pts[a].mtets))
    });
    let mut best = f64::NEG_INFINITY;
    let mut front = Vec::new();
    for i in idx {
        if pts[i].mtets > best {
            best = pts[i].mtets;
            front.push(i);
        }
    }
    front
}

/// The datasets a plot aggregates over: those on which every variant has a measured row (so
/// that no variant is averaged over easier or harder meshes than another); when no dataset is
/// shared by all, the one shared by the most variants.
pub fn common_datasets(rows: &[&Row]) -> Vec<String> {
    let by_variant = group(rows.iter().copied(), |r| r.variant.clone());
    let sets: Vec<std::collections::BTreeSet<&str>> = by_variant
        .iter()
        .map(|(_, rs)| rs)
        .map(|rs| rs.iter().map(|r| r.dataset.as_str()).collect())
        .collect();
    let all: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.dataset.as_str()).collect();
    let common: Vec<String> = all
        .iter()
        .filter(|d| sets.iter().all(|s| s.contains(*d)))
        .map(|d| d.to_string())
        .collect();
    if !common.is_empty() {
        return common;
    }
    all.iter()
        .max_by_key(|d| sets.iter().filter(|s| s.contains(*d)).count())
        .map(|d| vec![d.to_string()])
        .unwrap_or_default()
}

/// Speed against error, one point per variant (mean RMSE and median M tet/s over the views of
/// the datasets every variant ran on), the Pareto front joined.
pub fn speed_vs_error(rows: &[Row], stem: &Path) -> Result<Vec<PathBuf>> {
    let ok: Vec<&Row> = ok_rows(rows).filter(|r| r.rmse.is_some()).collect();
    let datasets = common_datasets(&ok);
    let pts: Vec<SpeedError> = group(
        ok.iter().copied().filter(|r| datasets.contains(&r.dataset)),
        |r| r.variant.clone(),
    )
    .into_iter()
    .map(|(label, rs)| SpeedError {
        label,
        rmse: rs.iter().map(|r| r.rmse.unwrap()).sum::<f64>() / rs.len() as f64,
        mtets: median(&rs.iter().map(|r| r.tets_per_s / 1e6).collect::<Vec<_>>()),
    })
    .collect();
    if pts.is_empty() {
        return Ok(Vec::new());
    }
    let what = format!("each point: one variant over {}", datasets.join(", "));
    Ok(draw_both!(stem, draw_speed_error, &pts, &what))
}

/// A log axis range of whole decades around `[lo, hi]` (at least two decades), so that the
/// axis has a labelled tick at every power of ten.
pub fn decades(lo: f64, hi: f64) -> (f64, f64) {
    let a = lo.max(1e-300).log10().floor();
    let mut b = hi.max(1e-300).log10().ceil();
    if b < a + 2.0 {
        b = a + 2.0;
    }
    (10f64.powf(a), 10f64.powf(b))
}

/// A log-axis tick label: `1e-4`, `1e-3`, … at powers of ten, nothing between.
fn decade_label(v: &f64) -> String {
    let e = v.log10();
    if (e - e.round()).abs() < 1e-6 {
        format!("1e{}", e.round() as i32)
    } else {
        String::new()
    }
}

/// Labels longer than this are shortened in legends.
const LEGEND_CHARS: usize = 44;

/// A legend beside the chart (never over the data): a marker and a label per entry.
fn side_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, labels: &[String]) -> PResult
where
    DB::ErrorType: 'static,
{
    for (i, l) in labels.iter().enumerate() {
        let y = 60 + 20 * i as i32;
        draw_marker(area, i, (12, y), 5)?;
        let text: String = if l.chars().count() > LEGEND_CHARS {
            l.chars().take(LEGEND_CHARS - 1).chain(['…']).collect()
        } else {
            l.clone()
        };
        area.draw(&Text::new(text, (24, y - 7), ("sans-serif", 14)))?;
    }
    Ok(())
}

/// Marker `i`: ten colours, then the same colours as triangles, then squares, so that no two
/// series look alike.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    at: (i32, i32),
    size: i32,
) -> PResult
where
    DB::ErrorType: 'static,
{
    let c = color(i).filled();
    match (i / 10) % 3 {
        0 => area.draw(&Circle::new(at, size, c))?,
        1 => area.draw(&TriangleMarker::new(at, size + 2, c))?,
        _ => area.draw(&Rectangle::new(
            [(at.0 - size, at.1 - size), (at.0 + size, at.1 + size)],
            c,
        ))?,
    }
    Ok(())
}

/// The same marker in chart coordinates.
fn marker_series<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'_, DB, CT>,
    i: usize,
    at: (f64, f64),
    size: i32,
) -> PResult
where
    DB::ErrorType: 'static,
{
    let c = color(i).filled();
    match (i / 10) % 3 {
        0 => {
            chart.draw_series(std::iter::once(Circle::new(at, size, c)))?;
        }
        1 => {
            chart.draw_series(std::iter::once(TriangleMarker::new(at, size + 2, c)))?;
        }
        _ => {
            chart.draw_series(std::iter::once(
                EmptyElement::at(at) + Rectangle::new([(-size, -size), (size, size)], c),
            ))?;
        }
    }
    Ok(())
}

fn draw_speed_error<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    pts: &[SpeedError],
    what: &str,
) -> PResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(SIZE.0 * 64 / 100);
    let floor = 1e-6;
    let xs: Vec<f64> = pts.iter().map(|p| p.rmse.max(floor)).collect();
    let (x0, x1) = decades(
        xs.iter().cloned().fold(f64::INFINITY, f64::min),
        xs.iter().cloned().fold(0.0, f64::max),
    );
    let y1 = pts.iter().map(|p| p.mtets).fold(0.0, f64::max) * 1.15 + 1e-9;
    let mut chart = ChartBuilder::on(&left)
        .caption("Speed against error", ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), 0.0..y1)?;
    chart
        .configure_mesh()
        .x_desc(format!(
            "RMSE against the exact reference (mean over views; 0 drawn at {floor:e})"
        ))
        .y_desc("M tet/s (median over views)")
        .x_label_formatter(&decade_label)
        .draw()?;
    let front = pareto_front(pts);
    chart.draw_series(LineSeries::new(
        front.iter().map(|&i| (xs[i], pts[i].mtets)),
        RED.stroke_width(2),
    ))?;
    for (i, p) in pts.iter().enumerate() {
        let size = if front.contains(&i) { 7 } else { 5 };
        marker_series(&mut chart, i, (xs[i], p.mtets), size)?;
    }
    right.draw(&Text::new(
        "red line: Pareto front",
        (10, 15),
        ("sans-serif", 14),
    ))?;
    right.draw(&Text::new(what.to_string(), (10, 33), ("sans-serif", 12)))?;
    let labels: Vec<String> = pts.iter().map(|p| p.label.clone()).collect();
    side_legend(&right, &labels)?;
    root.present()?;
    Ok(())
}

/// Least-squares slope and intercept of y on x.
pub fn fit_line(pts: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = pts.len() as f64;
    if pts.len() < 2 {
        return None;
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    Some((b, my - b * mx))
}

struct Series {
    label: String,
    pts: Vec<(f64, f64)>,
    /// Draw this power law (log-space slope, intercept) instead of joining the points.
    fit: Option<(f64, f64)>,
}

/// Tet/s against mesh size, log–log, one series per variant with the fitted exponent `b` of
/// tet/s ∝ tets^b in the legend. Needs at least two mesh sizes.
pub fn tets_per_s_vs_size(rows: &[Row], stem: &Path) -> Result<Vec<PathBuf>> {
    let mut series = Vec::new();
    for (label, rs) in group(ok_rows(rows), |r| r.variant.clone()) {
        let mut pts: Vec<(f64, f64)> = group(rs.into_iter(), |r| r.dataset.clone())
            .into_iter()
            .map(|(_, d)| {
                (
                    d[0].tets as f64,
                    median(&d.iter().map(|r| r.tets_per_s).collect::<Vec<_>>()),
                )
            })
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let distinct = pts.windows(2).filter(|w| w[0].0 != w[1].0).count() + 1;
        if distinct < 2 {
            continue;
        }
        let logs: Vec<(f64, f64)> = pts.iter().map(|p| (p.0.ln(), p.1.ln())).collect();
        let fit = fit_line(&logs);
        let b = fit.map(|f| f.0).unwrap_or(f64::NAN);
        series.push(Series {
            label: format!("{label}: tet/s ~ tets^{b:.2} (fit)"),
            pts,
            fit,
        });
    }
    if series.is_empty() {
        return Ok(Vec::new());
    }
    Ok(draw_both!(
        stem,
        draw_loglog,
        &series,
        "Throughput against mesh size",
        "tets",
        "tet/s (median)"
    ))
}

/// Frame time against viewport size, one series per variant (and dataset). Needs two sizes.
pub fn time_vs_viewport(rows: &[Row], stem: &Path) -> Result<Vec<PathBuf>> {
    let multi_ds = group(rows.iter(), |r| r.dataset.clone()).len() > 1;
    let mut series = Vec::new();
    for ((ds, label), rs) in group(ok_rows(rows), |r| (r.dataset.clone(), r.variant.clone())) {
        let mut pts: Vec<(f64, f64)> = group(rs.into_iter(), |r| (r.width, r.height))
            .into_iter()
            .map(|((w, h), d)| {
                (
                    ((w as f64) * (h as f64)).sqrt(),
                    median(&d.iter().map(|r| r.total_ms).collect::<Vec<_>>()),
                )
            })
            .collect();
        if pts.len() < 2 {
            continue;
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(Series {
            label: if multi_ds {
                format!("{label} on {ds}")
            } else {
                label
            },
            pts,
            fit: None,
        });
    }
    if series.is_empty() {
        return Ok(Vec::new());
    }
    Ok(draw_both!(
        stem,
        draw_loglog,
        &series,
        "Frame time against viewport size",
        "viewport side (sqrt of W x H, pixels)",
        "ms per frame (median)"
    ))
}

fn draw_loglog<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    series: &[Series],
    title: &str,
    xd: &str,
    yd: &str,
) -> PResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let all = series.iter().flat_map(|s| s.pts.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let (left, right) = root.split_horizontally(SIZE.0 * 68 / 100);
    let (x0, x1) = decades(x0, x1);
    let (y0, y1) = decades(y0.max(1e-12), y1);
    let mut chart = ChartBuilder::on(&left)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(xd)
        .y_desc(yd)
        .x_label_formatter(&decade_label)
        .y_label_formatter(&decade_label)
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let c = color(i);
        let line: Vec<(f64, f64)> = match s.fit {
            Some((b, a)) => {
                let (lo, hi) = (s.pts[0].0, s.pts[s.pts.len() - 1].0);
                vec![(lo, (a + b * lo.ln()).exp()), (hi, (a + b * hi.ln()).exp())]
            }
            None => s.pts.clone(),
        };
        chart.draw_series(LineSeries::new(line, c.stroke_width(2)))?;
        for &p in &s.pts {
            marker_series(&mut chart, i, p, 4)?;
        }
    }
    let labels: Vec<String> = series.iter().map(|s| s.label.clone()).collect();
    side_legend(&right, &labels)?;
    root.present()?;
    Ok(())
}

/// Every plot the rows support, written into `dir` with the given file-name prefix.
pub fn all(rows: &[Row], pairs: &[PairRow], dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    out.extend(speed_vs_error(rows, &dir.join("speed_vs_error"))?);
    out.extend(tets_per_s_vs_size(rows, &dir.join("tets_per_s_vs_size"))?);
    out.extend(time_vs_viewport(rows, &dir.join("time_vs_viewport"))?);
    out.extend(pair_errors(pairs, &dir.join("pair_errors"))?);
    out.extend(stage_bars(
        rows,
        &dir.join("stages"),
        "Time per stage and variant",
    )?);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_keeps_undominated_points() {
        let p = |l: &str, e, s| SpeedError {
            label: l.into(),
            rmse: e,
            mtets: s,
        };
        let pts = vec![
            p("a", 0.0, 1.0),
            p("b", 0.1, 5.0),
            p("c", 0.2, 3.0),
            p("d", 0.3, 9.0),
        ];
        assert_eq!(pareto_front(&pts), vec![0, 1, 3]);
    }

    #[test]
    fn fit_recovers_slope() {
        let pts: Vec<(f64, f64)> = (1..5).map(|i| (i as f64, 2.0 * i as f64 + 1.0)).collect();
        let (b, a) = fit_line(&pts).unwrap();
        assert!((b - 2.0).abs() < 1e-12 && (a - 1.0).abs() < 1e-12);
    }
}

/// One labelled point of [`time_vs_error`].
#[derive(Clone, Debug)]
pub struct TimeError {
    pub label: String,
    pub rmse: f64,
    pub time_ms: f64,
}

/// Time against error (log x), one labelled point each: the BCC tables (CC vs BCC per lattice
/// and field; reconstruction schemes per field, the paper's Fig. 9 with errors added).
pub fn time_vs_error(pts: &[TimeError], stem: &Path, title: &str) -> Result<Vec<PathBuf>> {
    if pts.is_empty() {
        return Ok(Vec::new());
    }
    Ok(draw_both!(stem, draw_time_error, pts, title))
}

fn draw_time_error<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    pts: &[TimeError],
    title: &str,
) -> PResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(SIZE.0 * 66 / 100);
    let floor = 1e-6;
    let xs: Vec<f64> = pts.iter().map(|p| p.rmse.max(floor)).collect();
    let (x0, x1) = decades(
        xs.iter().cloned().fold(f64::INFINITY, f64::min),
        xs.iter().cloned().fold(0.0, f64::max),
    );
    let y1 = pts.iter().map(|p| p.time_ms).fold(0.0, f64::max) * 1.15 + 1e-9;
    let mut chart = ChartBuilder::on(&left)
        .caption(title, ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), 0.0..y1)?;
    chart
        .configure_mesh()
        .x_desc("RMSE against the analytic ground truth")
        .y_desc("time per frame (ms, median)")
        .x_label_formatter(&decade_label)
        .draw()?;
    for (i, p) in pts.iter().enumerate() {
        marker_series(&mut chart, i, (xs[i], p.time_ms), 6)?;
    }
    let labels: Vec<String> = pts.iter().map(|p| p.label.clone()).collect();
    side_legend(&right, &labels)?;
    root.present()?;
    Ok(())
}
