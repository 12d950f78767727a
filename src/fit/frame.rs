//! Reading a frame for a trained model: the network was trained on cut-out characters over
//! transparency at the puppet's frame size (neural-puppet.md §3.2), so a frame of another size
//! (checked from its header, before decoding) or without any transparent pixel is refused,
//! naming the file.

use std::path::Path;

use burn::tensor::Device;

use crate::error::{Error, Result};
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::sequence::{self, FrameCheck};
use crate::train::trainer::SplitRecord;

/// Loads the image at `path` and checks it suits `model`: the puppet's size, and some pixel
/// that is not opaque.
///
/// # Errors
/// [`Error::Io`]/[`Error::Image`] if it cannot be read; [`Error::Mismatch`] (about the file) if
/// its size differs from the puppet's; [`Error::Image`] if it has no transparency.
pub fn load_frame(path: &Path, model: &Model) -> Result<Picture> {
    let picture = sequence::load_frame(path, &frame_check(model))?;
    check_cut_out(&picture, path)?;
    Ok(picture)
}

/// The frames `model` was trained on, read again from the folder its `split.json` names (for
/// what a fit or an edit takes from them); `None`, with a warning through `progress` saying
/// what `purpose` goes without, if the model has no split record or a frame can no longer be
/// read.
///
/// # Errors
/// As [`SplitRecord::load`].
pub fn training_frames(model_dir: &Path, model: &Model, purpose: &str, progress: &dyn Progress) -> Result<Option<Vec<Picture>>> {
    let Some(split) = SplitRecord::load(model_dir)? else {
        progress.warn(&format!("{}: no split.json, so no training frames; {purpose}", model_dir.display()));
        return Ok(None);
    };
    let mut frames = Vec::with_capacity(split.train.len());
    for name in &split.train {
        match load_frame(&split.frames.join(name), model) {
            Ok(frame) => frames.push(frame),
            Err(e) => {
                progress.warn(&format!("{e}; {purpose}"));
                return Ok(None);
            }
        }
    }
    Ok(Some(frames))
}

/// The network's one-pass poses (frame pixels, global numbering) of the frames `model` was
/// trained on: what a fit learns its plausible turns and its hidden limbs' places from. `None`,
/// with a warning, as for [`training_frames`].
///
/// # Errors
/// As [`training_frames`] and [`Model::encode`].
pub fn training_poses(
    model_dir: &Path,
    model: &Model,
    device: &Device,
    purpose: &str,
    progress: &dyn Progress,
) -> Result<Option<Vec<Vec<[f32; 2]>>>> {
    let Some(frames) = training_frames(model_dir, model, purpose, progress)? else {
        return Ok(None);
    };
    let refs: Vec<_> = frames.iter().collect();
    Ok(Some(model.to_frame_vertices(model.decode(model.encode(&refs, device)?, device))))
}

/// The checks a model's frames must pass before decoding: the puppet's size, default limits.
pub fn frame_check(model: &Model) -> FrameCheck {
    FrameCheck::of_size(model.puppet.width, model.puppet.height)
}

/// Checks `picture`, read from `path`, is a cut-out character (some pixel is not opaque).
///
/// # Errors
/// [`Error::Image`] naming `path`.
pub fn check_cut_out(picture: &Picture, path: &Path) -> Result<()> {
    if picture.pixels.iter().all(|p| p[3] >= 1.0) {
        return Err(Error::image(
            path,
            "is opaque everywhere (frames are cut-out characters on transparency, RGBA PNG)",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::tiny_model;

    #[test]
    fn wrong_size_and_missing_alpha_name_the_file() {
        let (model, _) = tiny_model();
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.png");
        let frame = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        frame.save_png(&good).unwrap();
        assert_eq!(load_frame(&good, &model).unwrap().width, 48);
        let small = dir.path().join("small.png");
        image::RgbaImage::new(10, 10).save(&small).unwrap();
        let err = load_frame(&small, &model).unwrap_err().to_string();
        assert!(err.contains("small.png") && err.contains("10×10"), "{err}");
        let rgb = dir.path().join("rgb.png");
        image::RgbImage::new(48, 40).save(&rgb).unwrap();
        let err = load_frame(&rgb, &model).unwrap_err().to_string();
        assert!(err.contains("rgb.png") && err.contains("opaque everywhere"), "{err}");
        let opaque = dir.path().join("opaque.png");
        image::RgbaImage::from_pixel(48, 40, image::Rgba([9, 9, 9, 255]))
            .save(&opaque)
            .unwrap();
        assert!(load_frame(&opaque, &model).unwrap_err().to_string().contains("opaque everywhere"));
    }
}
