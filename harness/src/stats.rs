//! Statistics over measured samples, with one rule for missing values: NaN samples (a frame or
//! view that failed) are left out, and a statistic over no samples is NaN (shown as "—").

/// Median: the middle sample, or the mean of the middle two for an even count.
pub fn median(samples: &[f64]) -> f64 {
    let mut v: Vec<f64> = samples.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Arithmetic mean of the finite samples (an infinite one is as unusable as a NaN).
pub fn mean(samples: &[f64]) -> f64 {
    let v: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Smallest sample.
pub fn min(samples: &[f64]) -> f64 {
    samples
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .reduce(f64::min)
        .unwrap_or(f64::NAN)
}

/// Largest sample.
pub fn max(samples: &[f64]) -> f64 {
    samples
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .reduce(f64::max)
        .unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_nan_rule() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[f64::NAN, 5.0, 1.0]), 3.0);
        assert!(median(&[]).is_nan() && median(&[f64::NAN]).is_nan());
        assert_eq!(mean(&[1.0, f64::NAN, 3.0, f64::INFINITY]), 2.0);
        assert!(mean(&[]).is_nan());
        assert_eq!(min(&[2.0, f64::NAN, 1.0]), 1.0);
        assert_eq!(max(&[2.0, f64::NAN, 1.0]), 2.0);
        assert!(min(&[]).is_nan());
    }
}
