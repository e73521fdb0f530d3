//! Image error (CONVENTIONS §6): test image A against reference B, RGB channels only.

use crate::error::{Error, Result};
use crate::image::{quantize, Image};

/// The metrics of §6.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageError {
    /// sqrt of the mean over pixels and the 3 RGB channels of (A − B)².
    pub rmse: f64,
    /// 20·log10(1 / rmse); +inf for identical images; NaN (as `rmse` and `max_abs`) when a
    /// pixel of either image is NaN.
    pub psnr: f64,
    /// Largest |A − B| over pixels and RGB channels.
    pub max_abs: f64,
    /// 100 · (pixels where any quantised RGB channel differs) / (pixels non-background in A or B).
    pub diff_pixels_pct: f64,
    /// 100 · (largest quantised channel difference) / 255.
    pub max_err_pct: f64,
    /// 100 · mean of |difference| / 255 over the (pixel, channel) pairs that differ.
    pub avg_err_pct: f64,
}

impl ImageError {
    /// `name: value` pairs in the order of §6 (for `tetbench compare` and CSV columns).
    pub fn fields(&self) -> [(&'static str, f64); 6] {
        [
            ("rmse", self.rmse),
            ("psnr", self.psnr),
            ("max_abs", self.max_abs),
            ("diff_pixels_pct", self.diff_pixels_pct),
            ("max_err_pct", self.max_err_pct),
            ("avg_err_pct", self.avg_err_pct),
        ]
    }
}

/// Compares `a` (test) against `b` (reference). Images must have the same size.
pub fn compare(a: &Image, b: &Image) -> Result<ImageError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Input(format!(
            "image sizes differ: {}x{} against {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let mut sq = 0.0f64;
    let mut max_abs = 0.0f64;
    let (mut diff_px, mut non_bg) = (0usize, 0usize);
    let (mut max_q, mut sum_q, mut n_q) = (0u32, 0u64, 0u64);
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let d = pa[c] as f64 - pb[c] as f64;
            sq += d * d;
            // A NaN difference makes the largest one NaN (f64::max would skip it).
            if d.abs() > max_abs || d.is_nan() {
                max_abs = d.abs();
            }
        }
        let qa = pa.map(quantize);
        let qb = pb.map(quantize);
        let background = qa.iter().chain(&qb).all(|&q| q == 0);
        if !background {
            non_bg += 1;
        }
        let mut differs = false;
        for c in 0..3 {
            let d = (qa[c] as i32 - qb[c] as i32).unsigned_abs();
            if d > 0 {
                differs = true;
                max_q = max_q.max(d);
                sum_q += d as u64;
                n_q += 1;
            }
        }
        if differs {
            diff_px += 1;
        }
    }
    let n = (a.pixels.len() * 3).max(1) as f64;
    let rmse = (sq / n).sqrt();
    Ok(ImageError {
        rmse,
        // +inf only for identical images: a NaN error stays NaN.
        psnr: if rmse > 0.0 || rmse.is_nan() {
            20.0 * (1.0 / rmse).log10()
        } else {
            f64::INFINITY
        },
        max_abs,
        diff_pixels_pct: if non_bg > 0 {
            100.0 * diff_px as f64 / non_bg as f64
        } else {
            0.0
        },
        max_err_pct: 100.0 * max_q as f64 / 255.0,
        avg_err_pct: if n_q > 0 {
            100.0 * (sum_q as f64 / n_q as f64) / 255.0
        } else {
            0.0
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A NaN pixel makes the error NaN, never "identical" (psnr +inf) or "no difference"
    /// (max_abs 0).
    #[test]
    fn nan_pixels_give_nan_errors() {
        let a = Image {
            width: 2,
            height: 2,
            pixels: vec![[f32::NAN; 4]; 4],
        };
        let b = Image::new(2, 2);
        for (x, y) in [(&a, &b), (&b, &a), (&a, &a)] {
            let e = compare(x, y).unwrap();
            assert!(
                e.rmse.is_nan() && e.psnr.is_nan() && e.max_abs.is_nan(),
                "{e:?}"
            );
        }
        let mut c = Image::new(2, 2);
        c.set(1, 1, [0.5, 0.0, 0.0, 1.0]);
        c.set(0, 0, [f32::NAN, 0.0, 0.0, 1.0]);
        let e = compare(&c, &b).unwrap();
        assert!(e.max_abs.is_nan(), "{e:?}");
    }

    #[test]
    fn identical_images_have_zero_error() {
        let mut a = Image::new(4, 4);
        a.set(1, 1, [0.5, 0.25, 0.125, 1.0]);
        let e = compare(&a, &a).unwrap();
        assert_eq!(e.rmse, 0.0);
        assert_eq!(e.diff_pixels_pct, 0.0);
        assert!(e.psnr.is_infinite());
    }

    #[test]
    fn hand_computed_example() {
        // 2×2 images. Pixel (0,0): background in both. (1,0): A = (0.2, 0, 0, 1), B = (0, 0, 0, 1).
        // (0,1): identical non-background. (1,1): A = (0.5,0.5,0.5,1), B = (0.5,0.5,0.6,1).
        let mut a = Image::new(2, 2);
        let mut b = Image::new(2, 2);
        a.set(1, 0, [0.2, 0.0, 0.0, 1.0]);
        b.set(1, 0, [0.0, 0.0, 0.0, 1.0]);
        a.set(0, 1, [0.3, 0.3, 0.3, 1.0]);
        b.set(0, 1, [0.3, 0.3, 0.3, 1.0]);
        a.set(1, 1, [0.5, 0.5, 0.5, 1.0]);
        b.set(1, 1, [0.5, 0.5, 0.6, 1.0]);
        let e = compare(&a, &b).unwrap();
        // rmse = sqrt((0.2² + 0.1²) / 12); f32 inputs, so compare loosely.
        let want = ((0.04f64 + 0.01) / 12.0).sqrt();
        assert!((e.rmse - want).abs() < 1e-7, "{}", e.rmse);
        assert!((e.psnr - 20.0 * (1.0 / want).log10()).abs() < 1e-5);
        assert!((e.max_abs - 0.2).abs() < 1e-7);
        // 3 non-background pixels, 2 differ.
        assert!((e.diff_pixels_pct - 200.0 / 3.0).abs() < 1e-12);
        // Quantised: 0.2 → 51 vs 0: diff 51; 0.5 → 128 vs 0.6 → 153: diff 25.
        assert!((e.max_err_pct - 100.0 * 51.0 / 255.0).abs() < 1e-12);
        assert!((e.avg_err_pct - 100.0 * 38.0 / 255.0).abs() < 1e-12);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(compare(&Image::new(2, 2), &Image::new(2, 3)).is_err());
    }
}
