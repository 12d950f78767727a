//! `Picture`: a straight-alpha RGBA image in memory, f32 in [0, 1], row-major, origin top-left
//! (DESIGN.md "Coordinates"), with PNG load/save that name the file on error.

use std::path::Path;

use crate::error::{Error, Result};

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

    /// Reads a PNG (or any format the `image` crate was built with).
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, [`Error::Image`] if it cannot be decoded.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::decode(&bytes, path)
    }

    /// Decodes image bytes; `path` only names the source in errors.
    ///
    /// # Errors
    /// [`Error::Image`] if the bytes are not a readable image.
    pub fn decode(bytes: &[u8], path: &Path) -> Result<Self> {
        let image = image::load_from_memory(bytes).map_err(|e| Error::Image {
            path: path.to_path_buf(),
            problem: format!("cannot decode image: {e}"),
        })?;
        Ok(Self::from_image(&image))
    }

    /// Writes the picture as an RGBA PNG, atomically (temporary file, then rename).
    ///
    /// # Errors
    /// [`Error::Io`] or [`Error::Image`] naming `path`.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let mut bytes = Vec::new();
        self.to_rgba8()
            .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|e| Error::Image {
                path: path.to_path_buf(),
                problem: format!("cannot encode PNG: {e}"),
            })?;
        crate::atomic_file::write_atomic(path, &bytes)
    }
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
}
