//! Downloads from the web editor: a pose or an in-between as PNG, GIF, APNG, sprite sheet (with
//! its atlas) or Spine skeleton, made by the same writers as the command line's outputs in a
//! folder of the server's own under the system's temporary directory, read back, and removed.
//! One file is sent as it is; several (a sheet and its atlas, a skeleton) as one ZIP. Poses are
//! drawn as crisp renders, or as the appearance stage redraws them.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use burn::tensor::Device;

use super::error::ApiError;
use crate::appearance::AppearanceStage;
use crate::atomic_file::Outputs;
use crate::error::{Error, Result};
use crate::export::spine::{self, PoseAnimation};
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Silent;
use crate::render::animation::{write_poses, AnimationFiles, AnimationWriter};
use crate::render::{render_pose, Background};
use crate::rig::outfit::undress;

/// What a download holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// One PNG per pose (one pose: one file).
    Png,
    /// An animated GIF.
    Gif,
    /// An animated PNG.
    Apng,
    /// A sprite sheet and its TexturePacker-hash atlas.
    Sheet,
    /// A Spine 4.2 skeleton: JSON, atlas and page.
    Spine,
}

impl std::str::FromStr for Format {
    type Err = ApiError;

    fn from_str(s: &str) -> std::result::Result<Self, ApiError> {
        Ok(match s {
            "png" => Format::Png,
            "gif" => Format::Gif,
            "apng" => Format::Apng,
            "sheet" => Format::Sheet,
            "spine" => Format::Spine,
            _ => {
                return Err(ApiError::bad_request(format!(
                    "{s:?} is not a download format (give png, gif, apng, sheet or spine)"
                )))
            }
        })
    }
}

/// A file to download: its name, media type and bytes.
#[derive(Clone, Debug)]
pub struct Download {
    /// The file name offered.
    pub name: String,
    /// Its media type.
    pub media_type: &'static str,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// How the poses are drawn and played.
#[derive(Clone, Debug)]
pub struct ExportStyle<'a> {
    /// Accessory layers left out (and whatever follows them in the rig).
    pub hidden: Vec<String>,
    /// What uncovered pixels show.
    pub background: Background,
    /// Frame time, milliseconds.
    pub delay_ms: u32,
    /// Soft-rasterizer σ in frame px² for a PNG of one pose (0: crisp, as every other format).
    pub sigma: f32,
    /// The appearance stage redrawing each crisp render, and its device (`None`: the renders).
    pub appearance: Option<(&'a AppearanceStage, &'a Device)>,
}

/// A folder of this server's own, removed when dropped (whatever was written in it).
struct ScratchDir(PathBuf);

impl ScratchDir {
    fn new() -> Result<Self> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        for _ in 0..100 {
            let dir = base.join(format!(
                "puppet-serve-{}-{}",
                std::process::id(),
                NEXT.fetch_add(1, Ordering::Relaxed)
            ));
            // create_dir fails if it exists: never a folder someone else made.
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(ScratchDir(dir)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(&dir, e)),
            }
        }
        Err(Error::io(&base, std::io::Error::other("no free name for a scratch folder")))
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        // Best effort: a leftover scratch folder is litter, not lost work.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Poses, frame pixels, global numbering.
type Poses = Vec<Vec<[f32; 2]>>;

/// The model drawing `model`'s poses without the accessories `hidden` (`None`: none hidden),
/// and `poses` in its numbering.
fn without(model: &Model, hidden: &[String], poses: Poses) -> Result<(Option<Model>, Poses)> {
    if hidden.is_empty() {
        return Ok((None, poses));
    }
    let drawn = model.wearing(undress(&model.puppet, hidden, &Silent)?)?;
    let poses = poses.iter().map(|p| drawn.pose_from(model, p)).collect();
    Ok((Some(drawn), poses))
}

/// `poses` of `model`'s puppet as `format`, named `stem`.
///
/// # Errors
/// As [`undress`] and [`Model::wearing`] for hidden layers; [`Error::Setting`] for a Spine
/// skeleton or a soft render asked of the appearance stage (it draws pictures, not meshes, from
/// crisp renders); the writers' errors.
pub fn export(model: &Model, poses: Vec<Vec<[f32; 2]>>, format: Format, style: &ExportStyle, stem: &str) -> Result<Download> {
    let (undressed, poses) = without(model, &style.hidden, poses)?;
    let puppet = &undressed.as_ref().unwrap_or(model).puppet;
    if style.appearance.is_some() && (format == Format::Spine || style.sigma > 0.0) {
        return Err(Error::setting(
            "appearance",
            if format == Format::Spine {
                "a Spine skeleton"
            } else {
                "a soft render"
            },
            "PNG, GIF, APNG or a sprite sheet of crisp renders (the stage redraws pictures, not meshes)",
        ));
    }
    let scratch = ScratchDir::new()?;
    let dir = &scratch.0;
    let outputs = Outputs::new(false);
    let written = if format == Format::Png && poses.len() == 1 && style.sigma > 0.0 {
        let path = dir.join(format!("{stem}.png"));
        let picture = render_pose(puppet, &poses[0], puppet.width, puppet.height, style.sigma, style.background)?;
        outputs.claim(&path)?;
        outputs.write(&path, &picture.png_bytes(&path)?)?;
        vec![path]
    } else if format == Format::Spine {
        let animation = PoseAnimation {
            name: stem.to_string(),
            poses,
        };
        let skeleton = spine::skeleton(puppet, &[animation], &[], stem, f64::from(style.delay_ms) / 1000.0)?;
        spine::write(&skeleton, dir, stem, &outputs)?
    } else {
        let mut files = AnimationFiles {
            delay_ms: style.delay_ms,
            background: style.background,
            ..AnimationFiles::default()
        };
        match format {
            Format::Png => files.frames = Some((dir.clone(), stem.to_string())),
            Format::Gif => files.gif = Some(dir.join(format!("{stem}.gif"))),
            Format::Apng => files.apng = Some(dir.join(format!("{stem}.png"))),
            Format::Sheet => files.sprites = Some((dir.join(format!("{stem}.png")), sheet_columns(poses.len()))),
            Format::Spine => unreachable!("handled above"),
        }
        let mut writer = AnimationWriter::new(&files, poses.len(), puppet.width, puppet.height, &outputs)?;
        match style.appearance {
            Some((stage, device)) => {
                for (_, generated) in stage.render_and_redraw(puppet, &poses, device)? {
                    writer.push(&generated)?;
                }
            }
            None => write_poses(puppet, &poses, &mut writer, |_, p| p, &Silent)?,
        }
        writer.finish()?
    };
    bundle(&written, stem)
}

/// `poses` of `model`'s puppet without the accessories `hidden`, rendered crisply and redrawn
/// by `stage`, side by side in one picture (pose k at x = k × the frame width).
///
/// # Errors
/// As [`undress`] and [`Model::wearing`] for hidden layers; as
/// [`AppearanceStage::render_and_redraw`].
pub fn redrawn_strip(
    model: &Model,
    poses: &[Vec<[f32; 2]>],
    hidden: &[String],
    stage: &AppearanceStage,
    device: &Device,
) -> Result<Picture> {
    let (undressed, poses) = without(model, hidden, poses.to_vec())?;
    let drawn = undressed.as_ref().unwrap_or(model);
    let (w, h) = (drawn.puppet.width as usize, drawn.puppet.height as usize);
    let mut strip = Picture::filled((w * poses.len()) as u32, h as u32, [0.0; 4]);
    for (k, (_, generated)) in stage.render_and_redraw(&drawn.puppet, &poses, device)?.into_iter().enumerate() {
        for (y, row) in generated.pixels.chunks_exact(w).enumerate() {
            let at = y * w * poses.len() + k * w;
            strip.pixels[at..at + w].copy_from_slice(row);
        }
    }
    Ok(strip)
}

/// Columns of a sheet of `n` frames: about square.
fn sheet_columns(n: usize) -> usize {
    ((n as f64).sqrt().ceil() as usize).max(1)
}

/// One file as it is, several as a ZIP named `<stem>.zip`.
fn bundle(paths: &[PathBuf], stem: &str) -> Result<Download> {
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let read = |p: &Path| std::fs::read(p).map_err(|e| Error::io(p, e));
    if let [only] = paths {
        let n = name(only);
        let media_type = if n.ends_with(".gif") { "image/gif" } else { "image/png" };
        return Ok(Download {
            name: n,
            media_type,
            bytes: read(only)?,
        });
    }
    let zip_name = format!("{stem}.zip");
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let zip_error = |e: &dyn std::fmt::Display| Error::format(Path::new(&zip_name), format!("cannot write the ZIP: {e}"));
    for p in paths {
        zip.start_file(name(p), options).map_err(|e| zip_error(&e))?;
        zip.write_all(&read(p)?).map_err(|e| zip_error(&e))?;
    }
    let bytes = zip.finish().map_err(|e| zip_error(&e))?.into_inner();
    Ok(Download {
        name: zip_name,
        media_type: "application/zip",
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::test_support::small_model;

    fn style() -> ExportStyle<'static> {
        ExportStyle {
            hidden: Vec::new(),
            background: Background::Transparent,
            delay_ms: 80,
            sigma: 0.0,
            appearance: None,
        }
    }

    #[test]
    fn every_format_downloads() {
        let (model, _) = small_model(0.3);
        let rest = model.puppet.rest_vertices();
        let shifted: Vec<[f32; 2]> = rest.iter().map(|v| [v[0] + 3.0, v[1]]).collect();
        let one = export(&model, vec![rest.clone()], Format::Png, &style(), "pose").unwrap();
        assert_eq!((one.name.as_str(), one.media_type), ("pose_000.png", "image/png"));
        let picture = image::load_from_memory(&one.bytes).unwrap();
        assert_eq!((picture.width(), picture.height()), (model.puppet.width, model.puppet.height));
        let soft = ExportStyle { sigma: 2.0, ..style() };
        let blurred = export(&model, vec![rest.clone()], Format::Png, &soft, "pose").unwrap();
        assert_eq!(blurred.name, "pose.png");
        assert_ne!(blurred.bytes, one.bytes, "a soft render is not the crisp one");
        let two = vec![rest, shifted];
        let gif = export(&model, two.clone(), Format::Gif, &style(), "walk").unwrap();
        assert!(gif.bytes.starts_with(b"GIF89a") && gif.name == "walk.gif");
        let apng = export(&model, two.clone(), Format::Apng, &style(), "walk").unwrap();
        assert!(apng.bytes.starts_with(b"\x89PNG") && apng.bytes.windows(4).any(|w| w == b"acTL"));
        for (format, inside) in [
            (Format::Sheet, ["walk.png", "walk.json"].as_slice()),
            (Format::Spine, &["walk.json", "walk.atlas", "walk.png"]),
        ] {
            let d = export(&model, two.clone(), format, &style(), "walk").unwrap();
            assert_eq!((d.name.as_str(), d.media_type), ("walk.zip", "application/zip"));
            let zip = zip::ZipArchive::new(std::io::Cursor::new(d.bytes)).unwrap();
            let mut names: Vec<&str> = zip.file_names().collect();
            names.sort_unstable();
            let mut expected = inside.to_vec();
            expected.sort_unstable();
            assert_eq!(names, expected, "{format:?}");
        }
    }

    #[test]
    fn a_scratch_folder_is_new_and_removed_with_what_was_written_in_it() {
        let (a, b) = (ScratchDir::new().unwrap(), ScratchDir::new().unwrap());
        assert_ne!(a.0, b.0);
        std::fs::write(a.0.join("x.png"), b"x").unwrap();
        let path = a.0.clone();
        drop(a);
        assert!(!path.exists() && b.0.is_dir());
    }

    #[test]
    fn formats_are_named_and_unknown_ones_refused() {
        assert_eq!("spine".parse::<Format>(), Ok(Format::Spine));
        let e = "psd".parse::<Format>().unwrap_err();
        assert!(e.message.contains("png, gif, apng, sheet or spine"), "{e:?}");
        let (model, _) = small_model(0.3);
        let hidden = ExportStyle {
            hidden: vec!["nothing".into()],
            ..style()
        };
        assert!(export(&model, vec![model.puppet.rest_vertices()], Format::Png, &hidden, "p").is_err());
    }
}
