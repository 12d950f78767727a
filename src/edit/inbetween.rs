//! In-betweening (neural-puppet.md §4.1): encode two frames, `z_i = E(x_i)`, interpolate the
//! latents linearly and decode each, `v(t) = D((1 − t)·z_1 + t·z_2)`.
//!
//! **On the keyframes.** A fit that goes past the decoder's manifold (vertex steps: the default
//! fit) lands where no latent decodes, so the plain latent path would start and end on poses the
//! animator did not draw. The latent path therefore adds the residual of each keyframe's fit
//! over its latent's decode, interpolated linearly:
//! `v(t) = D((1 − t)·z_1 + t·z_2) + (1 − t)·(v_1 − D(z_1)) + t·(v_2 − D(z_2))`, which is the fit
//! at both ends and the learned path between them (the plain latent path when the fit stays on
//! the manifold).
//!
//! **Along the manifold.** The straight line between two latents cuts across the manifold; the
//! paths users get run through the training frames' latents that lie between the keyframes
//! ([`ManifoldPath`], [`Interpolator::through`]), along the latents as above or — the default,
//! [`InbetweenPath::Rigid`] — as rigidly as possible between the path's corners.
//!
//! Beside it, the baselines the argument rests on: linear interpolation of the two fitted meshes
//! in vertex space, which leaves the learned manifold, and as-rigid-as-possible shape
//! interpolation of them ([`RigidInterpolation`], Alexa et al. 2000), the classical in-between.
//!
//! Timing: [`crate::edit::timing`] gives the interpolation parameters; [`steps_t`] is its
//! uniform case, `steps = N` in-betweens at `t_k = k / (N + 1)`, `k = 1..=N`, framed by the
//! keyframes (`k = 0` and `k = N + 1`), so `N + 2` poses in all.

use burn::tensor::{Device, Tensor, TensorData};

use std::path::PathBuf;

use super::manifold_path::{ManifoldPath, Waypoints};
use crate::atomic_file::Outputs;
use crate::error::{Error, Result};
use crate::fit::{fit_with_latents, FitOptions};
use crate::geom::RigidInterpolation;
use crate::model::Model;
use crate::objective::regularised_triangles;
use crate::picture::contact_sheet;
use crate::picture::Picture;
use crate::progress::{Progress, Silent};
use crate::puppet::pose_file::PoseFile;
use crate::puppet::Puppet;
use crate::render::animation::{AnimationFiles, AnimationWriter};
use crate::render::render_crisp;

/// Which path in-betweens follow from one keyframe's fit to the other's. Both run along the
/// manifold through the training frames that lie between the keyframes ([`ManifoldPath`]; the
/// straight line where none does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InbetweenPath {
    /// As-rigid-as-possible shape interpolation between consecutive corners of the path: the
    /// default, best at every gap on the synthetic walks (docs/results.md "In-betweens along the
    /// manifold").
    #[default]
    Rigid,
    /// The latent path of §4.1 along the corners, carried onto the keyframes' fits.
    Latent,
}

/// The in-betweens of two keyframes by each method, one pose per `t`.
#[derive(Clone, Debug)]
pub struct Inbetweens {
    /// Interpolation parameters, from 0 (the first keyframe) to 1 (the second).
    pub t: Vec<f32>,
    /// The in-betweens along the path asked for ([`InbetweenPath`]), frame pixels, global vertex
    /// numbering: the keyframes' fits at 0 and 1.
    pub path: Vec<Vec<[f32; 2]>>,
    /// The vertex-space interpolation `(1 − t)·v_1 + t·v_2` of the keyframes' fits.
    pub vertex: Vec<Vec<[f32; 2]>>,
    /// The as-rigid-as-possible shape interpolation of the keyframes' fits.
    pub rigid: Vec<Vec<[f32; 2]>>,
}

impl Inbetweens {
    /// The same in-betweens for `worn`, the model's body in another outfit (see
    /// [`Model::pose_from`]).
    pub fn dressed(&self, model: &Model, worn: &Model) -> Inbetweens {
        let dress = |poses: &[Vec<[f32; 2]>]| poses.iter().map(|p| worn.pose_from(model, p)).collect();
        Inbetweens {
            t: self.t.clone(),
            path: dress(&self.path),
            vertex: dress(&self.vertex),
            rigid: dress(&self.rigid),
        }
    }
}

/// The two keyframes, encoded and fitted, ready to produce any in-between quickly (one decode
/// each) — what an interactive timeline holds.
#[derive(Clone, Debug)]
pub struct Interpolator {
    z_a: Tensor<2>,
    z_b: Tensor<2>,
    /// D(z) of each end.
    decoded: [Vec<[f32; 2]>; 2],
    /// Each end's fit: its decode, or where vertex steps took it.
    keys: [Vec<[f32; 2]>; 2],
    /// The latent path the learned in-betweens follow through waypoints, if any were given
    /// (otherwise the straight line).
    path: Option<ManifoldPath>,
}

impl Interpolator {
    /// Fits frames `a` and `b` with `model` as `fit` says.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if a frame is not the puppet's size (see [`Model::check_frame`]).
    pub fn new(model: &Model, a: &Picture, b: &Picture, fit: &FitOptions, device: &Device) -> Result<Self> {
        let (z, keys) = fit_with_latents(model, &[a, b], fit, device, &Silent)?;
        let mut keys = keys.into_iter();
        let keys = [keys.next().unwrap_or_default(), keys.next().unwrap_or_default()];
        Ok(Self::between(model, z.clone().narrow(0, 0, 1), z.narrow(0, 1, 1), device).with_keys(keys))
    }

    /// The interpolation between two latents `[1, Z]` fitted earlier (by `model`, or by the same
    /// body in another outfit), decoded by `model`; the keyframes are their decodes.
    pub fn between(model: &Model, z_a: Tensor<2>, z_b: Tensor<2>, device: &Device) -> Self {
        let decoded = model.to_frame_vertices(model.decode(Tensor::cat(vec![z_a.clone(), z_b.clone()], 0), device));
        let mut it = decoded.into_iter();
        let decoded = [it.next().unwrap_or_default(), it.next().unwrap_or_default()];
        Interpolator {
            z_a,
            z_b,
            keys: decoded.clone(),
            decoded,
            path: None,
        }
    }

    /// The same keyframes with the learned path following the manifold through `waypoints`
    /// ([`ManifoldPath`]) instead of the straight latent line; the plain latent path stays
    /// straight.
    pub fn through(mut self, waypoints: &Waypoints) -> Self {
        self.path = Some(ManifoldPath::new(
            self.z_a.clone(),
            &self.decoded[0],
            self.z_b.clone(),
            &self.decoded[1],
            waypoints,
        ));
        self
    }

    /// The same latent path with other keyframe poses (fits of the same frames past the
    /// manifold); a pose of the wrong length is ignored for its own decode.
    pub fn with_keys(mut self, keys: [Vec<[f32; 2]>; 2]) -> Self {
        for (key, (new, decoded)) in self.keys.iter_mut().zip(keys.into_iter().zip(&self.decoded)) {
            if new.len() == decoded.len() {
                *key = new;
            }
        }
        self
    }

    /// The keyframe poses (frame pixels).
    pub fn keys(&self) -> [&[[f32; 2]]; 2] {
        [&self.keys[0], &self.keys[1]]
    }

    /// The plain latent path of §4.1 at each `t`, decoded in one batch (frame pixels): the
    /// decodes of the two latents at its ends, not the keyframes' fits.
    pub fn latent_poses(&self, model: &Model, t: &[f32], device: &Device) -> Vec<Vec<[f32; 2]>> {
        if t.is_empty() {
            return Vec::new();
        }
        let n = t.len();
        let w = Tensor::<2>::from_data(TensorData::new(t.to_vec(), [n, 1]), device);
        let z = self.z_a.clone().repeat_dim(0, n) * (w.clone().neg() + 1.0) + self.z_b.clone().repeat_dim(0, n) * w;
        model.to_frame_vertices(model.decode(z, device))
    }

    /// The default path at each `t`: the latent path (through the waypoints, if given) plus the
    /// keyframes' residuals over their decodes, interpolated (module doc) — the keyframes' fits
    /// at 0 and 1.
    pub fn keyed_poses(&self, model: &Model, t: &[f32], device: &Device) -> Vec<Vec<[f32; 2]>> {
        let mut poses = match &self.path {
            Some(path) if !t.is_empty() => model.to_frame_vertices(model.decode(path.latents(t, device), device)),
            _ => self.latent_poses(model, t, device),
        };
        for (pose, &t) in poses.iter_mut().zip(t) {
            // Exactly the keyframes at the ends, not up to float rounding of decode + residual.
            if t == 0.0 || t == 1.0 {
                pose.clone_from(&self.keys[usize::from(t == 1.0)]);
                continue;
            }
            for (k, p) in pose.iter_mut().enumerate() {
                for (end, weight) in [(0, 1.0 - t), (1, t)] {
                    let (key, decoded) = (self.keys[end][k], self.decoded[end][k]);
                    p[0] += weight * (key[0] - decoded[0]);
                    p[1] += weight * (key[1] - decoded[1]);
                }
            }
        }
        poses
    }

    /// The as-rigid-as-possible interpolation along the manifold path ([`Self::through`]; the
    /// straight one without it) at each `t`: between consecutive corners of the path, the
    /// keyframes' fits at its ends and the waypoints' decodes between.
    ///
    /// # Errors
    /// As [`Self::rigid_poses`].
    pub fn manifold_rigid_poses(&self, model: &Model, t: &[f32]) -> Result<Vec<Vec<[f32; 2]>>> {
        let Some(path) = &self.path else {
            return self.rigid_poses(model, t);
        };
        let mut corners = path.corner_poses().to_vec();
        let last = corners.len() - 1;
        corners[0].clone_from(&self.keys[0]);
        corners[last].clone_from(&self.keys[1]);
        let mut segments: Vec<Option<RigidInterpolation>> = (0..last).map(|_| None).collect();
        t.iter()
            .map(|&t| {
                // Exactly the keyframes at the ends, not up to the solve's rounding.
                if t == 0.0 || t == 1.0 {
                    return Ok(self.keys[usize::from(t == 1.0)].clone());
                }
                let (k, share) = path.segment(t);
                let interpolation = match &mut segments[k] {
                    Some(i) => i,
                    slot => slot.insert(rigid_interpolation(&model.puppet, &corners[k], &corners[k + 1])?),
                };
                let mut pose = interpolation.at(f64::from(share));
                if let Some(rig) = model.expansion.rig_map() {
                    rig.apply(&mut pose);
                }
                Ok(pose)
            })
            .collect()
    }

    /// The vertex-space interpolation of the keyframes at `t`.
    pub fn vertex_pose(&self, t: f32) -> Vec<[f32; 2]> {
        self.keys[0]
            .iter()
            .zip(&self.keys[1])
            .map(|(a, b)| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
            .collect()
    }

    /// The as-rigid-as-possible shape interpolation of the keyframes at each `t` (layers turn as
    /// one, joints stay joined; with an accessory rig the accessories are placed on the
    /// interpolated body).
    ///
    /// # Errors
    /// [`Error::Geometry`] if the keyframes are not poses of `model`'s puppet.
    pub fn rigid_poses(&self, model: &Model, t: &[f32]) -> Result<Vec<Vec<[f32; 2]>>> {
        let mut interpolation = rigid_interpolation(&model.puppet, &self.keys[0], &self.keys[1])?;
        Ok(t.iter()
            .map(|&t| {
                let mut pose = interpolation.at(f64::from(t));
                if let Some(rig) = model.expansion.rig_map() {
                    rig.apply(&mut pose);
                }
                pose
            })
            .collect())
    }
}

/// [`RigidInterpolation`] between two poses of `puppet`: the triangles its ARAP term holds
/// ([`regularised_triangles`]: with an accessory rig only the body's, which the rig then dresses),
/// each layer's a group, its root layer the anchor, its joints the links.
///
/// # Errors
/// As [`RigidInterpolation::new`].
pub fn rigid_interpolation(puppet: &Puppet, a: &[[f32; 2]], b: &[[f32; 2]]) -> Result<RigidInterpolation> {
    let offsets = puppet.vertex_offsets();
    let triangles = regularised_triangles(puppet);
    // A triangle's layer is its first vertex's: the last layer starting at or before it.
    let groups: Vec<u32> = triangles
        .iter()
        .map(|t| (offsets.partition_point(|&o| o <= t[0] as usize) - 1) as u32)
        .collect();
    let links: Vec<[u32; 2]> = puppet
        .joints
        .iter()
        .map(|j| [puppet.global_index(j.a) as u32, puppet.global_index(j.b) as u32])
        .collect();
    RigidInterpolation::new(&puppet.rest_vertices(), &triangles, &groups, puppet.root as u32, &links, a, b)
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

/// In-betweens of frames `a` and `b` at each of `t` (e.g. [`steps_t`]): `path` along the manifold
/// through `waypoints` (the frames the model was trained on) from one fit to the other, and the
/// vertex-space and as-rigid-as-possible interpolations of the fits.
///
/// # Errors
/// As [`Interpolator::new`] and [`Interpolator::manifold_rigid_poses`].
#[allow(clippy::too_many_arguments)] // each is one of the in-between's independent inputs
pub fn inbetween(
    model: &Model,
    a: &Picture,
    b: &Picture,
    t: &[f32],
    fit: &FitOptions,
    waypoints: &Waypoints,
    path: InbetweenPath,
    device: &Device,
) -> Result<Inbetweens> {
    along(
        &Interpolator::new(model, a, b, fit, device)?.through(waypoints),
        model,
        t,
        path,
        device,
    )
}

/// The in-betweens of `interp` (keyframes fitted already, e.g. with their poses replaced by
/// closer fits: [`Interpolator::with_keys`]) at each `t`, the learned path as `path` says, the
/// vertex and as-rigid-as-possible interpolations beside it.
///
/// # Errors
/// As [`inbetween`].
pub fn along(interp: &Interpolator, model: &Model, t: &[f32], path: InbetweenPath, device: &Device) -> Result<Inbetweens> {
    Ok(Inbetweens {
        t: t.to_vec(),
        path: match path {
            InbetweenPath::Rigid => interp.manifold_rigid_poses(model, t)?,
            InbetweenPath::Latent => interp.keyed_poses(model, t, device),
        },
        vertex: t.iter().map(|&t| interp.vertex_pose(t)).collect(),
        rigid: interp.rigid_poses(model, t)?,
    })
}

/// The most in-between steps [`comparison_sheet`] shows side by side.
pub const SHEET_COLUMNS: usize = 12;

/// Figure 5 of neural-puppet.md as one picture: at most [`SHEET_COLUMNS`] of the in-betweens'
/// steps (evenly sampled, ends included), in rows — the learned path, the vertex-space
/// interpolation, the as-rigid-as-possible interpolation, and, if `training` is not empty, the
/// training frame nearest each learned step.
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
    let path = render(&inbetweens.path)?;
    let vertex = render(&inbetweens.vertex)?;
    let rigid = render(&inbetweens.rigid)?;
    let nearest: Vec<Picture> = path
        .iter()
        .filter_map(|p| nearest_frame(p, training).map(|(k, _)| training[k].clone()))
        .collect();
    let cells: Vec<&Picture> = path.iter().chain(&vertex).chain(&rigid).chain(&nearest).collect();
    Ok(contact_sheet(&cells, columns))
}

/// Where in-betweens are written; each animation is optional.
#[derive(Clone, Debug, Default)]
pub struct InbetweenFiles {
    /// The path asked for (ours), played there and back in its GIF.
    pub path: AnimationFiles,
    /// The vertex-space interpolation.
    pub vertex: AnimationFiles,
    /// The as-rigid-as-possible interpolation.
    pub rigid: AnimationFiles,
    /// The training frame nearest each latent step (written only if there are training frames).
    pub nearest: AnimationFiles,
    /// Each step's pose as `<prefix>_NNN.json` in this folder, the prefix of the path's frames
    /// (`step` if it writes none).
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
    let prefix = files.path.frames.as_ref().map_or("step", |(_, prefix)| prefix.as_str());
    let pose_paths: Vec<PathBuf> = match &files.poses {
        Some(dir) => (0..n).map(|k| dir.join(format!("{prefix}_{k:0digits$}.json"))).collect(),
        None => Vec::new(),
    };
    for path in &pose_paths {
        outputs.claim(path)?;
    }
    let mut path = AnimationWriter::new(&files.path, n, w, h, outputs)?;
    // The comparisons are rendered only where they are written.
    let comparison = |files: &AnimationFiles| {
        (!files.is_empty())
            .then(|| AnimationWriter::new(files, n, w, h, outputs))
            .transpose()
    };
    let mut comparisons = [
        (comparison(&files.vertex)?, &inbetweens.vertex),
        (comparison(&files.rigid)?, &inbetweens.rigid),
    ];
    let mut nearest = (!training.is_empty())
        .then(|| AnimationWriter::new(&files.nearest, n, w, h, outputs))
        .transpose()?;
    progress.stage("render", n as u64);
    for k in 0..n {
        let picture = render_crisp(&model.puppet, &inbetweens.path[k], w, h)?;
        if let (Some(writer), Some((i, _))) = (&mut nearest, nearest_frame(&picture, training)) {
            writer.push(&training[i])?;
        }
        path.push(&picture)?;
        for (writer, poses) in &mut comparisons {
            if let Some(writer) = writer {
                writer.push(&render_crisp(&model.puppet, &poses[k], w, h)?)?;
            }
        }
        if let Some(path) = pose_paths.get(k) {
            let pose = PoseFile {
                vertices: inbetweens.path[k].clone(),
            };
            outputs.write(path, &pose.to_json())?;
        }
        progress.advance(1);
    }
    for k in path.return_frames() {
        path.push_return(&render_crisp(&model.puppet, &inbetweens.path[k], w, h)?)?;
    }
    let mut written = pose_paths;
    written.extend(path.finish()?);
    for writer in comparisons.into_iter().filter_map(|(writer, _)| writer).chain(nearest) {
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
    use crate::edit::test_support::small_model;

    #[test]
    fn latent_end_points_are_the_fits_and_vertex_interpolation_is_linear() {
        let (model, device) = small_model(0.3);
        let a = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut b = a.clone();
        b.pixels.rotate_left(37); // a different image, so a different latent
        let none = Waypoints::of_frames(&model, &[], &device).unwrap();
        let t = steps_t(3, MAX_STEPS).unwrap();
        let out = inbetween(&model, &a, &b, &t, &FitOptions::one_pass(), &none, InbetweenPath::Latent, &device).unwrap();
        assert_eq!(out.t, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let fits = model.fit(&[&a, &b], &device).unwrap();
        let close = |x: &[[f32; 2]], y: &[[f32; 2]]| {
            x.iter()
                .zip(y)
                .all(|(p, q)| (p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3)
        };
        assert!(close(&out.path[0], &fits[0]) && close(&out.path[4], &fits[1]));
        assert!(close(&out.vertex[0], &fits[0]) && close(&out.vertex[4], &fits[1]));
        assert!(close(&out.rigid[0], &fits[0]) && close(&out.rigid[4], &fits[1]));
        assert!(!close(&fits[0], &fits[1]), "the two frames should fit differently");
        for (k, &t) in out.t.iter().enumerate() {
            let want: Vec<[f32; 2]> = fits[0]
                .iter()
                .zip(&fits[1])
                .map(|(p, q)| [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])])
                .collect();
            assert!(close(&out.vertex[k], &want));
        }
        // With no waypoint, the rigid path is the as-rigid-as-possible interpolation of the fits.
        let rigid = inbetween(&model, &a, &b, &t, &FitOptions::one_pass(), &none, InbetweenPath::Rigid, &device).unwrap();
        assert!(rigid.path.iter().zip(&out.rigid).all(|(p, q)| close(p, q)));
        // The middle pose is the decoded mean latent.
        let z = model.encode(&[&a, &b], &device).unwrap();
        let mid = model.to_frame_vertices(model.decode(z.mean_dim(0), &device)).pop().unwrap();
        assert!(close(&out.path[2], &mid));
    }

    #[test]
    fn the_default_path_starts_and_ends_on_fits_past_the_manifold() {
        let (model, device) = small_model(0.3);
        let (w, h) = (model.puppet.width, model.puppet.height);
        let a = render_crisp(&model.puppet, &model.puppet.rest_vertices(), w, h).unwrap();
        let mut moved = model.puppet.rest_vertices();
        moved.iter_mut().for_each(|p| p[0] += 4.0);
        let b = render_crisp(&model.puppet, &moved, w, h).unwrap();
        let options = FitOptions {
            latent_steps: 0,
            vertex_steps: 30,
            vertex_rounds: 1,
            limb_search: None,
            ..FitOptions::default()
        };
        let t = [0.0, 0.5, 1.0];
        let none = Waypoints::of_frames(&model, &[], &device).unwrap();
        let out = inbetween(&model, &a, &b, &t, &options, &none, InbetweenPath::Latent, &device).unwrap();
        let fits = crate::fit::fit(&model, &[&a, &b], &options, &device, &crate::progress::Silent).unwrap();
        let gap = |x: &[[f32; 2]], y: &[[f32; 2]]| x.iter().zip(y).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f32::max);
        assert!(gap(&out.path[0], &fits[0]) < 1e-3 && gap(&out.path[2], &fits[1]) < 1e-3);
        let l2_to = |pose: &[[f32; 2]], frame: &Picture| crate::metrics::l2(&render_crisp(&model.puppet, pose, w, h).unwrap(), frame);
        assert!(l2_to(&out.path[0], &a) <= l2_to(&fits[0], &a) + 1e-6);
        assert!(l2_to(&out.path[2], &b) <= l2_to(&fits[1], &b) + 1e-6);
        // The vertex steps took the fit off the manifold: the plain latent path misses it.
        let interp = Interpolator::new(&model, &a, &b, &options, &device).unwrap();
        let plain = interp.latent_poses(&model, &[1.0], &device).pop().unwrap();
        assert!(gap(&plain, &fits[1]) > 1.0, "{}", gap(&plain, &fits[1]));
        // Half way, the offsets of both ends are carried half each.
        let mid = interp.latent_poses(&model, &[0.5], &device).pop().unwrap();
        let ends = interp.latent_poses(&model, &[0.0, 1.0], &device);
        for (k, p) in out.path[1].iter().enumerate() {
            for d in 0..2 {
                let want = mid[k][d] + 0.5 * (fits[0][k][d] - ends[0][k][d]) + 0.5 * (fits[1][k][d] - ends[1][k][d]);
                assert!((p[d] - want).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn zero_or_too_many_steps_and_wrong_sizes_are_refused() {
        let (model, device) = small_model(0.3);
        let a = Picture::filled(48, 40, [1.0, 0.0, 0.0, 1.0]);
        assert!(matches!(steps_t(0, MAX_STEPS), Err(Error::Setting { .. })));
        assert!(matches!(steps_t(11, 10), Err(Error::Limit { amount: 11, limit: 10, .. })));
        let small = Picture::filled(20, 20, [1.0; 4]);
        let none = Waypoints::of_frames(&model, &[], &device).unwrap();
        let err = inbetween(
            &model,
            &a,
            &small,
            &[0.0, 1.0],
            &FitOptions::one_pass(),
            &none,
            InbetweenPath::Rigid,
            &device,
        )
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
