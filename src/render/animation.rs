//! Animation export (DESIGN.md pipeline, last box: "frames, GIF/APNG, sprite sheets"): a list of
//! same-size frames to an animated GIF, a numbered PNG sequence, or a sprite sheet — what every
//! frame-making command (in-betweens, dragged poses, the demo) writes.
//!
//! GIF has only 1-bit transparency and a 256-colour palette, so frames are composited on an
//! opaque background colour first (white by default) and quantised per frame by the `image`
//! crate (NeuQuant). PNG sequences and sprite sheets keep straight alpha.

use std::path::{Path, PathBuf};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame};

use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::picture::Picture;

/// Checks `frames` is non-empty and all of one size; returns that size.
fn common_size(frames: &[Picture], what: &Path) -> Result<(u32, u32)> {
    let first = frames
        .first()
        .ok_or_else(|| Error::Invalid(format!("{}: no frames to write", what.display())))?;
    let size = (first.width, first.height);
    if size.0 == 0 || size.1 == 0 {
        return Err(Error::Invalid(format!(
            "{}: frames are {}×{} (empty)",
            what.display(),
            size.0,
            size.1
        )));
    }
    if let Some((k, f)) = frames.iter().enumerate().find(|(_, f)| (f.width, f.height) != size) {
        return Err(Error::Invalid(format!(
            "{}: frame {k} is {}×{}, frame 0 is {}×{} (all frames must be one size)",
            what.display(),
            f.width,
            f.height,
            size.0,
            size.1
        )));
    }
    Ok(size)
}

/// `p` composited over the opaque colour `background` (RGB in [0, 1]).
fn flatten(p: &Picture, background: [f32; 3]) -> Picture {
    Picture {
        width: p.width,
        height: p.height,
        pixels: p
            .pixels
            .iter()
            .map(|&[r, g, b, a]| {
                let a = a.clamp(0.0, 1.0);
                [
                    r * a + background[0] * (1.0 - a),
                    g * a + background[1] * (1.0 - a),
                    b * a + background[2] * (1.0 - a),
                    1.0,
                ]
            })
            .collect(),
    }
}

/// The frames as an animated GIF (looping forever), each shown `delay_ms` milliseconds and
/// composited on `background`.
///
/// # Errors
/// [`Error::Invalid`] for no frames or frames of different sizes; [`Error::Image`] if encoding fails.
pub fn gif_bytes(frames: &[Picture], delay_ms: u32, background: [f32; 3], what: &Path) -> Result<Vec<u8>> {
    common_size(frames, what)?;
    let mut bytes = Vec::new();
    {
        // Speed 1: NeuQuant learns the palette from every pixel. At 10 it samples a tenth and,
        // on a rendered robot, lost the small yellow eye (drawn pink); frames here are small.
        let mut encoder = GifEncoder::new_with_speed(&mut bytes, 1);
        let image_error = |e: image::ImageError| Error::Image {
            path: what.to_path_buf(),
            problem: format!("cannot encode GIF: {e}"),
        };
        encoder.set_repeat(Repeat::Infinite).map_err(image_error)?;
        let delay = Delay::from_numer_denom_ms(delay_ms.max(1), 1);
        encoder
            .encode_frames(
                frames
                    .iter()
                    .map(|f| Frame::from_parts(flatten(f, background).to_rgba8(), 0, 0, delay)),
            )
            .map_err(image_error)?;
    }
    Ok(bytes)
}

/// Writes [`gif_bytes`] to `path` atomically.
///
/// # Errors
/// As [`gif_bytes`], plus [`Error::Io`] naming `path`.
pub fn write_gif(path: &Path, frames: &[Picture], delay_ms: u32, background: [f32; 3]) -> Result<()> {
    let bytes = gif_bytes(frames, delay_ms, background, path)?;
    write_atomic(path, &bytes)
}

/// Writes the frames as `dir/<prefix>_000.png`, `…_001.png`, … (zero-padded to the count's
/// width, at least 3 digits) and returns the paths in order.
///
/// # Errors
/// [`Error::Invalid`] for no frames or mixed sizes; [`Error::Io`]/[`Error::Image`] naming the file.
pub fn write_png_sequence(dir: &Path, prefix: &str, frames: &[Picture]) -> Result<Vec<PathBuf>> {
    common_size(frames, dir)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let digits = frames.len().saturating_sub(1).to_string().len().max(3);
    frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let path = dir.join(format!("{prefix}_{k:0digits$}.png"));
            f.save_png(&path)?;
            Ok(path)
        })
        .collect()
}

/// Tiles the frames left to right, top to bottom, `columns` per row (frame `k` at column
/// `k % columns`, row `k / columns`), keeping alpha; empty cells stay transparent.
///
/// # Errors
/// [`Error::Invalid`] for no frames, mixed sizes or `columns == 0`.
pub fn sprite_sheet(frames: &[Picture], columns: usize) -> Result<Picture> {
    let (w, h) = common_size(frames, Path::new("sprite sheet"))?;
    if columns == 0 {
        return Err(Error::Invalid("sprite sheet: 0 columns".into()));
    }
    let cols = columns.min(frames.len());
    let rows = frames.len().div_ceil(cols);
    let (w, h) = (w as usize, h as usize);
    let sw = cols * w;
    let mut sheet = Picture::filled(sw as u32, (rows * h) as u32, [0.0; 4]);
    for (k, f) in frames.iter().enumerate() {
        let (ox, oy) = ((k % cols) * w, (k / cols) * h);
        for y in 0..h {
            sheet.pixels[(oy + y) * sw + ox..(oy + y) * sw + ox + w].copy_from_slice(&f.pixels[y * w..(y + 1) * w]);
        }
    }
    Ok(sheet)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames() -> Vec<Picture> {
        (0..5)
            .map(|k| {
                let mut p = Picture::filled(6, 4, [0.0; 4]);
                p.pixels[k] = [1.0, 0.0, 0.0, 1.0];
                p.pixels[23 - k] = [0.0, 0.0, 1.0, 0.5];
                p
            })
            .collect()
    }

    #[test]
    fn gif_decodes_to_the_frames_on_white() {
        use image::AnimationDecoder;
        let frames = frames();
        let bytes = gif_bytes(&frames, 80, [1.0; 3], Path::new("t.gif")).unwrap();
        let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(bytes)).unwrap();
        let decoded = decoder.into_frames().collect_frames().unwrap();
        assert_eq!(decoded.len(), 5);
        for (k, (d, f)) in decoded.iter().zip(&frames).enumerate() {
            assert_eq!(d.delay().numer_denom_ms(), (80, 1));
            let want = flatten(f, [1.0; 3]).to_rgba8();
            let got = d.buffer();
            assert_eq!((got.width(), got.height()), (6, 4));
            for (a, b) in got.pixels().zip(want.pixels()) {
                // Palette quantisation: a few levels per channel at most on so few colours.
                assert!(
                    a.0.iter().zip(b.0).all(|(x, y)| (*x as i32 - y as i32).abs() <= 8),
                    "frame {k}: {a:?} vs {b:?}"
                );
            }
        }
    }

    #[test]
    fn a_small_patch_of_a_rare_colour_keeps_its_colour_in_the_gif() {
        // The Kenney robot's yellow eye (68 pixels among ~5,000 blues): a sampling quantiser
        // (NeuQuant at speed 10) had no palette entry near it and drew it pink.
        use image::AnimationDecoder;
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/kenney/robot/frames/robot_idle.png");
        let drawn = Picture::load(&path).unwrap();
        // Resampled as a render is (a 3×3 box filter): thousands of in-between shades to sample.
        let mut frame = drawn.clone();
        for y in 1..drawn.height - 1 {
            for x in 1..drawn.width - 1 {
                let mut sum = [0.0f32; 4];
                for (dx, dy) in (0..9).map(|k| (k % 3, k / 3)) {
                    let p = drawn.get(x + dx - 1, y + dy - 1);
                    (0..4).for_each(|c| sum[c] += p[c] / 9.0);
                }
                frame.pixels[(y * drawn.width + x) as usize] = sum;
            }
        }
        let want = frame.get(48, 62);
        assert!(want[0] > 0.8 && want[2] < 0.3, "the test expects the eye at (48, 62): {want:?}");
        let bytes = gif_bytes(&[frame], 80, [1.0; 3], Path::new("t.gif")).unwrap();
        let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(bytes)).unwrap();
        let decoded = decoder.into_frames().collect_frames().unwrap();
        let eye = decoded[0].buffer().get_pixel(48, 62).0;
        assert!(eye[0] > 180 && eye[1] > 150 && eye[2] < 90, "the yellow eye came back as {eye:?}");
    }

    #[test]
    fn png_sequence_and_sprite_sheet_keep_every_pixel() {
        let dir = tempfile::tempdir().unwrap();
        let frames = frames();
        let paths = write_png_sequence(dir.path(), "step", &frames).unwrap();
        assert_eq!(paths.len(), 5);
        assert!(paths[4].ends_with("step_004.png"));
        for (p, f) in paths.iter().zip(&frames) {
            let back = Picture::load(p).unwrap();
            assert_eq!(back.pixels.len(), f.pixels.len());
            assert!(back
                .pixels
                .iter()
                .zip(&f.pixels)
                .all(|(a, b)| (0..4).all(|c| (a[c] - b[c]).abs() < 1.0 / 255.0)));
        }
        let sheet = sprite_sheet(&frames, 2).unwrap();
        assert_eq!((sheet.width, sheet.height), (12, 12));
        // Frame 3 is at column 1, row 1; its red pixel (3, 0) is sheet pixel (9, 4).
        assert_eq!(sheet.get(9, 4), [1.0, 0.0, 0.0, 1.0]);
        // The sixth cell is empty.
        assert_eq!(sheet.get(11, 11), [0.0; 4]);
    }

    #[test]
    fn empty_and_mixed_frame_lists_are_errors() {
        let err = gif_bytes(&[], 50, [1.0; 3], Path::new("out.gif")).unwrap_err().to_string();
        assert!(err.contains("out.gif") && err.contains("no frames"), "{err}");
        let mut frames = frames();
        frames.push(Picture::filled(3, 3, [0.0; 4]));
        let err = sprite_sheet(&frames, 3).unwrap_err().to_string();
        assert!(err.contains("frame 5 is 3×3"), "{err}");
        assert!(sprite_sheet(&frames[..2], 0).is_err());
    }
}
