//! A synthetic character's rig along its sequence's true body motion, against where the
//! generator drew its accessories.

use super::report::{MotionReport, MotionScores, Scores};
use super::scene::{dist, Scene};
use super::sticker::Sticker;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::puppet::rig_data::RigData;
use crate::puppet::Puppet;
use crate::rig::deform::{deform, DeformOptions};
use crate::synth::{true_positions, Truth};

/// Scores the rig of `puppet` (rigged, built from the template of the synthetic sequence whose
/// ground truth is `truth`) along the sequence: in every frame the body takes its true pose, and
/// the accessories placed by the rig, left at rest, or stuck to the body under them are compared
/// with where the generator drew them.
///
/// # Errors
/// [`Error::Setting`] if the puppet has no rig; as [`true_positions`] if a layer is not a part
/// of the truth.
pub fn evaluate_motion(puppet: &Puppet, truth: &Truth, progress: &dyn Progress) -> Result<MotionReport> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting(format!("character {:?}", truth.name), "no rig", "a character with accessory layers"))?;
    let scene = Scene::new(puppet, &rig.edges);
    let motion = Motion::new(puppet, rig, truth);
    let accessory: Vec<usize> = scene.accessory_vertices().collect();
    let mut sums = [[0.0f64; 2]; 3];
    let mut scores: [Vec<Scores>; 3] = Default::default();
    let mut truth_scores = Vec::with_capacity(truth.frames.len());
    progress.stage("true motion", truth.frames.len() as u64);
    for frame in 0..truth.frames.len() {
        let [rigged, unchanged, stuck, true_v] = motion.poses(frame)?;
        let poses = [rigged, unchanged, stuck];
        for (m, pose) in poses.iter().enumerate() {
            let error = accessory.iter().map(|&k| f64::from(dist(pose[k], true_v[k]))).sum::<f64>();
            sums[m][0] += error / accessory.len().max(1) as f64;
            let iou = scene
                .accessories
                .iter()
                .map(|&l| {
                    let (got, want) = (scene.layer_mask(l, pose), scene.layer_mask(l, &true_v));
                    got.and(&want).count() as f64 / got.or(&want).count().max(1) as f64
                })
                .sum::<f64>();
            sums[m][1] += iou / scene.accessories.len().max(1) as f64;
            scores[m].push(scene.score(pose));
        }
        truth_scores.push(scene.score(&true_v));
        progress.advance(1);
    }
    let n = truth.frames.len().max(1) as f64;
    let [rig_scores, unchanged, sticker] = [0, 1, 2].map(|m| MotionScores {
        accessory_error: sums[m][0] / n,
        accessory_iou: sums[m][1] / n,
        scores: Scores::worst(&scores[m]),
    });
    Ok(MotionReport {
        frames: truth.frames.len(),
        rig: rig_scores,
        unchanged,
        sticker,
        truth: Scores::worst(&truth_scores),
    })
}

/// A synthetic sequence's frames posed four ways: the body at its true pose, the accessories
/// placed by the rig, left at rest, stuck to the body under them, and at their true places.
struct Motion<'a> {
    puppet: &'a Puppet,
    rig: &'a RigData,
    truth: &'a Truth,
    sticker: Sticker,
    rest: Vec<[f32; 2]>,
    accessory_vertices: Vec<usize>,
}

impl<'a> Motion<'a> {
    fn new(puppet: &'a Puppet, rig: &'a RigData, truth: &'a Truth) -> Self {
        Motion {
            puppet,
            rig,
            truth,
            sticker: Sticker::new(puppet),
            rest: puppet.rest_vertices(),
            accessory_vertices: puppet.accessory_vertices(),
        }
    }

    /// Frame `frame` as [rig, unchanged, sticker, truth].
    fn poses(&self, frame: usize) -> Result<[Vec<[f32; 2]>; 4]> {
        let true_v = true_positions(self.truth, frame, self.puppet)?;
        let mut unchanged = true_v.clone();
        self.accessory_vertices.iter().for_each(|&k| unchanged[k] = self.rest[k]);
        Ok([
            deform(self.puppet, self.rig, &true_v, &DeformOptions::default()),
            unchanged,
            self.sticker.apply(&true_v),
            true_v,
        ])
    }
}

/// A picture of `puppet` (rigged, from the template of the sequence `truth` describes) along the
/// true motion: `rows` frames spread over the sequence, each drawn with the accessories placed
/// by the rig | where the generator drew them | stuck to the body | left at rest.
///
/// # Errors
/// [`Error::Setting`] without a rig; as [`true_positions`]; render errors.
pub fn motion_sheet(puppet: &Puppet, truth: &Truth, rows: usize) -> Result<crate::picture::Picture> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting("motion sheet", "a puppet without a rig", "a rigged puppet"))?;
    let motion = Motion::new(puppet, rig, truth);
    let scale = (256 / puppet.width.max(puppet.height)).clamp(1, 4);
    let n = truth.frames.len();
    let rows = rows.min(n).max(1);
    let mut cells = Vec::new();
    for r in 0..rows {
        let [rigged, unchanged, stuck, true_v] = motion.poses(r * n / rows)?;
        for pose in [rigged, true_v, stuck, unchanged] {
            cells.push(crate::render::render_crisp(puppet, &pose, puppet.width, puppet.height)?.upscaled_on_white(scale));
        }
    }
    let refs: Vec<&crate::picture::Picture> = cells.iter().collect();
    Ok(crate::picture::contact_sheet(&refs, 4))
}
