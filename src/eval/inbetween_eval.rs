//! In-between quality (issue 6, after neural-puppet.md §4.1; gaps and baselines from issue 19):
//! on a sequence whose odd frames were held out of training, take two training frames `gap + 1`
//! apart as keyframes, generate every held-out frame between them at its place in time
//! (t = (j − k)/(gap + 1)) and measure the L2 (DESIGN.md: RGB on white, [0, 255], frame pixels)
//! to the true frame for
//!
//! - **latent**: the plain latent path of §4.1, between the keyframes' latents;
//! - **keyed**: the latent path carried onto the keyframes' fits ([`Interpolator::keyed_poses`]);
//! - **along_latent**: the same along the manifold, through the training frames' latents where
//!   they lie between the keyframes ([`Interpolator::through`], [`InbetweenPath::Latent`](crate::edit::inbetween::InbetweenPath::Latent));
//! - **along_rigid**: the default — as-rigid-as-possible interpolation between the corners of
//!   that path ([`Interpolator::manifold_rigid_poses`], [`InbetweenPath::Rigid`](crate::edit::inbetween::InbetweenPath::Rigid));
//! - **vertex**: linear interpolation of the two fitted meshes;
//! - **rigid**: their as-rigid-as-possible shape interpolation (Alexa et al. 2000);
//! - **nearest**: the training frame nearest (Euclidean image distance) to the keyed render —
//!   Figure 5's last row, used as an in-between;
//! - **hold**: the first keyframe itself (no in-betweening at all);
//! - **fit**: the model's own fit of the true frame (how well it could do given the frame).
//!
//! Keyframes and held-out frames are fitted once each, with the options given.

use std::collections::BTreeSet;
use std::path::Path;

use burn::tensor::Device;

use crate::edit::inbetween::{nearest_frame, Interpolator};
use crate::edit::manifold_path::Waypoints;
use crate::error::{Error, Result};
use crate::fit::frame::{frame_check, training_frames};
use crate::fit::{fit, fit_with_latents, FitOptions};
use crate::metrics::l2;
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::{Progress, Silent};
use crate::puppet::sequence::Frames;
use crate::render::render_crisp;

/// One generated frame's L2 by each method (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InbetweenScore {
    /// Index of the held-out frame generated.
    pub frame: usize,
    /// Frames between the two keyframes.
    pub gap: usize,
    /// Its place between them, (0, 1).
    pub t: f32,
    /// The plain latent path.
    pub latent: f64,
    /// The latent path through the keyframes' fits, straight.
    pub keyed: f64,
    /// That path along the manifold through the training frames.
    pub along_latent: f64,
    /// As-rigid-as-possible interpolation between the corners of that path (the default).
    pub along_rigid: f64,
    /// Vertex-space interpolation.
    pub vertex: f64,
    /// As-rigid-as-possible interpolation.
    pub rigid: f64,
    /// Nearest training frame to the keyed render.
    pub nearest: f64,
    /// The first keyframe repeated.
    pub hold: f64,
    /// The model's fit of the frame.
    pub fit: f64,
}

/// Scores, for each of `gaps`, every frame of `held_out` (indices into `frames`) that lies
/// between two frames of `training` that far apart; the manifold path runs through `waypoints`
/// (the frames the model was trained on).
///
/// # Errors
/// [`Error::Setting`] if no held-out frame lies between two training frames at any gap;
/// [`Error::Mismatch`] if a frame is not the puppet's size.
#[allow(clippy::too_many_arguments)] // each is one of the experiment's independent inputs
pub fn inbetween_scores(
    model: &Model,
    frames: &[Picture],
    training: &[usize],
    held_out: &[usize],
    gaps: &[usize],
    waypoints: &Waypoints,
    options: &FitOptions,
    device: &Device,
) -> Result<Vec<InbetweenScore>> {
    let is_training: BTreeSet<usize> = training.iter().copied().filter(|&i| i < frames.len()).collect();
    let is_held_out: BTreeSet<usize> = held_out.iter().copied().filter(|&i| i < frames.len()).collect();
    // (gap, first keyframe, second keyframe, the held-out frames between them).
    let mut spans = Vec::new();
    for &gap in gaps {
        for &k in &is_training {
            let Some(end) = k.checked_add(gap).and_then(|e| e.checked_add(1)) else {
                continue;
            };
            let inside: Vec<usize> = (k + 1..end).filter(|j| is_held_out.contains(j)).collect();
            if gap > 0 && is_training.contains(&end) && !inside.is_empty() {
                spans.push((gap, k, end, inside));
            }
        }
    }
    if spans.is_empty() {
        return Err(Error::setting(
            "in-between scores: held-out frames",
            held_out.len(),
            format!("some between two training frames {gaps:?} frames apart"),
        ));
    }
    let keys: Vec<usize> = spans.iter().flat_map(|s| [s.1, s.2]).collect::<BTreeSet<_>>().into_iter().collect();
    let targets: Vec<usize> = spans
        .iter()
        .flat_map(|s| s.3.iter().copied())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let (key_latents, key_poses) = fit_with_latents(model, &pictures(frames, &keys), options, device, &Silent)?;
    let target_fits = fit(model, &pictures(frames, &targets), options, device, &Silent)?;
    let train_pics: Vec<Picture> = is_training.iter().map(|&i| frames[i].clone()).collect();
    let (w, h) = (model.puppet.width, model.puppet.height);
    let render = |pose: &[[f32; 2]]| render_crisp(&model.puppet, pose, w, h);
    let key_at = |i: usize| keys.binary_search(&i).unwrap_or_default();
    let mut out = Vec::new();
    for (gap, a, b, inside) in spans {
        let (ka, kb) = (key_at(a), key_at(b));
        let interp = Interpolator::between(
            model,
            key_latents.clone().narrow(0, ka, 1),
            key_latents.clone().narrow(0, kb, 1),
            device,
        )
        .with_keys([key_poses[ka].clone(), key_poses[kb].clone()]);
        let t: Vec<f32> = inside.iter().map(|&j| (j - a) as f32 / (gap + 1) as f32).collect();
        let latent = interp.latent_poses(model, &t, device);
        let keyed = interp.keyed_poses(model, &t, device);
        let along = interp.clone().through(waypoints);
        let along_latent = along.keyed_poses(model, &t, device);
        let along_rigid = along.manifold_rigid_poses(model, &t)?;
        let rigid = interp.rigid_poses(model, &t)?;
        for (n, &j) in inside.iter().enumerate() {
            let truth = &frames[j];
            let keyed_picture = render(&keyed[n])?;
            let nearest = nearest_frame(&keyed_picture, &train_pics).map_or(f64::NAN, |(i, _)| l2(&train_pics[i], truth));
            let fitted = &target_fits[targets.binary_search(&j).unwrap_or_default()];
            out.push(InbetweenScore {
                frame: j,
                gap,
                t: t[n],
                latent: l2(&render(&latent[n])?, truth),
                keyed: l2(&keyed_picture, truth),
                along_latent: l2(&render(&along_latent[n])?, truth),
                along_rigid: l2(&render(&along_rigid[n])?, truth),
                vertex: l2(&render(&interp.vertex_pose(t[n]))?, truth),
                rigid: l2(&render(&rigid[n])?, truth),
                nearest,
                hold: l2(&frames[a], truth),
                fit: l2(&render(fitted)?, truth),
            });
        }
    }
    Ok(out)
}

/// The frames at `indices`.
fn pictures<'a>(frames: &'a [Picture], indices: &[usize]) -> Vec<&'a Picture> {
    indices.iter().map(|&i| &frames[i]).collect()
}

/// The scores of one gap: every held-out frame that lies between two keyframes that far apart.
#[derive(Clone, Debug, PartialEq)]
pub struct GapScores {
    /// The gap (frames between the keyframes).
    pub gap: usize,
    /// One score per held-out frame scored at it (none if no held-out frame lies in a span of
    /// this gap).
    pub scores: Vec<InbetweenScore>,
}

impl GapScores {
    /// The mean over this gap's frames of one method's L2 (`method` picks it); NaN for none.
    pub fn mean(&self, method: fn(&InbetweenScore) -> f64) -> f64 {
        self.scores.iter().map(method).sum::<f64>() / self.scores.len() as f64
    }
}

/// The in-between protocol on a whole sequence: its even frames are the keyframes, its odd
/// frames the in-betweens to make, at each of `gaps`; the manifold path runs through the frames
/// of `model_dir`'s training set (the straight line, with a warning through `progress`, when
/// they cannot be read). The scores mean something only if the model did not train on the odd
/// frames (a sequence held out of training, e.g. a synthetic one).
///
/// # Errors
/// As [`Frames::load`] for `sequence`, [`training_frames`] and [`inbetween_scores`].
pub fn score_sequence(
    model_dir: &Path,
    model: &Model,
    sequence: &Path,
    gaps: &[usize],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Vec<GapScores>> {
    let frames = Frames::load(sequence, &frame_check(model))?;
    let trained = training_frames(model_dir, model, "the path along them is the straight line", progress)?.unwrap_or_default();
    let waypoints = Waypoints::of_frames(model, &trained.iter().collect::<Vec<_>>(), device)?;
    let n = frames.frames.len();
    let even: Vec<usize> = (0..n).step_by(2).collect();
    let odd: Vec<usize> = (1..n).step_by(2).collect();
    let scores = inbetween_scores(model, &frames.frames, &even, &odd, gaps, &waypoints, options, device)?;
    Ok(gaps
        .iter()
        .map(|&gap| GapScores {
            gap,
            scores: scores.iter().filter(|s| s.gap == gap).copied().collect(),
        })
        .collect())
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
        let waypoints = Waypoints::of_frames(&model, &[&frames[0], &frames[2]], &device).unwrap();
        let scores = inbetween_scores(&model, &frames, &[0, 2, 4], &[1, 3], &[1, 3], &waypoints, &options, &device).unwrap();
        let placed: Vec<(usize, usize, f32)> = scores.iter().map(|s| (s.gap, s.frame, s.t)).collect();
        assert_eq!(placed, vec![(1, 1, 0.5), (1, 3, 0.5), (3, 1, 0.25), (3, 3, 0.75)]);
        for s in &scores {
            // An untrained model predicts the rest pose: every method renders the rest frame.
            // (up to f32 rounding of the vertices' trip through the letterbox)
            let same = |x: f64| (x - s.hold).abs() < 1e-3;
            assert!(
                same(s.latent)
                    && same(s.keyed)
                    && same(s.along_latent)
                    && same(s.along_rigid)
                    && same(s.vertex)
                    && same(s.rigid)
                    && same(s.fit)
                    && same(s.nearest),
                "{s:?}"
            );
            assert!(s.hold > 1000.0, "the shifted frame differs from the rest frame: {s:?}");
        }
        assert!(inbetween_scores(&model, &frames, &[0, 1], &[3], &[1], &waypoints, &options, &device).is_err());
        assert!(inbetween_scores(&model, &frames, &[0, 2, 4], &[1, 3], &[5], &waypoints, &options, &device).is_err());
    }
}
