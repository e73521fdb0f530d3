//! Images (CONVENTIONS §5): RGBA f32, linear, premultiplied, row 0 at the top. Written as `.exr`
//! (the renderer's own numbers) or `.png` (8-bit, `floor(255·clamp(v, 0, 1) + 0.5)`, no gamma).

use std::path::Path;

use crate::error::{Error, Result};
use crate::io::atomic_write;

#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<[f32; 4]>,
}

/// The 8-bit quantisation of §5 and §6: `floor(255·clamp(v, 0, 1) + 0.5)`.
#[inline]
pub fn quantize(v: f32) -> u8 {
    // NaN clamps to 0 (f32::clamp keeps NaN, so handle it first).
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (255.0 * v + 0.5).floor() as u8
}

impl Image {
    /// A transparent black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0; 4]; width as usize * height as usize],
        }
    }

    #[inline]
    pub fn get(&self, i: u32, j: u32) -> [f32; 4] {
        self.pixels[(j * self.width + i) as usize]
    }

    #[inline]
    pub fn set(&mut self, i: u32, j: u32, v: [f32; 4]) {
        self.pixels[(j * self.width + i) as usize] = v;
    }

    /// Number of pixels with a NaN or infinite channel.
    pub fn non_finite_pixels(&self) -> usize {
        self.pixels
            .iter()
            .filter(|p| p.iter().any(|c| !c.is_finite()))
            .count()
    }

    /// Reads `.exr` or `.png` by extension.
    pub fn read(path: &Path) -> Result<Image> {
        if !path.exists() {
            return Err(Error::Input(format!("{}: no such file", path.display())));
        }
        match ext(path).as_str() {
            "exr" => read_exr(path),
            "png" => read_png(path),
            e => Err(Error::Input(format!(
                "{}: unknown image format '.{e}' (known: .exr, .png)",
                path.display()
            ))),
        }
    }

    /// Writes `.exr` or `.png` by extension, atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        match ext(path).as_str() {
            "exr" => self.write_exr(path),
            "png" => self.write_png(path),
            e => Err(Error::Input(format!(
                "{}: unknown image format '.{e}' (known: .exr, .png)",
                path.display()
            ))),
        }
    }

    fn write_exr(&self, path: &Path) -> Result<()> {
        use exr::prelude::*;
        let w = self.width as usize;
        let channels = SpecificChannels::rgba(|pos: Vec2<usize>| {
            let p = self.pixels[pos.y() * w + pos.x()];
            (p[0], p[1], p[2], p[3])
        });
        let image = exr::image::Image::from_channels((w, self.height as usize), channels);
        atomic_write(path, |out| {
            let mut buf = std::io::Cursor::new(Vec::new());
            image
                .write()
                .to_buffered(&mut buf)
                .map_err(|e| std::io::Error::other(e.to_string()))?;
            std::io::Write::write_all(out, &buf.into_inner())
        })
    }

    fn write_png(&self, path: &Path) -> Result<()> {
        let data: Vec<u8> = self.pixels.iter().flatten().map(|&v| quantize(v)).collect();
        atomic_write(path, |out| {
            let mut enc = png::Encoder::new(out, self.width, self.height);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().map_err(std::io::Error::other)?;
            w.write_image_data(&data).map_err(std::io::Error::other)?;
            w.finish().map_err(std::io::Error::other)
        })
    }
}

fn ext(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

fn read_exr(path: &Path) -> Result<Image> {
    let bad =
        |e: exr::error::Error| crate::Error::input(path.display(), format!("bad EXR file: {e}"));
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| self::Image::new(res.width() as u32, res.height() as u32),
        |img: &mut self::Image, pos, (r, g, b, a): (f32, f32, f32, f32)| {
            img.set(pos.x() as u32, pos.y() as u32, [r, g, b, a])
        },
    )
    .map_err(bad)?;
    Ok(image.layer_data.channel_data.pixels)
}

fn read_png(path: &Path) -> Result<Image> {
    let bad = |e: String| Error::input(path.display(), format!("bad PNG file: {e}"));
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| bad(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    let (w, h) = (info.width, info.height);
    let n = w as usize * h as usize;
    let to_f = |v: u8| v as f32 / 255.0;
    let px: Vec<[f32; 4]> = match info.color_type {
        png::ColorType::Rgba => buf[..n * 4]
            .chunks_exact(4)
            .map(|c| [to_f(c[0]), to_f(c[1]), to_f(c[2]), to_f(c[3])])
            .collect(),
        png::ColorType::Rgb => buf[..n * 3]
            .chunks_exact(3)
            .map(|c| [to_f(c[0]), to_f(c[1]), to_f(c[2]), 1.0])
            .collect(),
        png::ColorType::GrayscaleAlpha => buf[..n * 2]
            .chunks_exact(2)
            .map(|c| [to_f(c[0]), to_f(c[0]), to_f(c[0]), to_f(c[1])])
            .collect(),
        png::ColorType::Grayscale => buf[..n]
            .iter()
            .map(|&c| [to_f(c), to_f(c), to_f(c), 1.0])
            .collect(),
        other => return Err(bad(format!("unsupported colour type {other:?}"))),
    };
    Ok(Image {
        width: w,
        height: h,
        pixels: px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantisation_rounds_halves_up_and_clamps() {
        assert_eq!(quantize(0.0), 0);
        assert_eq!(quantize(1.0), 255);
        assert_eq!(quantize(2.0), 255);
        assert_eq!(quantize(-1.0), 0);
        assert_eq!(quantize(f32::NAN), 0);
        assert_eq!(quantize(0.5 / 255.0), 1);
        assert_eq!(quantize(0.49 / 255.0), 0);
        assert_eq!(quantize(0.5), 128);
    }

    #[test]
    fn exr_and_png_round_trip() {
        let dir = std::env::temp_dir().join(format!("tetbench-img-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(3, 2);
        img.set(0, 0, [0.1, 0.2, 0.3, 0.4]);
        img.set(2, 1, [1.5, -0.25, 1e-7, 1.0]);
        let exr = dir.join("a.exr");
        img.write(&exr).unwrap();
        assert_eq!(Image::read(&exr).unwrap(), img);
        let png = dir.join("a.png");
        img.write(&png).unwrap();
        let back = Image::read(&png).unwrap();
        assert_eq!(
            back.get(0, 0),
            [26.0 / 255.0, 51.0 / 255.0, 77.0 / 255.0, 102.0 / 255.0]
        );
        assert_eq!(back.get(2, 1), [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(back.get(1, 0), [0.0; 4]);
        assert!(Image::read(&dir.join("missing.png")).is_err());
        std::fs::write(dir.join("junk.exr"), b"not an exr").unwrap();
        let e = Image::read(&dir.join("junk.exr")).unwrap_err().to_string();
        assert!(e.contains("junk.exr") && !e.contains('\n'), "{e}");
        // No temporary files are left behind.
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 3);
        std::fs::remove_dir_all(&dir).ok();
    }
}
