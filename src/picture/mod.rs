//! `Picture`: a straight-alpha RGBA image in memory, f32 in [0, 1], row-major, origin top-left
//! (DESIGN.md "Coordinates"), with PNG load/save that name the file on error.

pub mod draw;

use std::path::Path;

use crate::error::{Error, Result};
use crate::user_file;

/// A straight-alpha RGBA image, `pixels[y * width + x] = [r, g, b, a]`, each in [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels, `width * height` of them.
    pub pixels: Vec<[f32; 4]>,
}

impl Picture {
    /// A picture of one colour.
    pub fn filled(width: u32, height: u32, rgba: [f32; 4]) -> Self {
        Picture {
            width,
            height,
            pixels: vec![rgba; width as usize * height as usize],
        }
    }

    /// The pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the picture (a caller bug).
    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}×{}",
            self.width,
            self.height
        );
        self.pixels[(y * self.width + x) as usize]
    }

    /// The picture with `f` applied to every pixel.
    pub fn mapped(&self, f: impl Fn([f32; 4]) -> [f32; 4]) -> Picture {
        Picture {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|&c| f(c)).collect(),
        }
    }

    /// The part of the picture inside `[x0, x0 + width) × [y0, y0 + height)`.
    ///
    /// # Panics
    /// If the window reaches outside the picture (a caller bug).
    pub fn crop(&self, x0: u32, y0: u32, width: u32, height: u32) -> Picture {
        assert!(
            x0 + width <= self.width && y0 + height <= self.height,
            "window {width}×{height} at ({x0}, {y0}) outside a {}×{} picture",
            self.width,
            self.height
        );
        let pixels = (y0..y0 + height)
            .flat_map(|y| {
                let row = (y * self.width + x0) as usize;
                self.pixels[row..row + width as usize].iter().copied()
            })
            .collect();
        Picture { width, height, pixels }
    }

    /// The alpha channel, row-major.
    pub fn alpha(&self) -> Vec<f32> {
        self.pixels.iter().map(|p| p[3]).collect()
    }

    /// Converts an 8-bit image (any colour type) to straight-alpha f32.
    pub fn from_image(image: &image::DynamicImage) -> Self {
        let rgba = image.to_rgba8();
        let pixels = rgba.pixels().map(|p| p.0.map(|c| c as f32 / 255.0)).collect();
        Picture {
            width: rgba.width(),
            height: rgba.height(),
            pixels,
        }
    }

    /// Converts to an 8-bit RGBA image, rounding and clamping each channel.
    pub fn to_rgba8(&self) -> image::RgbaImage {
        let bytes = self.pixels.iter().flat_map(|p| p.map(to_u8)).collect();
        image::RgbaImage::from_raw(self.width, self.height, bytes).expect("pixel count is width × height")
    }

    /// Reads a PNG (or any format the `image` crate was built with) within the default
    /// [`ImageLimits`].
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, [`Error::Image`] if it cannot be decoded,
    /// [`Error::Limit`] (about `path`) if its header declares more pixels than the limit or the
    /// file is longer than [`ImageLimits::max_file_bytes`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_within(path, &ImageLimits::default())
    }

    /// Reads an image within `limits`: the file's length against
    /// [`ImageLimits::max_file_bytes`] before it is read, the pixels from its header before any
    /// is decoded.
    ///
    /// # Errors
    /// As [`Picture::load`]; also [`Error::Limit`] naming `path` if the file is too long.
    pub fn load_within(path: &Path, limits: &ImageLimits) -> Result<Self> {
        let bytes = user_file::read_bytes(path, limits.max_file_bytes())?;
        Self::decode_within(&bytes, path, limits)
    }

    /// Decodes image bytes within the default [`ImageLimits`]; `path` only names the source in
    /// errors.
    ///
    /// # Errors
    /// [`Error::Image`] if the bytes are not a readable image; [`Error::Limit`] if too large.
    pub fn decode(bytes: &[u8], path: &Path) -> Result<Self> {
        Self::decode_within(bytes, path, &ImageLimits::default())
    }

    /// Decodes image bytes within `limits`; `path` only names the source in errors.
    ///
    /// # Errors
    /// As [`Picture::decode`].
    pub fn decode_within(bytes: &[u8], path: &Path, limits: &ImageLimits) -> Result<Self> {
        let (width, height) = Self::header_size(bytes, path)?;
        limits.check(width, height).map_err(|e| e.with_path(path))?;
        let mut reader = reader(bytes, path)?;
        let mut decoder_limits = image::Limits::default();
        decoder_limits.max_image_width = Some(width);
        decoder_limits.max_image_height = Some(height);
        // The decoder's own buffers: 8 bytes per pixel covers 16-bit RGBA, plus its scratch.
        decoder_limits.max_alloc = Some(8 * u64::from(width) * u64::from(height) + (16 << 20));
        reader.limits(decoder_limits);
        let image = reader
            .decode()
            .map_err(|e| Error::image(path, format!("cannot decode image: {e}")))?;
        Ok(Self::from_image(&image))
    }

    /// The width and height an image file declares in its header, without decoding it.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable, [`Error::Image`] if it is not an image this build reads.
    pub fn file_size(path: &Path) -> Result<(u32, u32)> {
        let reader = image::ImageReader::open(path)
            .map_err(|e| Error::io(path, e))?
            .with_guessed_format()
            .map_err(|e| Error::io(path, e))?;
        reader
            .into_dimensions()
            .map_err(|e| Error::image(path, format!("cannot decode image: {e}")))
    }

    /// The width and height image bytes declare in their header, without decoding them; `path`
    /// only names the source in errors.
    ///
    /// # Errors
    /// [`Error::Image`] if the bytes are not an image this build reads.
    pub fn header_size(bytes: &[u8], path: &Path) -> Result<(u32, u32)> {
        reader(bytes, path)?
            .into_dimensions()
            .map_err(|e| Error::image(path, format!("cannot decode image: {e}")))
    }

    /// Writes the picture as an RGBA PNG, atomically (temporary file, then rename).
    ///
    /// # Errors
    /// [`Error::Io`] or [`Error::Image`] naming `path`.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        crate::atomic_file::write_atomic(path, &self.png_bytes(path)?)
    }

    /// The picture as RGBA PNG bytes; `path` only names the destination in errors.
    ///
    /// # Errors
    /// [`Error::Image`] naming `path` if encoding fails.
    pub fn png_bytes(&self, path: &Path) -> Result<Vec<u8>> {
        let mut bytes = Vec::new();
        self.to_rgba8()
            .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|e| Error::image(path, format!("cannot encode PNG: {e}")))?;
        Ok(bytes)
    }
}

/// Frames composited on white in a grid of `columns`, 2-pixel light grey gutters; each cell is
/// the first frame's size (larger frames are cropped, smaller ones padded with grey).
///
/// # Panics
/// If `frames` is empty or `columns` is 0 (caller bugs).
pub fn contact_sheet(frames: &[&Picture], columns: usize) -> Picture {
    assert!(!frames.is_empty() && columns > 0, "contact sheet of nothing");
    let (w, h) = (frames[0].width as usize, frames[0].height as usize);
    let cols = columns.min(frames.len());
    let rows = frames.len().div_ceil(cols);
    let gap = 2;
    let (sw, sh) = (cols * w + (cols + 1) * gap, rows * h + (rows + 1) * gap);
    let mut sheet = Picture::filled(sw as u32, sh as u32, [0.8, 0.8, 0.8, 1.0]);
    for (k, f) in frames.iter().enumerate() {
        let (ox, oy) = (gap + (k % cols) * (w + gap), gap + (k / cols) * (h + gap));
        for y in 0..h.min(f.height as usize) {
            for x in 0..w.min(f.width as usize) {
                let p = f.pixels[y * f.width as usize + x];
                let a = p[3];
                sheet.pixels[(oy + y) * sw + ox + x] = [p[0] * a + 1.0 - a, p[1] * a + 1.0 - a, p[2] * a + 1.0 - a, 1.0];
            }
        }
    }
    sheet
}

impl Picture {
    /// The picture scaled up `s` times (nearest neighbour), composited on white.
    pub fn upscaled_on_white(&self, s: u32) -> Picture {
        let s = s.max(1);
        let mut out = Picture::filled(self.width * s, self.height * s, [1.0; 4]);
        for y in 0..out.height {
            for x in 0..out.width {
                let [r, g, b, a] = self.get(x / s, y / s);
                out.pixels[(y * out.width + x) as usize] = [r * a + 1.0 - a, g * a + 1.0 - a, b * a + 1.0 - a, 1.0];
            }
        }
        out
    }
}

/// The largest image the library decodes, checked from the header before any pixel is decoded
/// (a 19 KB PNG can declare a canvas that would take gigabytes). In memory a [`Picture`] takes
/// 16 bytes per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageLimits {
    /// Pixels (width × height) of one image.
    pub max_pixels: u64,
}

/// The default [`ImageLimits::max_pixels`]: 4096 × 4096 (256 MB as a [`Picture`]).
pub const DEFAULT_MAX_PIXELS: u64 = 4096 * 4096;

impl Default for ImageLimits {
    fn default() -> Self {
        ImageLimits {
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

impl ImageLimits {
    /// Checks a `width` × `height` image against the limit.
    ///
    /// # Errors
    /// [`Error::Limit`] naming both sizes.
    pub fn check(&self, width: u32, height: u32) -> Result<()> {
        let pixels = u64::from(width) * u64::from(height);
        if pixels > self.max_pixels {
            return Err(Error::limit(format!("a {width}×{height} image"), pixels, self.max_pixels, "pixels"));
        }
        Ok(())
    }

    /// The longest image file read: 8 bytes a pixel of the largest image (a 16-bit RGBA PNG
    /// stored uncompressed) plus 16 MiB for headers and metadata chunks — 144 MiB by default.
    pub fn max_file_bytes(&self) -> u64 {
        self.max_pixels.saturating_mul(8).saturating_add(16 << 20)
    }
}

fn reader<'a>(bytes: &'a [u8], path: &Path) -> Result<image::ImageReader<std::io::Cursor<&'a [u8]>>> {
    image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))
}

fn to_u8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip_is_lossless_at_8_bits() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.png");
        let mut p = Picture::filled(3, 2, [0.0, 0.0, 0.0, 0.0]);
        p.pixels[4] = [1.0, 128.0 / 255.0, 0.0, 64.0 / 255.0];
        p.save_png(&path).unwrap();
        assert_eq!(Picture::load(&path).unwrap(), p);
    }

    #[test]
    fn undecodable_file_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("broken.png");
        std::fs::write(&path, b"not a png").unwrap();
        let err = Picture::load(&path).unwrap_err().to_string();
        assert!(err.contains("broken.png") && err.contains("cannot decode"), "{err}");
    }

    #[test]
    fn an_image_above_the_pixel_limit_is_refused_from_its_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.png");
        Picture::filled(40, 30, [0.0; 4]).save_png(&path).unwrap();
        assert_eq!(Picture::file_size(&path).unwrap(), (40, 30));
        let err = Picture::load_within(&path, &ImageLimits { max_pixels: 1000 }).unwrap_err();
        assert!(
            matches!(
                err.innermost(),
                Error::Limit {
                    amount: 1200,
                    limit: 1000,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
        assert!(Picture::load_within(&path, &ImageLimits { max_pixels: 1200 }).is_ok());
    }
}
