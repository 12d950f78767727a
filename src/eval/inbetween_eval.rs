//! In-between quality (issue 6, after neural-puppet.md §4.1): on a sequence whose every other
//! frame was held out of training, generate each held-out frame k from its neighbours k − 1 and
//! k + 1 at t = ½ and measure the L2 (DESIGN.md: RGB on white, [0, 255], frame pixels) to the
//! true frame k for
//!
//! - **latent**: decode ½(z_{k−1} + z_{k+1}) and render (ours, §4.1);
//! - **vertex**: render ½(v_{k−1} + v_{k+1}) of the two fitted meshes;
//! - **nearest**: the training frame nearest (Euclidean image distance) to the latent render —
//!   Figure 5's last row, used as an in-between;
//! - **hold**: frame k − 1 itself (no in-betweening at all);
//! - **fit**: the model's own reconstruction of frame k (how well it could do given the frame).

use burn::tensor::Device;

use crate::edit::inbetween::{nearest_frame, Interpolator};
use crate::error::{Error, Result};
use crate::fit::{fit, FitOptions};
use crate::metrics::l2;
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Silent;
use crate::render::render_crisp;

/// Per held-out frame L2 of each method (module doc), frame index first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InbetweenScore {
    /// Index of the held-out frame k.
    pub frame: usize,
    /// Latent interpolation.
    pub latent: f64,
    /// Vertex-space interpolation.
    pub vertex: f64,
    /// Nearest training frame to the latent render.
    pub nearest: f64,
    /// Frame k − 1 repeated.
    pub hold: f64,
    /// The model's fit of frame k.
    pub fit: f64,
}

/// Scores every frame `k` in `held_out` that has both neighbours in `training` (indices into
/// `frames`).
///
/// # Errors
/// [`Error::Setting`] if no held-out frame has both neighbours among the training frames,
/// [`Error::Mismatch`] if a frame is not the puppet's size.
pub fn inbetween_scores(
    model: &Model,
    frames: &[Picture],
    training: &[usize],
    held_out: &[usize],
    options: &FitOptions,
    device: &Device,
) -> Result<Vec<InbetweenScore>> {
    let train_pics: Vec<Picture> = training.iter().filter_map(|&i| frames.get(i).cloned()).collect();
    let (w, h) = (model.puppet.width, model.puppet.height);
    let mut out = Vec::new();
    for &k in held_out {
        if k == 0 || k + 1 >= frames.len() || !training.contains(&(k - 1)) || !training.contains(&(k + 1)) {
            continue;
        }
        let interp = Interpolator::new(model, &frames[k - 1], &frames[k + 1], options, device)?;
        let latent_pose = interp.latent_poses(model, &[0.5], device).pop().unwrap_or_default();
        let latent = render_crisp(&model.puppet, &latent_pose, w, h)?;
        let vertex = render_crisp(&model.puppet, &interp.vertex_pose(0.5), w, h)?;
        let fit_pose = fit(model, &[&frames[k]], options, device, &Silent)?.pop().unwrap_or_default();
        let fit = render_crisp(&model.puppet, &fit_pose, w, h)?;
        let nearest = nearest_frame(&latent, &train_pics).map_or(f64::NAN, |(i, _)| l2(&train_pics[i], &frames[k]));
        out.push(InbetweenScore {
            frame: k,
            latent: l2(&latent, &frames[k]),
            vertex: l2(&vertex, &frames[k]),
            nearest,
            hold: l2(&frames[k - 1], &frames[k]),
            fit: l2(&fit, &frames[k]),
        });
    }
    if out.is_empty() {
        return Err(Error::setting(
            "in-between scores: held-out frames",
            held_out.len(),
            "some with both neighbours among the training frames",
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::deformation::DeformationNetConfig;
    use crate::test_util::layered_puppet;

    #[test]
    fn scores_cover_frames_with_both_neighbours_and_the_untrained_model_is_the_rest_pose() {
        let device = crate::backend::device();
        let puppet = layered_puppet();
        let config = DeformationNetConfig::new(puppet.vertex_count())
            .with_input_size(48)
            .with_encoder_hidden([16, 16])
            .with_latent(8)
            .with_decoder_hidden([16, 16]);
        let model = Model::new(config, puppet, &device).unwrap();
        let rest = render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut shifted = model.puppet.rest_vertices();
        shifted.iter_mut().for_each(|p| p[0] += 3.0);
        let moved = render_crisp(&model.puppet, &shifted, 48, 40).unwrap();
        let frames = vec![rest.clone(), moved.clone(), rest.clone(), moved, rest.clone()];
        // Latent refinement only: vertex steps would fit the shifted frames whatever the model.
        let options = FitOptions {
            vertex_steps: 0,
            ..FitOptions::default()
        };
        let scores = inbetween_scores(&model, &frames, &[0, 2, 4], &[1, 3], &options, &device).unwrap();
        assert_eq!(scores.iter().map(|s| s.frame).collect::<Vec<_>>(), vec![1, 3]);
        for s in &scores {
            // An untrained model predicts the rest pose: every method renders the rest frame.
            // (up to f32 rounding of the vertices' trip through the letterbox)
            let same = |x: f64| (x - s.hold).abs() < 1e-3;
            assert!(same(s.latent) && same(s.vertex) && same(s.fit) && same(s.nearest), "{s:?}");
            assert!(s.hold > 1000.0, "the shifted frame differs from the rest frame: {s:?}");
        }
        assert!(inbetween_scores(&model, &frames, &[0, 1], &[3], &options, &device).is_err());
    }
}
