//! Animation export (DESIGN.md pipeline, last box): frames written one by one as numbered PNGs,
//! sprite-sheet pages with engine atlases ([`sheet`]), an animated PNG and an animated GIF —
//! what every frame-making command (in-betweens, dragged poses, exports, the demo) writes —
//! holding one frame and one sheet page in memory however long the animation.
//!
//! The background is a choice: transparent (straight alpha everywhere; GIF, which has 1-bit
//! alpha, keeps pixels of alpha ≥ ½) or an opaque colour every frame is composited on.

mod apng;
mod gif;
pub mod sheet;
mod stream;

use std::borrow::Cow;
use std::path::PathBuf;

use crate::atomic_file::{record, Outputs};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::Puppet;
use crate::render::soft_raster::{Background, Params, SoftRasterizer};
use crate::render::straight_picture;

pub use sheet::MAX_SHEET_SIDE;

/// `p` composited over the opaque colour `background` (RGB in [0, 1]).
fn flatten(p: &Picture, background: [f32; 3]) -> Picture {
    p.mapped(|[r, g, b, a]| {
        let a = a.clamp(0.0, 1.0);
        [
            r * a + background[0] * (1.0 - a),
            g * a + background[1] * (1.0 - a),
            b * a + background[2] * (1.0 - a),
            1.0,
        ]
    })
}

/// Where an animation goes (each output optional) and how it plays.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationFiles {
    /// Numbered PNGs: the folder and the file-name prefix (`dir/<prefix>_000.png`, …).
    pub frames: Option<(PathBuf, String)>,
    /// A sprite sheet and its columns, with its atlas `<stem>.json` beside it (pages
    /// `<stem>_2.png`, … when one page would pass [`MAX_SHEET_SIDE`]).
    pub sprites: Option<(PathBuf, usize)>,
    /// An animated GIF.
    pub gif: Option<PathBuf>,
    /// An animated PNG.
    pub apng: Option<PathBuf>,
    /// Frame time in milliseconds (animations and atlases).
    pub delay_ms: u32,
    /// Transparent, or an opaque colour every output is composited on.
    pub background: Background,
    /// The animations (and the atlas's animation) play the frames forwards, then backwards
    /// without the two ends, so the loop has no jump; the frames of the way back are pushed with
    /// [`AnimationWriter::push_return`].
    pub there_and_back: bool,
}

impl AnimationFiles {
    /// Whether no output is asked for (a writer for it writes nothing, so its frames need not
    /// be rendered).
    pub fn is_empty(&self) -> bool {
        self.frames.is_none() && self.sprites.is_none() && self.gif.is_none() && self.apng.is_none()
    }
}

impl Default for AnimationFiles {
    fn default() -> Self {
        AnimationFiles {
            frames: None,
            sprites: None,
            gif: None,
            apng: None,
            delay_ms: 80,
            background: Background::Transparent,
            there_and_back: false,
        }
    }
}

/// Writes an animation frame by frame, holding one frame and one sprite-sheet page in memory
/// whatever the length: every output path is claimed (see [`Outputs`]) before the first frame.
pub struct AnimationWriter<'o> {
    outputs: &'o Outputs,
    files: AnimationFiles,
    size: (u32, u32),
    total: usize,
    written: usize,
    returned: usize,
    paths: Vec<PathBuf>,
    sprites: Option<sheet::SpritePages>,
    gif: Option<gif::GifStream>,
    apng: Option<apng::ApngStream>,
}

/// Renders each pose of `puppet` (frame pixels) crisply at the puppet's size, passes it through
/// `decorate` (pose index, picture), and writes it to `writer` — and, if the writer's animation
/// plays there and back, the way back.
///
/// # Errors
/// Render errors (a pose of another puppet) and write errors, each naming what failed.
pub fn write_poses(
    puppet: &Puppet,
    poses: &[Vec<[f32; 2]>],
    writer: &mut AnimationWriter<'_>,
    decorate: impl Fn(usize, Picture) -> Picture,
    progress: &dyn Progress,
) -> Result<()> {
    let raster = SoftRasterizer::new(puppet)?;
    let render = |k: usize| -> Result<Picture> {
        let flat: Vec<f32> = poses[k].iter().flatten().copied().collect();
        let (w, h) = (puppet.width as usize, puppet.height as usize);
        let frame = raster.forward(&flat, 1, w, h, &Params::crisp(Background::Transparent))?;
        Ok(decorate(k, straight_picture(&frame.image, puppet.width, puppet.height)))
    };
    for k in 0..poses.len() {
        writer.push(&render(k)?)?;
        progress.advance(1);
    }
    for k in writer.return_frames() {
        writer.push_return(&render(k)?)?;
    }
    Ok(())
}

impl<'o> AnimationWriter<'o> {
    /// Prepares to write `total` frames of `width` × `height` to `files`.
    ///
    /// # Errors
    /// [`Error::Setting`] for no frames, an empty size, 0 sprite columns or an APNG frame time
    /// past 65,535 ms; [`Error::Limit`] if one frame is wider or taller than a sheet page;
    /// [`Error::WouldOverwrite`] (nothing written) if an output is in the way; [`Error::Io`] if
    /// an animation file cannot be created.
    pub fn new(files: &AnimationFiles, total: usize, width: u32, height: u32, outputs: &'o Outputs) -> Result<Self> {
        if total == 0 || width == 0 || height == 0 {
            return Err(Error::setting(
                "animation",
                format!("{total} frames of {width}×{height}"),
                "at least one non-empty frame",
            ));
        }
        let digits = (total - 1).to_string().len().max(3);
        let mut paths = Vec::new();
        if let Some((dir, prefix)) = &files.frames {
            paths.extend((0..total).map(|k| dir.join(format!("{prefix}_{k:0digits$}.png"))));
        }
        let sprites = match &files.sprites {
            Some((path, columns)) => Some(sheet::SpritePages::plan(
                path,
                *columns,
                total,
                (width, height),
                files.delay_ms,
                files.there_and_back,
            )?),
            None => None,
        };
        let sheet_files: Vec<PathBuf> = sprites.iter().flat_map(|s| s.files()).collect();
        for path in paths.iter().chain(&sheet_files).chain(&files.gif).chain(&files.apng) {
            outputs.claim(path)?;
        }
        let played = total + if files.there_and_back { total.saturating_sub(2) } else { 0 };
        let gif = files
            .gif
            .as_deref()
            .map(|path| gif::GifStream::create(path, files.delay_ms, files.background))
            .transpose()?;
        let apng = files
            .apng
            .as_deref()
            .map(|path| apng::ApngStream::create(path, (width, height), played, files.delay_ms))
            .transpose()?;
        Ok(AnimationWriter {
            outputs,
            files: files.clone(),
            size: (width, height),
            total,
            written: 0,
            returned: 0,
            paths,
            sprites,
            gif,
            apng,
        })
    }

    /// The frames of the way back, in the order to push them with
    /// [`AnimationWriter::push_return`] (none unless the animation plays there and back).
    pub fn return_frames(&self) -> Vec<usize> {
        if self.files.there_and_back {
            (1..self.total.saturating_sub(1)).rev().collect()
        } else {
            Vec::new()
        }
    }

    /// Writes the next frame to every output.
    ///
    /// # Errors
    /// [`Error::Mismatch`] for a frame of another size or one past the total; [`Error::Io`]/
    /// [`Error::Image`] naming the file that could not be written.
    pub fn push(&mut self, frame: &Picture) -> Result<()> {
        self.check(frame)?;
        if self.total == self.written {
            return Err(Error::mismatch("the animation's frame count", self.written + 1, self.total));
        }
        let k = self.written;
        let shown = self.on_background(frame);
        if self.files.frames.is_some() {
            shown.save_png(&self.paths[k])?;
        }
        if let Some(sprites) = &mut self.sprites {
            sprites.put(k, &shown)?;
        }
        self.animate(frame, &shown)?;
        self.written += 1;
        Ok(())
    }

    /// Writes a frame of the way back (see [`AnimationFiles::there_and_back`]) to the GIF and
    /// APNG only.
    ///
    /// # Errors
    /// As [`AnimationWriter::push`]; [`Error::Mismatch`] before the last frame forwards or past
    /// the way back's length.
    pub fn push_return(&mut self, frame: &Picture) -> Result<()> {
        self.check(frame)?;
        let back = self.return_frames().len();
        if self.written != self.total || self.returned == back {
            return Err(Error::mismatch(
                "the animation's way back",
                format!("frame {} after {} of {} forwards", self.returned + 1, self.written, self.total),
                format!("{back} frames after all {} forwards", self.total),
            ));
        }
        let shown = self.on_background(frame);
        self.animate(frame, &shown)?;
        self.returned += 1;
        Ok(())
    }

    /// `frame` on the chosen background.
    fn on_background<'f>(&self, frame: &'f Picture) -> Cow<'f, Picture> {
        match self.files.background {
            Background::Transparent => Cow::Borrowed(frame),
            Background::Colour(c) => Cow::Owned(flatten(frame, c)),
        }
    }

    /// Writes a frame to the animations: the GIF takes the straight frame (it handles the
    /// background itself), the APNG the frame on its background.
    fn animate(&mut self, frame: &Picture, shown: &Picture) -> Result<()> {
        if let Some(gif) = &mut self.gif {
            gif.push(frame)?;
        }
        if let Some(apng) = &mut self.apng {
            apng.push(shown)?;
        }
        Ok(())
    }

    fn check(&self, frame: &Picture) -> Result<()> {
        if (frame.width, frame.height) != self.size {
            return Err(Error::mismatch(
                "an animation frame",
                format!("{}×{}", frame.width, frame.height),
                format!("{}×{} (the first frame's)", self.size.0, self.size.1),
            ));
        }
        Ok(())
    }

    /// Finishes every output and returns the files written: PNG frames, sheet pages each with
    /// its atlas, the GIF, the APNG.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if fewer frames were pushed than announced (forwards or back); write
    /// errors naming the file.
    pub fn finish(mut self) -> Result<Vec<PathBuf>> {
        if self.written != self.total {
            return Err(Error::mismatch("the animation's frame count", self.written, self.total));
        }
        let back = self.return_frames().len();
        if self.returned != back {
            return Err(Error::mismatch("the frames of the animation's way back", self.returned, back));
        }
        let mut written = if self.files.frames.is_some() {
            std::mem::take(&mut self.paths)
        } else {
            Vec::new()
        };
        if let Some(sprites) = self.sprites.take() {
            written.extend(sprites.finish()?);
        }
        if let Some(gif) = self.gif.take() {
            written.push(gif.finish()?);
        }
        if let Some(apng) = self.apng.take() {
            written.push(apng.finish()?);
        }
        for path in &written {
            record(path)?;
        }
        let _ = self.outputs;
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::AnimationDecoder;
    use std::path::Path;

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

    fn write(frames: &[Picture], files: &AnimationFiles) -> Vec<PathBuf> {
        let outputs = Outputs::new(false);
        let mut writer = AnimationWriter::new(files, frames.len(), frames[0].width, frames[0].height, &outputs).unwrap();
        for f in frames {
            writer.push(f).unwrap();
        }
        writer.finish().unwrap()
    }

    fn decode_gif(path: &Path) -> Vec<image::Frame> {
        let bytes = std::fs::read(path).unwrap();
        let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(bytes)).unwrap();
        decoder.into_frames().collect_frames().unwrap()
    }

    fn gif(path: PathBuf) -> AnimationFiles {
        AnimationFiles {
            gif: Some(path),
            background: Background::Colour([1.0; 3]),
            ..AnimationFiles::default()
        }
    }

    #[test]
    fn gif_decodes_to_the_frames_on_white_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let frames = frames();
        let path = dir.path().join("t.gif");
        assert_eq!(write(&frames, &gif(path.clone())), std::slice::from_ref(&path));
        let decoded = decode_gif(&path);
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
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "the GIF and the manifest only: {names:?}");
    }

    /// Frames on a transparent background: an opaque red pixel, a half-transparent blue one
    /// and a faint (alpha 0.3) green one, moving along the first row.
    fn soft_frames() -> Vec<Picture> {
        (0..4)
            .map(|k| {
                let mut p = Picture::filled(6, 4, [0.0; 4]);
                p.pixels[k] = [1.0, 0.0, 0.0, 1.0];
                p.pixels[12] = [0.0, 0.0, 1.0, 0.5];
                p.pixels[18] = [0.0, 1.0, 0.0, 0.3];
                p
            })
            .collect()
    }

    #[test]
    fn transparent_apng_and_gif_keep_the_alpha_of_known_pixels_there_and_back() {
        let dir = tempfile::tempdir().unwrap();
        let frames = soft_frames();
        let files = AnimationFiles {
            gif: Some(dir.path().join("a.gif")),
            apng: Some(dir.path().join("a.png")),
            delay_ms: 120,
            there_and_back: true,
            ..AnimationFiles::default()
        };
        let outputs = Outputs::new(false);
        let mut writer = AnimationWriter::new(&files, 4, 6, 4, &outputs).unwrap();
        assert!(writer.push_return(&frames[2]).is_err(), "the way back starts after the last frame");
        for f in &frames {
            writer.push(f).unwrap();
        }
        assert_eq!(writer.return_frames(), [2, 1]);
        for k in writer.return_frames() {
            writer.push_return(&frames[k]).unwrap();
        }
        assert!(writer.push_return(&frames[0]).is_err(), "the way back has two frames");
        writer.finish().unwrap();
        let played = [0, 1, 2, 3, 2, 1];

        let bytes = std::fs::read(dir.path().join("a.png")).unwrap();
        let decoder = image::codecs::png::PngDecoder::new(std::io::Cursor::new(bytes)).unwrap();
        let apng: Vec<image::Frame> = decoder.apng().unwrap().into_frames().collect_frames().unwrap();
        assert_eq!(apng.len(), played.len());
        for (frame, &k) in apng.iter().zip(&played) {
            assert_eq!(frame.delay().numer_denom_ms(), (120, 1));
            let px = |i: u32| frame.buffer().get_pixel(i % 6, i / 6).0;
            assert_eq!(px(k as u32), [255, 0, 0, 255]);
            assert_eq!(px(12), [0, 0, 255, 128]);
            assert_eq!(px(18), [0, 255, 0, 77]);
            assert_eq!(px(23), [0, 0, 0, 0]);
        }

        let gif = decode_gif(&dir.path().join("a.gif"));
        assert_eq!(gif.len(), played.len());
        for (frame, &k) in gif.iter().zip(&played) {
            let px = |i: u32| frame.buffer().get_pixel(i % 6, i / 6).0;
            assert_eq!(px(k as u32), [255, 0, 0, 255], "the drawn pixel");
            assert_eq!(px(12), [0, 0, 255, 255], "alpha ½ is drawn, in its own colour");
            assert_eq!(px(18)[3], 0, "alpha 0.3 is transparent");
            assert_eq!(px(23)[3], 0, "the background is transparent");
            // The previous frame's red pixel does not stay behind (each frame replaces the last).
            let old = (0..4).filter(|&j| j != k).all(|j| px(j as u32)[3] == 0);
            assert!(old, "frame {k} shows an earlier frame's pixel");
        }
    }

    #[test]
    fn a_background_colour_is_under_every_output() {
        let dir = tempfile::tempdir().unwrap();
        let files = AnimationFiles {
            frames: Some((dir.path().to_path_buf(), "f".into())),
            apng: Some(dir.path().join("a.png")),
            background: Background::Colour([0.0, 0.0, 0.0]),
            ..AnimationFiles::default()
        };
        let paths = write(&soft_frames(), &files);
        let frame = Picture::load(&paths[0]).unwrap();
        assert_eq!(frame.get(0, 2), [0.0, 0.0, 128.0 / 255.0, 1.0]);
        assert_eq!(frame.get(5, 3), [0.0, 0.0, 0.0, 1.0]);
        let first = Picture::load(&dir.path().join("a.png")).unwrap();
        assert_eq!(first.pixels, frame.pixels, "the APNG's first frame is the first PNG");
    }

    #[test]
    fn a_small_patch_of_a_rare_colour_keeps_its_colour_in_the_gif() {
        // The Kenney robot's yellow eye (68 pixels among ~5,000 blues): a sampling quantiser
        // (NeuQuant at speed 10) had no palette entry near it and drew it pink.
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
        let dir = tempfile::tempdir().unwrap();
        let gif_path = dir.path().join("eye.gif");
        write(&[frame], &gif(gif_path.clone()));
        let eye = decode_gif(&gif_path)[0].buffer().get_pixel(48, 62).0;
        assert!(eye[0] > 180 && eye[1] > 150 && eye[2] < 90, "the yellow eye came back as {eye:?}");
    }

    #[test]
    fn png_sequence_and_sprite_pages_keep_every_pixel() {
        let dir = tempfile::tempdir().unwrap();
        let frames = frames();
        let files = AnimationFiles {
            frames: Some((dir.path().join("seq"), "step".into())),
            sprites: Some((dir.path().join("sprites.png"), 2)),
            ..AnimationFiles::default()
        };
        let paths = write(&frames, &files);
        assert_eq!(paths.len(), 7);
        assert!(paths[4].ends_with("step_004.png"));
        for (p, f) in paths.iter().zip(&frames) {
            let back = Picture::load(p).unwrap();
            assert!(back
                .pixels
                .iter()
                .zip(&f.pixels)
                .all(|(a, b)| (0..4).all(|c| (a[c] - b[c]).abs() < 1.0 / 255.0)));
        }
        let sheet = Picture::load(&paths[5]).unwrap();
        let atlas: serde_json::Value = serde_json::from_slice(&std::fs::read(&paths[6]).unwrap()).unwrap();
        let third = &atlas["frames"]["sprites_003"];
        assert_eq!(third["frame"], serde_json::json!({"x": 6, "y": 4, "w": 6, "h": 4}));
        assert_eq!((third["sourceSize"]["w"].as_u64(), third["duration"].as_u64()), (Some(6), Some(80)));
        assert_eq!(atlas["meta"]["size"], serde_json::json!({"w": 12, "h": 12}));
        assert_eq!(atlas["meta"]["frameTags"][0]["direction"], "forward");
        assert_eq!((sheet.width, sheet.height), (12, 12));
        // Frame 3 is at column 1, row 1; its red pixel (3, 0) is sheet pixel (9, 4).
        assert_eq!(sheet.get(9, 4), [1.0, 0.0, 0.0, 1.0]);
        // The sixth cell is empty.
        assert_eq!(sheet.get(11, 11), [0.0; 4]);
    }

    #[test]
    fn a_long_animation_wraps_into_rows_and_pages() {
        let dir = tempfile::tempdir().unwrap();
        let frame = Picture::filled(1000, 1000, [0.0, 1.0, 0.0, 1.0]);
        let files = AnimationFiles {
            sprites: Some((dir.path().join("sprites.png"), 64)),
            ..AnimationFiles::default()
        };
        // 4 columns × 4 rows fit a 4096 px page: 17 frames need two pages.
        let outputs = Outputs::new(false);
        let mut writer = AnimationWriter::new(&files, 17, 1000, 1000, &outputs).unwrap();
        for _ in 0..17 {
            writer.push(&frame).unwrap();
        }
        let pages = writer.finish().unwrap();
        let [page1, atlas1, page2, atlas2] = [
            dir.path().join("sprites.png"),
            dir.path().join("sprites.json"),
            dir.path().join("sprites_2.png"),
            dir.path().join("sprites_2.json"),
        ];
        assert_eq!(pages, [page1, atlas1.clone(), page2, atlas2.clone()]);
        let atlas = |p: &Path| -> serde_json::Value { serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap() };
        let (first, second) = (atlas(&atlas1), atlas(&atlas2));
        assert_eq!(first["frames"].as_object().unwrap().len(), 16);
        assert_eq!(
            second["frames"]["sprites_016"]["frame"],
            serde_json::json!({"x": 0, "y": 0, "w": 1000, "h": 1000})
        );
        assert_eq!(second["meta"]["image"], "sprites_2.png");
        assert_eq!(first["animations"]["sprites"].as_array().unwrap().len(), 17);
        // PixiJS loads the second page with the first (TexturePacker's multipack field).
        assert_eq!(first["meta"]["related_multi_packs"], serde_json::json!(["sprites_2.json"]));
        assert!(second["meta"].get("related_multi_packs").is_none());
        assert_eq!(Picture::file_size(&pages[0]).unwrap(), (4000, 4000));
        assert_eq!(Picture::file_size(&pages[2]).unwrap(), (1000, 1000));
    }

    #[test]
    fn wrong_counts_sizes_and_occupied_outputs_are_errors_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let outputs = Outputs::new(false);
        assert!(AnimationWriter::new(&AnimationFiles::default(), 0, 6, 4, &outputs).is_err());
        let files = gif(dir.path().join("a.gif"));
        let mut writer = AnimationWriter::new(&files, 1, 6, 4, &outputs).unwrap();
        let err = writer.push(&Picture::filled(3, 3, [0.0; 4])).unwrap_err().to_string();
        assert!(err.contains("3×3") && err.contains("6×4"), "{err}");
        assert!(writer.finish().is_err(), "no frame was written");
        std::fs::write(dir.path().join("b.gif"), b"user's").unwrap();
        let fresh = Outputs::new(false);
        let taken = AnimationWriter::new(&gif(dir.path().join("b.gif")), 1, 6, 4, &fresh);
        assert!(matches!(taken, Err(Error::WouldOverwrite { .. })));
        assert_eq!(std::fs::read(dir.path().join("b.gif")).unwrap(), b"user's");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }
}
