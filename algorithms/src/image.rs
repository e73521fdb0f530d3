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
    /// The most pixels an image read from a file may have: the largest image tetbench renders
    /// (16384 × 16384). A header that announces more is refused before anything is allocated.
    pub const MAX_PIXELS: u64 = 16384 * 16384;

    /// A transparent black image. Panics where memory cannot hold it: images whose size comes
    /// from outside (a frame of a renderer, a file) are made with [`Image::try_new`].
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0; 4]; width as usize * height as usize],
        }
    }

    /// A transparent black image, or an error naming its size when memory cannot hold it
    /// (see [`crate::util::alloc::try_vec`]).
    pub fn try_new(width: u32, height: u32) -> Result<Image> {
        let n = width as usize * height as usize;
        let pixels = crate::util::alloc::try_vec(n, [0.0; 4])
            .map_err(|e| Error::Input(format!("image {width}x{height}: {e}")))?;
        Ok(Image {
            width,
            height,
            pixels,
        })
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
        let mut data = crate::util::alloc::try_vec_with_capacity(4 * self.pixels.len())
            .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
        data.extend(self.pixels.iter().flatten().map(|&v| quantize(v)));
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

/// Checks the size an image file's header announces before anything of that size is
/// allocated: at most [`Image::MAX_PIXELS`], and no more raw bytes than a file of `file_len`
/// bytes can hold at the best ratio its compression reaches (`max_ratio`; 1 uncompressed).
fn check_announced(
    path: &Path,
    (w, h): (u64, u64),
    raw_per_pixel: u64,
    file_len: u64,
    max_ratio: u64,
) -> Result<()> {
    let pixels = w.saturating_mul(h);
    if pixels > Image::MAX_PIXELS {
        return Err(Error::Input(format!(
            "{}: its header announces {w}x{h} pixels, more than the {} an image may have",
            path.display(),
            Image::MAX_PIXELS
        )));
    }
    let raw = pixels.saturating_mul(raw_per_pixel);
    if raw > file_len.saturating_mul(max_ratio).saturating_add(4096) {
        return Err(Error::Input(format!(
            "{}: its header announces {w}x{h} pixels ({raw} bytes of samples), more than its {file_len} bytes can hold: a damaged or forged file",
            path.display()
        )));
    }
    Ok(())
}

/// The best ratio of raw to stored bytes an EXR compression reaches (deflate's is about
/// 1032:1; run-length's 64:1 on bytes; PIZ's Huffman runs stay below deflate's); generous, as
/// it only has to catch a header that lies by orders of magnitude.
fn exr_max_ratio(c: exr::compression::Compression) -> u64 {
    use exr::compression::Compression as C;
    match c {
        C::Uncompressed => 1,
        C::RLE => 64,
        _ => 4096,
    }
}

fn read_exr(path: &Path) -> Result<Image> {
    use std::io::Seek;
    let bad =
        |e: exr::error::Error| crate::Error::input(path.display(), format!("bad EXR file: {e}"));
    let file = crate::io::open_input(path)?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut reader = std::io::BufReader::new(file);
    let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false).map_err(bad)?;
    for h in &meta.headers {
        let size = (h.layer_size.width() as u64, h.layer_size.height() as u64);
        let per_pixel = h.channels.bytes_per_pixel as u64;
        check_announced(path, size, per_pixel, len, exr_max_ratio(h.compression))?;
    }
    reader
        .seek(std::io::SeekFrom::Start(0))
        .map_err(|e| Error::io(path, e))?;
    // The image is allocated here, fallibly, at the size of the largest layer (the one read is
    // no larger); the reader's callback then takes it.
    let (w, h) = meta
        .headers
        .iter()
        .map(|h| (h.layer_size.width() as u32, h.layer_size.height() as u32))
        .max_by_key(|&(w, h)| w as u64 * h as u64)
        .unwrap_or((0, 0));
    let room = std::cell::Cell::new(Some(Image::try_new(w, h)?));
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            move |res, _| {
                let (w, h) = (res.width() as u32, res.height() as u32);
                let mut img = room.take().unwrap_or_else(|| self::Image {
                    width: 0,
                    height: 0,
                    pixels: Vec::new(),
                });
                img.pixels.truncate(w as usize * h as usize);
                img.pixels.resize(w as usize * h as usize, [0.0; 4]);
                img.width = w;
                img.height = h;
                img
            },
            |img: &mut self::Image, pos, (r, g, b, a): (f32, f32, f32, f32)| {
                img.set(pos.x() as u32, pos.y() as u32, [r, g, b, a])
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(bad)?;
    Ok(image.layer_data.channel_data.pixels)
}

fn read_png(path: &Path) -> Result<Image> {
    let bad = |e: String| Error::input(path.display(), format!("bad PNG file: {e}"));
    let file = crate::io::open_input(path)?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| bad(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("image too large".into()))?;
    // PNG's samples are deflated: at best about 1032:1.
    let info = reader.info();
    let (w, h) = (info.width as u64, info.height as u64);
    check_announced(
        path,
        (w, h),
        (size as u64 / (w * h).max(1)).max(1),
        len,
        1100,
    )?;
    let mut buf = crate::util::alloc::try_vec(size, 0u8)
        .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    let (w, h) = (info.width, info.height);
    let n = w as usize * h as usize;
    let mut px = crate::util::alloc::try_vec_with_capacity::<[f32; 4]>(n)
        .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
    let pixel: fn(&[u8]) -> [f32; 4] = match info.color_type {
        png::ColorType::Rgba => |c| [to_f(c[0]), to_f(c[1]), to_f(c[2]), to_f(c[3])],
        png::ColorType::Rgb => |c| [to_f(c[0]), to_f(c[1]), to_f(c[2]), 1.0],
        png::ColorType::GrayscaleAlpha => |c| [to_f(c[0]), to_f(c[0]), to_f(c[0]), to_f(c[1])],
        png::ColorType::Grayscale => |c| [to_f(c[0]), to_f(c[0]), to_f(c[0]), 1.0],
        other => return Err(bad(format!("unsupported colour type {other:?}"))),
    };
    let channels = info.color_type.samples();
    px.extend(buf[..n * channels].chunks_exact(channels).map(pixel));
    Ok(Image {
        width: w,
        height: h,
        pixels: px,
    })
}

/// 8-bit sample to [0, 1].
fn to_f(v: u8) -> f32 {
    v as f32 / 255.0
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
