//! Plain line plots for callers outside the experiment rows (JBU's time and RMSE per
//! rendered resolution).

use super::*;

/// Line plots on log–log axes (e.g. JBU's time and RMSE per rendered resolution): each series
/// is `(label, points)`, joined in order of x whatever order the points came in; points that a
/// log axis cannot show (y ≤ 0 or not finite) are left out, and so are series left empty.
pub fn lines_loglog(
    series: Vec<(String, Vec<(f64, f64)>)>,
    stem: &Path,
    title: &str,
    xd: &str,
    yd: &str,
) -> Result<Vec<PathBuf>> {
    let series: Vec<Series> = series
        .into_iter()
        .filter_map(|(label, pts)| {
            let mut pts: Vec<(f64, f64)> = pts
                .into_iter()
                .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            (!pts.is_empty()).then_some(Series {
                label,
                pts,
                fit: None,
            })
        })
        .collect();
    if series.is_empty() {
        return Ok(Vec::new());
    }
    Ok(draw_both!(stem, draw_loglog, &series, title, xd, yd))
}
