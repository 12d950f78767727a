//! Animation export (DESIGN.md pipeline, last box): frames written one by one as numbered PNGs,
//! sprite-sheet pages and an animated GIF — what every frame-making command (in-betweens,
//! dragged poses, the demo) writes — holding one frame and one sheet page in memory however
//! long the animation.
//!
//! GIF has only 1-bit transparency and a 256-colour palette, so frames are composited on an
//! opaque background colour first (white by default) and quantised per frame by the `image`
//! crate (NeuQuant). PNG sequences and sprite sheets keep straight alpha.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame};

use crate::atomic_file::{record, write_atomic, Outputs};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::Puppet;
use crate::render::soft_raster::{Background, Params, SoftRasterizer};
use crate::render::straight_picture;

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

/// The largest side of a sprite-sheet page: frames past it go on further pages (4096 px is the
/// texture size every engine and GPU takes; a page is 64 MB while it is filled).
pub const MAX_SHEET_SIDE: u32 = 4096;

/// An animated GIF's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct GifSettings {
    /// The file.
    pub path: PathBuf,
    /// Frame time in milliseconds.
    pub delay_ms: u32,
    /// The opaque colour frames are composited on (RGB in [0, 1]): GIF has 1-bit alpha.
    pub background: [f32; 3],
}

/// Where an animation goes; each output is optional.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnimationFiles {
    /// Numbered PNGs: the folder and the file-name prefix (`dir/<prefix>_000.png`, …).
    pub frames: Option<(PathBuf, String)>,
    /// A sprite sheet and its columns (pages `<stem>_2.png`, … when one page would pass
    /// [`MAX_SHEET_SIDE`]).
    pub sprites: Option<(PathBuf, usize)>,
    /// An animated GIF.
    pub gif: Option<GifSettings>,
}

/// Writes an animation frame by frame, holding one frame and one sprite-sheet page in memory
/// whatever the length: every output path is claimed (see [`Outputs`]) before the first frame.
pub struct AnimationWriter<'o> {
    outputs: &'o Outputs,
    files: AnimationFiles,
    size: (u32, u32),
    total: usize,
    written: usize,
    paths: Vec<PathBuf>,
    sprites: Option<SpritePages>,
    gif: Option<GifStream>,
}

/// The sprite-sheet page being filled.
struct SpritePages {
    pages: Vec<PathBuf>,
    columns: usize,
    per_page: usize,
    cell: (u32, u32),
    page: image::RgbaImage,
}

/// Renders each pose of `puppet` (frame pixels) crisply at the puppet's size, passes it through
/// `decorate` (pose index, picture), and writes it to `writer`; with `there_and_back` the GIF
/// then plays the poses backwards (without the two ends), so its loop has no jump.
///
/// # Errors
/// Render errors (a pose of another puppet) and write errors, each naming what failed.
pub fn write_poses(
    puppet: &Puppet,
    poses: &[Vec<[f32; 2]>],
    writer: &mut AnimationWriter<'_>,
    there_and_back: bool,
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
    if there_and_back {
        for k in (1..poses.len().saturating_sub(1)).rev() {
            writer.push_gif(&render(k)?)?;
        }
    }
    Ok(())
}

/// A GIF written to a temporary sibling and renamed when finished.
struct GifStream {
    encoder: GifEncoder<FileSink>,
    sink: FileSink,
    tmp: PathBuf,
    path: PathBuf,
    delay: Delay,
    background: [f32; 3],
}

impl Drop for GifStream {
    fn drop(&mut self) {
        // Only an unfinished stream still has its temporary file.
        let _ = std::fs::remove_file(&self.tmp);
    }
}

impl<'o> AnimationWriter<'o> {
    /// Prepares to write `total` frames of `width` × `height` to `files`.
    ///
    /// # Errors
    /// [`Error::Setting`] for no frames, an empty size or 0 sprite columns; [`Error::Limit`] if
    /// one frame is wider or taller than a sheet page; [`Error::WouldOverwrite`] (nothing
    /// written) if an output is in the way; [`Error::Io`] if the GIF cannot be created.
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
            Some((path, columns)) => Some(SpritePages::plan(path, *columns, total, width, height)?),
            None => None,
        };
        let claims = paths
            .iter()
            .chain(sprites.iter().flat_map(|s| &s.pages))
            .chain(files.gif.iter().map(|g| &g.path));
        for path in claims {
            outputs.claim(path)?;
        }
        let gif = files.gif.as_ref().map(GifStream::create).transpose()?;
        Ok(AnimationWriter {
            outputs,
            files: files.clone(),
            size: (width, height),
            total,
            written: 0,
            paths,
            sprites,
            gif,
        })
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
        if self.files.frames.is_some() {
            frame.save_png(&self.paths[k])?;
        }
        if let Some(sprites) = &mut self.sprites {
            sprites.put(k, frame, self.total)?;
        }
        self.push_gif(frame)?;
        self.written += 1;
        Ok(())
    }

    /// Writes a frame to the GIF only (a loop's way back, which the other outputs do not repeat).
    ///
    /// # Errors
    /// As [`AnimationWriter::push`].
    pub fn push_gif(&mut self, frame: &Picture) -> Result<()> {
        self.check(frame)?;
        match &mut self.gif {
            Some(gif) => gif.push(frame),
            None => Ok(()),
        }
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

    /// Finishes every output and returns the files written, PNG frames first.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if fewer frames were pushed than announced; write errors naming the
    /// file.
    pub fn finish(mut self) -> Result<Vec<PathBuf>> {
        if self.written != self.total {
            return Err(Error::mismatch("the animation's frame count", self.written, self.total));
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
        for path in &written {
            record(path)?;
        }
        let _ = self.outputs;
        Ok(written)
    }
}

impl SpritePages {
    fn plan(path: &Path, columns: usize, total: usize, width: u32, height: u32) -> Result<Self> {
        if columns == 0 {
            return Err(Error::setting("sprite sheet columns", 0, "at least 1"));
        }
        if width > MAX_SHEET_SIDE || height > MAX_SHEET_SIDE {
            return Err(Error::limit(
                format!("a {width}×{height} frame on a sprite sheet"),
                u64::from(width.max(height)),
                u64::from(MAX_SHEET_SIDE),
                "px",
            ));
        }
        let columns = columns.min(total).min((MAX_SHEET_SIDE / width) as usize).max(1);
        let rows_per_page = (MAX_SHEET_SIDE / height) as usize;
        let per_page = columns * rows_per_page;
        let count = total.div_ceil(per_page);
        let stem = path
            .file_stem()
            .map_or_else(|| "sprites".into(), |s| s.to_string_lossy().into_owned());
        let pages = (0..count)
            .map(|p| {
                if p == 0 {
                    path.to_path_buf()
                } else {
                    path.with_file_name(format!("{stem}_{}.png", p + 1))
                }
            })
            .collect();
        Ok(SpritePages {
            pages,
            columns,
            per_page,
            cell: (width, height),
            page: image::RgbaImage::new(0, 0),
        })
    }

    /// Puts frame `k` in its cell, writing the previous page when `k` starts a new one; a page
    /// is as large as the frames it will hold.
    fn put(&mut self, k: usize, frame: &Picture, total: usize) -> Result<()> {
        let (w, h) = self.cell;
        if k % self.per_page == 0 {
            if k > 0 {
                self.write(k / self.per_page - 1)?;
            }
            let on_page = (total - k).min(self.per_page);
            let columns = self.columns.min(on_page) as u32;
            let rows = on_page.div_ceil(self.columns) as u32;
            self.page = image::RgbaImage::new(columns * w, rows * h);
        }
        let cell = k % self.per_page;
        let (ox, oy) = ((cell % self.columns) as u32 * w, (cell / self.columns) as u32 * h);
        image::imageops::replace(&mut self.page, &frame.to_rgba8(), i64::from(ox), i64::from(oy));
        Ok(())
    }

    fn write(&self, page: usize) -> Result<()> {
        let path = &self.pages[page];
        let mut bytes = Vec::new();
        self.page
            .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|e| Error::image(path, format!("cannot encode PNG: {e}")))?;
        write_atomic(path, &bytes)
    }

    /// Writes the last page.
    fn finish(self) -> Result<Vec<PathBuf>> {
        self.write(self.pages.len() - 1)?;
        Ok(self.pages)
    }
}

impl GifStream {
    fn create(settings: &GifSettings) -> Result<Self> {
        let path = settings.path.clone();
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
        let name = path
            .file_name()
            .map_or_else(|| "animation.gif".into(), |n| n.to_string_lossy().into_owned());
        let tmp = parent.join(format!(".{name}.tmp{}", std::process::id()));
        let file = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let sink = FileSink {
            file: Arc::new(file),
            failure: Arc::new(Mutex::new(None)),
        };
        // Speed 1: NeuQuant learns the palette from every pixel. At 10 it samples a tenth and,
        // on a rendered robot, lost the small yellow eye (drawn pink); frames here are small.
        let mut encoder = GifEncoder::new_with_speed(sink.clone(), 1);
        let stream = GifStream {
            sink,
            tmp,
            path,
            delay: Delay::from_numer_denom_ms(settings.delay_ms.max(1), 1),
            background: settings.background,
            encoder: {
                encoder
                    .set_repeat(Repeat::Infinite)
                    .map_err(|e| Error::image(&settings.path, format!("cannot encode GIF: {e}")))?;
                encoder
            },
        };
        Ok(stream)
    }

    fn push(&mut self, frame: &Picture) -> Result<()> {
        let frame = Frame::from_parts(flatten(frame, self.background).to_rgba8(), 0, 0, self.delay);
        self.encoder
            .encode_frame(frame)
            .map_err(|e| Error::image(&self.path, format!("cannot encode GIF: {e}")))
    }

    fn finish(mut self) -> Result<PathBuf> {
        // Dropping the encoder writes the GIF trailer; a write that failed then is kept by the
        // sink, since a drop cannot report it.
        let encoder = std::mem::replace(&mut self.encoder, GifEncoder::new(self.sink.clone()));
        drop(encoder);
        let failure = self.sink.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        if let Some(e) = failure {
            return Err(Error::io(&self.tmp, e));
        }
        self.sink.file.sync_all().map_err(|e| Error::io(&self.tmp, e))?;
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        Ok(self.path.clone())
    }
}

/// A file the GIF encoder writes to, which remembers the first write that failed.
#[derive(Clone)]
struct FileSink {
    file: Arc<std::fs::File>,
    failure: Arc<Mutex<Option<std::io::Error>>>,
}

impl std::io::Write for FileSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        (&*self.file).write(buf).inspect_err(|e| self.remember(e))
    }

    fn flush(&mut self) -> std::io::Result<()> {
        (&*self.file).flush().inspect_err(|e| self.remember(e))
    }
}

impl FileSink {
    fn remember(&self, e: &std::io::Error) {
        let mut failure = self.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if failure.is_none() {
            *failure = Some(std::io::Error::new(e.kind(), e.to_string()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::AnimationDecoder;

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
            gif: Some(GifSettings {
                path,
                delay_ms: 80,
                background: [1.0; 3],
            }),
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
            gif: None,
        };
        let paths = write(&frames, &files);
        assert_eq!(paths.len(), 6);
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
        assert_eq!(pages, [dir.path().join("sprites.png"), dir.path().join("sprites_2.png")]);
        assert_eq!(Picture::file_size(&pages[0]).unwrap(), (4000, 4000));
        assert_eq!(Picture::file_size(&pages[1]).unwrap(), (1000, 1000));
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
