//! The pixels of an image figure: a render shown over a checkerboard, its error map against the
//! reference in false colour on a logarithmic scale shared by the whole figure, and the integer
//! rescaling of both to the figure's cell size.

use algorithms::image::{quantize, Image};
use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};

/// The two tones of the checkerboard behind a render (linear, like the render itself: no gamma,
/// as `tetbench render --out x.png`), and the side of one square in figure pixels.
pub const CHECKER: [f32; 2] = [0.16, 0.26];
pub const CHECKER_SQUARE: u32 = 8;

/// An 8-bit RGB picture (what the figure draws and the report shows).
#[derive(Clone, Debug)]
pub struct Rgb {
    pub width: u32,
    pub height: u32,
    /// Row-major RGB bytes, row 0 at the top.
    pub data: Vec<u8>,
}

/// The per-pixel error of `test` against `reference`: the root mean square over the RGB
/// channels, so that the root mean square over all pixels is the image's RMSE (CONVENTIONS §6).
/// `None` when the sizes differ.
pub fn error_map(test: &Image, reference: &Image) -> Option<Vec<f32>> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return None;
    }
    Some(
        test.pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| {
                let s: f64 = (0..3)
                    .map(|c| {
                        let d = a[c] as f64 - b[c] as f64;
                        d * d
                    })
                    .sum();
                let e = (s / 3.0).sqrt() as f32;
                // A non-finite pixel is the largest error there is.
                if e.is_finite() {
                    e
                } else {
                    f32::INFINITY
                }
            })
            .collect(),
    )
}

/// A logarithmic colour scale from `lo` to `hi` (decades), shared by every error map of a
/// figure; errors below `lo` take the bottom colour, exact zeros are black.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogScale {
    pub lo: f64,
    pub hi: f64,
}

impl LogScale {
    /// Decades shown below the top one.
    pub const DECADES: i32 = 5;

    /// The scale whose top is the decade above the largest finite error (at least 1e-6).
    pub fn for_max(max: f64) -> LogScale {
        let max = if max.is_finite() && max > 0.0 {
            max
        } else {
            1e-6
        };
        let top = max.log10().ceil().max(-6.0) as i32;
        LogScale {
            lo: 10f64.powi(top - Self::DECADES),
            hi: 10f64.powi(top),
        }
    }

    /// Position of `e` on the scale, 0 (at or below `lo`) to 1 (at or above `hi`).
    pub fn position(&self, e: f64) -> f64 {
        if e.is_nan() || e <= self.lo {
            return 0.0;
        }
        ((e.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())).clamp(0.0, 1.0)
    }

    /// The palette index of `e`: 0 (black) for an exact zero, else 1 + its position on the
    /// ramp in 255 steps.
    pub fn index(&self, e: f64) -> u8 {
        if e == 0.0 {
            return 0;
        }
        1 + (self.position(e) * 254.0).round() as u8
    }

    /// The false colour of `e` (viridis, [`palette`]); black for an exact zero.
    pub fn colour(&self, e: f64) -> [u8; 3] {
        let i = self.index(e) as usize;
        match i {
            0 => [0, 0, 0],
            _ => ramp((i - 1) as f64 / 254.0),
        }
    }

    /// The decade exponents from `lo` to `hi`.
    pub fn decades(&self) -> std::ops::RangeInclusive<i32> {
        (self.lo.log10().round() as i32)..=(self.hi.log10().round() as i32)
    }
}

/// The error maps' 256 colours: black, then viridis in 255 steps ([`LogScale::index`]).
pub fn palette() -> Vec<u8> {
    let mut p = vec![0, 0, 0];
    for i in 0..255 {
        p.extend(ramp(i as f64 / 254.0));
    }
    p
}

/// Viridis at `t` in [0, 1].
pub fn ramp(t: f64) -> [u8; 3] {
    let c = ViridisRGB.get_color_normalized(t as f32, 0.0, 1.0);
    [c.0, c.1, c.2]
}

/// How a picture of `side` pixels is scaled to a cell of about `target`: an integer factor up
/// (nearest neighbour) or down (box filter), so that no pixel is smeared between two.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Up(u32),
    Down(u32),
}

impl Scale {
    pub fn to_fit(side: u32, target: u32) -> Scale {
        let side = side.max(1);
        if side <= target {
            Scale::Up(((target as f64 / side as f64).round() as u32).max(1))
        } else {
            Scale::Down(((side as f64 / target as f64).round() as u32).max(1))
        }
    }

    pub fn apply(&self, n: u32) -> u32 {
        match *self {
            Scale::Up(k) => n * k,
            Scale::Down(k) => (n / k).max(1),
        }
    }
}

/// Resamples a grid of `width` × `height` values of type `T` by `scale`: nearest neighbour up,
/// `pool` over each k × k block down (pixels past the last whole block are dropped).
fn resample<T: Copy>(
    width: u32,
    height: u32,
    px: &[T],
    scale: Scale,
    pool: impl Fn(&[T]) -> T,
) -> (u32, u32, Vec<T>) {
    let (w, h) = (scale.apply(width), scale.apply(height));
    let mut out = Vec::with_capacity(w as usize * h as usize);
    let mut block = Vec::new();
    for y in 0..h {
        for x in 0..w {
            match scale {
                Scale::Up(k) => out.push(px[((y / k) * width + x / k) as usize]),
                Scale::Down(k) => {
                    block.clear();
                    for sy in y * k..((y + 1) * k).min(height) {
                        for sx in x * k..((x + 1) * k).min(width) {
                            block.push(px[(sy * width + sx) as usize]);
                        }
                    }
                    out.push(pool(&block));
                }
            }
        }
    }
    (w, h, out)
}

/// The render (premultiplied RGBA) over the checkerboard, rescaled. Premultiplied values are
/// averaged as they are (the correct way to filter them), then composited: `I + (1 − α)·bg`.
pub fn over_checkerboard(img: &Image, scale: Scale) -> Rgb {
    let (w, h, px) = resample(img.width, img.height, &img.pixels, scale, |b| {
        let mut s = [0f32; 4];
        for p in b {
            for c in 0..4 {
                s[c] += if p[c].is_finite() { p[c] } else { 0.0 };
            }
        }
        s.map(|v| v / b.len() as f32)
    });
    let mut data = Vec::with_capacity(px.len() * 3);
    for y in 0..h {
        for x in 0..w {
            let p = px[(y * w + x) as usize];
            let bg = CHECKER[(((x / CHECKER_SQUARE) + (y / CHECKER_SQUARE)) % 2) as usize];
            for c in p.iter().take(3) {
                let v = if c.is_finite() { *c } else { 0.0 };
                data.push(quantize(v + (1.0 - p[3].clamp(0.0, 1.0)) * bg));
            }
        }
    }
    Rgb {
        width: w,
        height: h,
        data,
    }
}

/// An error map in false colour on `scale`, rescaled: blocks pooled by their root mean square
/// (what the RMSE of the block is).
pub fn false_colour(err: &[f32], width: u32, height: u32, scale: Scale, s: &LogScale) -> Rgb {
    let (w, h, px) = resample(width, height, err, scale, |b| {
        let sum: f64 = b.iter().map(|&e| e as f64 * e as f64).sum();
        (sum / b.len() as f64).sqrt() as f32
    });
    Rgb {
        width: w,
        height: h,
        data: px.iter().flat_map(|&e| s.colour(e as f64)).collect(),
    }
}

/// An error map at 1:1 as palette indices ([`palette`]): a PNG of them is a sixth of the size
/// of the same colours as RGB.
pub fn error_indices(err: &[f32], s: &LogScale) -> Vec<u8> {
    err.iter().map(|&e| s.index(e as f64)).collect()
}

/// Writes an 8-bit PNG through a temporary file: RGB (`palette` None, 3 bytes a pixel) or
/// indexed (one byte a pixel into `palette`).
pub fn write_png(
    path: &std::path::Path,
    (width, height): (u32, u32),
    data: &[u8],
    palette: Option<Vec<u8>>,
) -> algorithms::Result<()> {
    algorithms::io::atomic_write(path, |out| {
        let mut enc = png::Encoder::new(out, width, height);
        enc.set_depth(png::BitDepth::Eight);
        match palette {
            Some(p) => {
                enc.set_color(png::ColorType::Indexed);
                enc.set_palette(p);
            }
            None => enc.set_color(png::ColorType::Rgb),
        }
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(data).map_err(std::io::Error::other)?;
        w.finish().map_err(std::io::Error::other)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_map_squares_to_the_rmse() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        a.set(0, 0, [0.3, 0.0, 0.0, 1.0]);
        b.set(1, 0, [0.0, 0.1, 0.2, 1.0]);
        let e = error_map(&a, &b).unwrap();
        let rmse = algorithms::metrics::compare(&a, &b).unwrap().rmse;
        let from_map = (e.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / 2.0).sqrt();
        assert!((from_map - rmse).abs() < 1e-7, "{from_map} {rmse}");
        assert!(error_map(&a, &Image::new(1, 1)).is_none());
    }

    #[test]
    fn log_scale_spans_decades_up_to_the_largest_error() {
        let s = LogScale::for_max(0.023);
        assert_eq!((s.lo, s.hi), (1e-6, 0.1));
        assert_eq!(s.position(1e-9), 0.0);
        assert_eq!(s.position(1.0), 1.0);
        assert!((s.position(1e-3) - 0.6).abs() < 1e-12);
        assert_eq!(s.colour(0.0), [0, 0, 0]);
        assert_ne!(s.colour(1e-9), [0, 0, 0]);
        assert_eq!(s.decades().count(), 6);
        assert_eq!(LogScale::for_max(0.0).hi, 1e-6);
    }

    #[test]
    fn integer_rescaling() {
        assert_eq!(Scale::to_fit(128, 256), Scale::Up(2));
        assert_eq!(Scale::to_fit(512, 256), Scale::Down(2));
        assert_eq!(Scale::to_fit(1024, 256), Scale::Down(4));
        // Box filter of premultiplied pixels, then over the checkerboard.
        let mut img = Image::new(2, 2);
        img.set(0, 0, [1.0, 1.0, 1.0, 1.0]);
        let rgb = over_checkerboard(&img, Scale::Down(2));
        assert_eq!((rgb.width, rgb.height), (1, 1));
        let want = quantize(0.25 + 0.75 * CHECKER[0]);
        assert_eq!(rgb.data, vec![want; 3]);
        let up = over_checkerboard(&img, Scale::Up(3));
        assert_eq!((up.width, up.height), (6, 6));
        assert_eq!(up.data[0], 255);
        // An error block pools as its RMS.
        let s = LogScale { lo: 1e-6, hi: 1.0 };
        let fc = false_colour(&[0.0, 0.0, 0.0, 0.2], 2, 2, Scale::Down(2), &s);
        assert_eq!(fc.data, s.colour(0.1).to_vec());
    }
}
