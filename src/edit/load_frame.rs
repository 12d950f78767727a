//! Reading a frame for a trained model: the network was trained on cut-out characters over
//! transparency at the puppet's frame size (neural-puppet.md §3.2), so a frame of another size
//! or without any transparent pixel is refused up front, naming the file.

use std::path::Path;

use crate::error::{Error, Result};
use crate::model::Model;
use crate::picture::Picture;

/// Loads the image at `path` and checks it suits `model`: the puppet's size, and an alpha
/// channel that is not everywhere opaque.
///
/// # Errors
/// [`Error::Io`]/[`Error::Image`] if it cannot be read; [`Error::Image`] naming the file if its
/// size differs from the puppet's or it has no transparency.
pub fn load_frame(path: &Path, model: &Model) -> Result<Picture> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let image = image::load_from_memory(&bytes).map_err(|e| Error::Image {
        path: path.to_path_buf(),
        problem: format!("cannot decode image: {e}"),
    })?;
    let picture = Picture::from_image(&image);
    model.check_frame(&picture).map_err(|e| Error::Image {
        path: path.to_path_buf(),
        problem: e.to_string(),
    })?;
    if !image.color().has_alpha() {
        return Err(Error::Image {
            path: path.to_path_buf(),
            problem: "has no alpha channel (frames are cut-out characters on transparency, RGBA PNG)".into(),
        });
    }
    if picture.pixels.iter().all(|p| p[3] >= 1.0) {
        return Err(Error::Image {
            path: path.to_path_buf(),
            problem: "is opaque everywhere (frames are cut-out characters on transparency)".into(),
        });
    }
    Ok(picture)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::deformation::DeformationNetConfig;
    use crate::test_util::layered_puppet;

    #[test]
    fn wrong_size_and_missing_alpha_name_the_file() {
        let device = crate::backend::device();
        let puppet = layered_puppet();
        let config = DeformationNetConfig::new(puppet.vertex_count()).with_input_size(16);
        let model = Model::new(config, puppet, &device).unwrap();
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
        assert!(err.contains("rgb.png") && err.contains("no alpha"), "{err}");
        let opaque = dir.path().join("opaque.png");
        image::RgbaImage::from_pixel(48, 40, image::Rgba([9, 9, 9, 255]))
            .save(&opaque)
            .unwrap();
        assert!(load_frame(&opaque, &model).unwrap_err().to_string().contains("opaque everywhere"));
    }
}
