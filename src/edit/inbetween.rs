//! In-betweening (neural-puppet.md §4.1): encode two frames, `z_i = E(x_i)`, interpolate the
//! latents linearly with uniform steps and decode each, `v(t) = D((1 − t)·z_1 + t·z_2)`. Beside
//! it, the comparison the paper's argument rests on: linear interpolation of the two fitted
//! meshes in vertex space, which leaves the learned manifold.
//!
//! Step convention: `steps = N` in-betweens at `t_k = k / (N + 1)`, `k = 1..=N`, framed by the
//! fitted end frames (`k = 0` and `k = N + 1`), so `N + 2` poses in all.

use burn::tensor::{Device, Tensor, TensorData};

use std::path::PathBuf;

use crate::atomic_file::Outputs;
use crate::error::{Error, Result};
use crate::fit::{fit_latents, FitOptions};
use crate::model::Model;
use crate::picture::contact_sheet;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::pose_file::PoseFile;
use crate::render::animation::{AnimationFiles, AnimationWriter};
use crate::render::render_crisp;

/// Latent and vertex-space interpolation between two frames.
#[derive(Clone, Debug)]
pub struct Inbetweens {
    /// Interpolation parameters `t_k`, `N + 2` of them from 0 to 1.
    pub t: Vec<f32>,
    /// The decoded latent interpolation per `t_k`, frame pixels, global vertex numbering.
    pub latent: Vec<Vec<[f32; 2]>>,
    /// The vertex-space interpolation `(1 − t)·v_1 + t·v_2` of the fitted end poses.
    pub vertex: Vec<Vec<[f32; 2]>>,
}

/// The two encoded end frames, ready to produce any in-between quickly (one decode each) —
/// what an interactive timeline would hold.
#[derive(Clone, Debug)]
pub struct Interpolator {
    z_a: Tensor<2>,
    z_b: Tensor<2>,
    fitted: [Vec<[f32; 2]>; 2],
}

impl Interpolator {
    /// Encodes frames `a` and `b` with `model` (latents fitted as `fit` says).
    ///
    /// # Errors
    /// [`Error::Mismatch`] if a frame is not the puppet's size (see [`Model::check_frame`]).
    pub fn new(model: &Model, a: &Picture, b: &Picture, fit: &FitOptions, device: &Device) -> Result<Self> {
        let z = fit_latents(model, &[a, b], fit, device)?;
        Ok(Self::between(model, z.clone().narrow(0, 0, 1), z.narrow(0, 1, 1), device))
    }

    /// The interpolation between two latents `[1, Z]` fitted earlier (by `model`, or by the same
    /// body in another outfit), decoded by `model`.
    pub fn between(model: &Model, z_a: Tensor<2>, z_b: Tensor<2>, device: &Device) -> Self {
        let fitted = model.to_frame_vertices(model.decode(Tensor::cat(vec![z_a.clone(), z_b.clone()], 0), device));
        let mut it = fitted.into_iter();
        let (va, vb) = (it.next().unwrap_or_default(), it.next().unwrap_or_default());
        Interpolator {
            z_a,
            z_b,
            fitted: [va, vb],
        }
    }

    /// The fitted poses of a and b (frame pixels).
    pub fn fitted(&self) -> [&[[f32; 2]]; 2] {
        [&self.fitted[0], &self.fitted[1]]
    }

    /// Decodes the latent interpolations at each `t` in one batch (frame pixels).
    pub fn latent_poses(&self, model: &Model, t: &[f32], device: &Device) -> Vec<Vec<[f32; 2]>> {
        if t.is_empty() {
            return Vec::new();
        }
        let n = t.len();
        let w = Tensor::<2>::from_data(TensorData::new(t.to_vec(), [n, 1]), device);
        let z = self.z_a.clone().repeat_dim(0, n) * (w.clone().neg() + 1.0) + self.z_b.clone().repeat_dim(0, n) * w;
        model.to_frame_vertices(model.decode(z, device))
    }

    /// The vertex-space interpolation of the fitted end poses at `t`.
    pub fn vertex_pose(&self, t: f32) -> Vec<[f32; 2]> {
        self.fitted[0]
            .iter()
            .zip(&self.fitted[1])
            .map(|(a, b)| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
            .collect()
    }
}

/// The `N + 2` interpolation parameters of `steps = N` in-betweens (module doc).
///
/// # Errors
/// [`Error::Setting`] if `steps` is 0 (nothing to generate); [`Error::Limit`] if it is above
/// `max_steps`.
pub fn steps_t(steps: usize, max_steps: usize) -> Result<Vec<f32>> {
    if steps == 0 {
        return Err(Error::setting("in-between steps", 0, "at least 1"));
    }
    if steps > max_steps {
        return Err(Error::limit("the in-between count", steps as u64, max_steps as u64, "frames"));
    }
    Ok((0..=steps + 1).map(|k| k as f32 / (steps + 1) as f32).collect())
}

/// The default most in-betweens one call makes ([`steps_t`]): 1000 frames are 40 s at 25 fps.
pub const MAX_STEPS: usize = 1000;

/// In-betweens of frames `a` and `b`: latent and vertex-space interpolations at each of `t`
/// (e.g. [`steps_t`]).
///
/// # Errors
/// As [`Interpolator::new`].
pub fn inbetween(model: &Model, a: &Picture, b: &Picture, t: &[f32], fit: &FitOptions, device: &Device) -> Result<Inbetweens> {
    let interp = Interpolator::new(model, a, b, fit, device)?;
    let latent = interp.latent_poses(model, t, device);
    let vertex = t.iter().map(|&t| interp.vertex_pose(t)).collect();
    Ok(Inbetweens {
        t: t.to_vec(),
        latent,
        vertex,
    })
}

/// The most in-between steps [`comparison_sheet`] shows side by side.
pub const SHEET_COLUMNS: usize = 12;

/// Figure 5 of neural-puppet.md as one picture: at most [`SHEET_COLUMNS`] of the in-betweens'
/// steps (evenly sampled, ends included), in rows — the latent interpolation, the vertex-space
/// interpolation, and, if `training` is not empty, the training frame nearest each latent step.
///
/// # Errors
/// Render errors (in-betweens of another puppet).
pub fn comparison_sheet(model: &Model, inbetweens: &Inbetweens, training: &[Picture]) -> Result<Picture> {
    let n = inbetweens.t.len();
    let columns = n.clamp(1, SHEET_COLUMNS);
    let picked: Vec<usize> = (0..columns)
        .map(|c| if columns == 1 { 0 } else { c * (n - 1) / (columns - 1) })
        .collect();
    let (w, h) = (model.puppet.width, model.puppet.height);
    let render = |poses: &[Vec<[f32; 2]>]| -> Result<Vec<Picture>> {
        picked.iter().map(|&k| render_crisp(&model.puppet, &poses[k], w, h)).collect()
    };
    let latent = render(&inbetweens.latent)?;
    let vertex = render(&inbetweens.vertex)?;
    let nearest: Vec<Picture> = latent
        .iter()
        .filter_map(|p| nearest_frame(p, training).map(|(k, _)| training[k].clone()))
        .collect();
    let cells: Vec<&Picture> = latent.iter().chain(&vertex).chain(&nearest).collect();
    Ok(contact_sheet(&cells, columns))
}

/// Where in-betweens are written; each animation is optional.
#[derive(Clone, Debug, Default)]
pub struct InbetweenFiles {
    /// The latent interpolation (ours), played there and back in its GIF.
    pub latent: AnimationFiles,
    /// The vertex-space interpolation.
    pub vertex: AnimationFiles,
    /// The training frame nearest each latent step (written only if there are training frames).
    pub nearest: AnimationFiles,
    /// Each latent step's pose as `step_NNN.json` in this folder.
    pub poses: Option<PathBuf>,
}

/// Renders and writes the in-betweens one frame at a time (memory does not grow with their
/// number); `training` frames, if any, give the nearest-frame animation. Returns the files
/// written.
///
/// # Errors
/// [`Error::WouldOverwrite`] before anything is written if an output is in the way; render and
/// write errors naming what failed.
pub fn write_inbetweens(
    model: &Model,
    inbetweens: &Inbetweens,
    training: &[Picture],
    files: &InbetweenFiles,
    outputs: &Outputs,
    progress: &dyn Progress,
) -> Result<Vec<PathBuf>> {
    let n = inbetweens.t.len();
    let (w, h) = (model.puppet.width, model.puppet.height);
    let digits = n.saturating_sub(1).to_string().len().max(3);
    let pose_paths: Vec<PathBuf> = match &files.poses {
        Some(dir) => (0..n).map(|k| dir.join(format!("step_{k:0digits$}.json"))).collect(),
        None => Vec::new(),
    };
    for path in &pose_paths {
        outputs.claim(path)?;
    }
    let mut latent = AnimationWriter::new(&files.latent, n, w, h, outputs)?;
    let mut vertex = AnimationWriter::new(&files.vertex, n, w, h, outputs)?;
    let mut nearest = (!training.is_empty())
        .then(|| AnimationWriter::new(&files.nearest, n, w, h, outputs))
        .transpose()?;
    progress.stage("render", n as u64);
    for k in 0..n {
        let picture = render_crisp(&model.puppet, &inbetweens.latent[k], w, h)?;
        if let (Some(writer), Some((i, _))) = (&mut nearest, nearest_frame(&picture, training)) {
            writer.push(&training[i])?;
        }
        latent.push(&picture)?;
        vertex.push(&render_crisp(&model.puppet, &inbetweens.vertex[k], w, h)?)?;
        if let Some(path) = pose_paths.get(k) {
            let pose = PoseFile {
                vertices: inbetweens.latent[k].clone(),
            };
            outputs.write(path, &pose.to_json())?;
        }
        progress.advance(1);
    }
    for k in latent.return_frames() {
        latent.push_return(&render_crisp(&model.puppet, &inbetweens.latent[k], w, h)?)?;
    }
    let mut written = pose_paths;
    written.extend(latent.finish()?);
    written.extend(vertex.finish()?);
    if let Some(writer) = nearest {
        written.extend(writer.finish()?);
    }
    Ok(written)
}

/// The index of the picture in `candidates` nearest to `picture` in Euclidean image distance
/// (the DESIGN.md L2, composited on white) and that distance (§4.1, Figure 5's last row);
/// `None` if there is no candidate of the same size.
pub fn nearest_frame(picture: &Picture, candidates: &[Picture]) -> Option<(usize, f64)> {
    candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| (c.width, c.height) == (picture.width, picture.height))
        .map(|(k, c)| (k, crate::metrics::l2(picture, c)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::deformation::DeformationNetConfig;
    use crate::test_util::layered_puppet;

    fn small_model() -> (Model, Device) {
        let device = crate::backend::device();
        let puppet = layered_puppet();
        let config = DeformationNetConfig::new(puppet.vertex_count())
            .with_input_size(16)
            .with_encoder_hidden([32, 16])
            .with_latent(8)
            .with_decoder_hidden([16, 16]);
        let mut model = Model::new(config, puppet, &device).unwrap();
        // Give the last decoder layer weights so that poses depend on z (an untrained model
        // predicts the rest pose whatever z is).
        model.net = crate::edit::test_support::randomise_last_layer(model.net, 0.3);
        (model, device)
    }

    #[test]
    fn latent_end_points_are_the_fits_and_vertex_interpolation_is_linear() {
        let (model, device) = small_model();
        let a = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut b = a.clone();
        b.pixels.rotate_left(37); // a different image, so a different latent
        let out = inbetween(&model, &a, &b, &steps_t(3, MAX_STEPS).unwrap(), &FitOptions::one_pass(), &device).unwrap();
        assert_eq!(out.t, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let fits = model.fit(&[&a, &b], &device).unwrap();
        let close = |x: &[[f32; 2]], y: &[[f32; 2]]| {
            x.iter()
                .zip(y)
                .all(|(p, q)| (p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3)
        };
        assert!(close(&out.latent[0], &fits[0]) && close(&out.latent[4], &fits[1]));
        assert!(close(&out.vertex[0], &fits[0]) && close(&out.vertex[4], &fits[1]));
        assert!(!close(&fits[0], &fits[1]), "the two frames should fit differently");
        for (k, &t) in out.t.iter().enumerate() {
            let want: Vec<[f32; 2]> = fits[0]
                .iter()
                .zip(&fits[1])
                .map(|(p, q)| [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])])
                .collect();
            assert!(close(&out.vertex[k], &want));
        }
        // The middle pose is the decoded mean latent.
        let z = model.encode(&[&a, &b], &device).unwrap();
        let mid = model.to_frame_vertices(model.decode(z.mean_dim(0), &device)).pop().unwrap();
        assert!(close(&out.latent[2], &mid));
    }

    #[test]
    fn zero_or_too_many_steps_and_wrong_sizes_are_refused() {
        let (model, device) = small_model();
        let a = Picture::filled(48, 40, [1.0, 0.0, 0.0, 1.0]);
        assert!(matches!(steps_t(0, MAX_STEPS), Err(Error::Setting { .. })));
        assert!(matches!(steps_t(11, 10), Err(Error::Limit { amount: 11, limit: 10, .. })));
        let small = Picture::filled(20, 20, [1.0; 4]);
        let err = inbetween(&model, &a, &small, &[0.0, 1.0], &FitOptions::one_pass(), &device)
            .unwrap_err()
            .to_string();
        assert!(err.contains("20×20") && err.contains("48×40"), "{err}");
    }

    #[test]
    fn nearest_frame_picks_the_closest_picture() {
        let red = Picture::filled(4, 4, [1.0, 0.0, 0.0, 1.0]);
        let pink = Picture::filled(4, 4, [1.0, 0.3, 0.3, 1.0]);
        let blue = Picture::filled(4, 4, [0.0, 0.0, 1.0, 1.0]);
        let (k, d) = nearest_frame(&red, &[blue.clone(), pink, blue]).unwrap();
        assert_eq!(k, 1);
        assert!((d - (2.0 * 16.0 * (0.3f64 * 255.0).powi(2)).sqrt()).abs() < 0.5, "{d}");
        assert!(nearest_frame(&red, &[Picture::filled(2, 2, [1.0; 4])]).is_none());
    }
}
