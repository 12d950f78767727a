//! Poses the template draws itself (issue 19): the puppet is a generator with exact ground
//! truth, so beside the drawn frames each step can show the network the template rendered in
//! a sampled pose — every limb turned about its joint, root first, then the whole figure scaled
//! and shifted — and ask for that pose's vertices back (a vertex loss beside eq. 4's image
//! loss). Nine drawn frames show few poses; sampled ones fill the manifold between and around
//! them. The turns and moves are the posing engine's (`posing::sample`), so these poses and the
//! engine's agree. Not in neural-puppet.md.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::Model;
use crate::posing::sample::{scale_and_shift, turn_limbs};
use crate::puppet::limbs::{limbs, Limb};
use crate::render::render_crisp;
use crate::rng::Rng;

/// `[train.sampled]`: how many sampled poses a step shows and how they are drawn. Off (share 0,
/// the paper's training) unless a config asks for it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SampledPoses {
    /// Sampled poses per drawn frame of a batch (0: none; 1: as many as the batch's frames).
    pub share: f64,
    /// Weight of the vertex loss: the mean squared distance, in working pixels², between the
    /// vertices the network gives a sampled pose's render and the pose's own.
    pub vertex_weight: f64,
    /// Each limb turned about its joint by up to this many degrees either way.
    pub max_degrees: f32,
    /// The figure scaled by up to this share either way, about the frame's centre.
    pub scale: f32,
    /// The figure shifted by up to this share of the frame's width and height either way.
    pub shift: f32,
    /// What the limbs are turned from: the rest pose, or the poses the network gives the step's
    /// drawn frames (so the samples explore around the drawn poses as training learns them).
    pub around: SampleAround,
    /// The schedule: samples are shown for this share of the run's steps (`train.steps`), and
    /// the steps after train on the drawn frames alone (1: the whole run).
    pub until: f64,
}

/// What sampled poses are drawn around.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SampleAround {
    /// The template's rest pose.
    Rest,
    /// The network's current poses of the step's drawn frames, in turn.
    Fits,
}

impl Default for SampledPoses {
    /// Off (share 0): it lowered the network's own fits of held-out frames but made latent
    /// in-betweens worse (docs/results.md "Sampled poses and in-betweens"). The other settings are
    /// the ones that measured best, so `share = 0.5` alone turns on the measured setting: limbs
    /// turned up to 20° from the network's pose of a drawn frame, the figure scaled within ±5 % and
    /// shifted within ±3 %.
    fn default() -> Self {
        SampledPoses {
            share: 0.0,
            vertex_weight: 10.0,
            max_degrees: 20.0,
            scale: 0.05,
            shift: 0.03,
            around: SampleAround::Fits,
            until: 1.0,
        }
    }
}

/// The most sampled poses one step may add (their renders and activations are held at once).
pub const MAX_SAMPLED: usize = 256;

impl SampledPoses {
    /// Whether no sampled pose is shown (the config's table may then be left out).
    pub fn is_off(&self) -> bool {
        self.share == 0.0
    }

    /// Whether step `step` (from 0) of a run of `steps` shows samples.
    pub fn shown_at(&self, step: u64, steps: u64) -> bool {
        !self.is_off() && (step as f64) < self.until * steps as f64
    }

    /// Sampled poses in a step of `batch` drawn frames.
    pub fn per_step(&self, batch: usize) -> usize {
        ((batch as f64 * self.share).ceil() as usize).min(MAX_SAMPLED)
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first key out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |key: &str, value: f64, expected: &str| Err(Error::setting(format!("train.sampled.{key}"), value, expected));
        if !(self.share.is_finite() && (0.0..=16.0).contains(&self.share)) {
            return bad("share", self.share, "from 0 to 16 sampled poses per drawn frame");
        }
        if !(self.vertex_weight.is_finite() && self.vertex_weight >= 0.0) {
            return bad("vertex_weight", self.vertex_weight, "a finite weight ≥ 0");
        }
        if !(self.max_degrees.is_finite() && (0.0..=180.0).contains(&self.max_degrees)) {
            return bad("max_degrees", f64::from(self.max_degrees), "from 0 to 180");
        }
        if !(self.scale.is_finite() && (0.0..0.9).contains(&self.scale)) {
            return bad("scale", f64::from(self.scale), "from 0 to below 0.9");
        }
        if !(self.shift.is_finite() && (0.0..=0.5).contains(&self.shift)) {
            return bad("shift", f64::from(self.shift), "from 0 to 0.5");
        }
        if !(self.until > 0.0 && self.until <= 1.0) {
            return bad("until", self.until, "a share of the run's steps above 0, at most 1");
        }
        Ok(())
    }
}

/// Draws sampled poses of one model's puppet.
pub struct PoseSampler {
    settings: SampledPoses,
    limbs: Vec<Limb>,
    seed: u64,
}

/// Sampled poses and their renders as the network takes them.
pub struct Sampled {
    /// Each pose's premultiplied planes `[4, S, S]` of the working square.
    pub planes: Vec<Vec<f32>>,
    /// Each pose's vertices in working pixels, global numbering.
    pub vertices: Vec<Vec<[f32; 2]>>,
}

impl PoseSampler {
    /// A sampler for `model`'s puppet, seeded by `seed`.
    pub fn new(model: &Model, settings: &SampledPoses, seed: u64) -> Self {
        PoseSampler {
            settings: settings.clone(),
            limbs: limbs(&model.puppet),
            seed,
        }
    }

    /// Whether the samples are drawn around the network's poses of the drawn frames.
    pub fn around_fits(&self) -> bool {
        self.settings.around == SampleAround::Fits
    }

    /// A pose of `model`'s puppet (frame pixels) drawn by `rng`: `base`'s limbs (the rest pose
    /// when `None`) turned, root first, the figure scaled about the frame's centre and shifted;
    /// accessories placed by the rig, if the model has one.
    pub fn pose(&self, model: &Model, base: Option<&[[f32; 2]]>, rng: &mut Rng) -> Vec<[f32; 2]> {
        let s = &self.settings;
        let mut pose = base.map_or_else(|| model.puppet.rest_vertices(), <[_]>::to_vec);
        turn_limbs(&self.limbs, &mut pose, s.max_degrees, rng);
        scale_and_shift(&mut pose, model.puppet.width, model.puppet.height, s.scale, s.shift, rng);
        if let Some(map) = model.expansion.rig_map() {
            map.apply(&mut pose);
        }
        pose
    }

    /// The sampled poses of step `step` for a batch of `batch` drawn frames, each around the
    /// next of `bases` (frame pixels; the rest pose when there are none): a function of the
    /// seed, the step and the bases, so a resumed run sees what an uninterrupted one would.
    ///
    /// # Errors
    /// As [`render_crisp`].
    pub fn step(&self, model: &Model, step: u64, batch: usize, bases: &[Vec<[f32; 2]>]) -> Result<Sampled> {
        let count = self.settings.per_step(batch);
        let mut rng = Rng::new(self.seed).fork(step);
        let mut out = Sampled {
            planes: Vec::with_capacity(count),
            vertices: Vec::with_capacity(count),
        };
        for k in 0..count {
            let base = (!bases.is_empty()).then(|| bases[k % bases.len()].as_slice());
            let pose = self.pose(model, base, &mut rng);
            let picture = render_crisp(&model.puppet, &pose, model.puppet.width, model.puppet.height)?;
            out.planes.push(model.letterbox.premultiplied_planes(&picture));
            out.vertices.push(pose.iter().map(|&p| model.letterbox.to_work(p)).collect());
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampled_poses_keep_joints_welded_turn_limbs_and_depend_only_on_seed_and_step() {
        let (model, _) = crate::edit::test_support::small_model(0.3);
        let settings = SampledPoses {
            share: 1.0,
            ..SampledPoses::default()
        };
        let sampler = PoseSampler::new(&model, &settings, 3);
        let puppet = &model.puppet;
        let rest = puppet.rest_vertices();
        let gap = |pose: &[[f32; 2]], j: &crate::puppet::Joint| {
            let (a, b) = (pose[puppet.global_index(j.a)], pose[puppet.global_index(j.b)]);
            (a[0] - b[0]).hypot(a[1] - b[1])
        };
        let mut rng = Rng::new(9);
        for _ in 0..20 {
            let pose = sampler.pose(&model, None, &mut rng);
            assert!(pose.iter().flatten().all(|x| x.is_finite()));
            for j in &puppet.joints {
                // A turn about the child's joint vertex, then one similarity: the gap scales.
                assert!(
                    gap(&pose, j) <= gap(&rest, j) * (1.0 + settings.scale) + 1e-3,
                    "joint drifted apart"
                );
            }
        }
        let a = sampler.step(&model, 5, 4, &[]).unwrap();
        let b = sampler.step(&model, 5, 4, &[]).unwrap();
        let c = sampler.step(&model, 6, 4, &[]).unwrap();
        assert_eq!(a.vertices.len(), 4);
        assert!(a.vertices == b.vertices && a.planes == b.planes, "one step, one sample");
        assert_ne!(a.vertices, c.vertices, "another step, other poses");
        let work: Vec<[f32; 2]> = rest.iter().map(|&p| model.letterbox.to_work(p)).collect();
        assert!(a.vertices.iter().all(|v| *v != work), "sampled poses are not the rest pose");
    }

    #[test]
    fn samples_around_the_fits_start_from_the_bases_given() {
        let (model, _) = crate::edit::test_support::small_model(0.3);
        let still = SampledPoses {
            share: 1.0,
            max_degrees: 0.0,
            scale: 0.0,
            shift: 0.0,
            around: SampleAround::Fits,
            ..SampledPoses::default()
        };
        let sampler = PoseSampler::new(&model, &still, 3);
        assert!(sampler.around_fits());
        let rest = model.puppet.rest_vertices();
        let bases: Vec<Vec<[f32; 2]>> = [4.0, -3.0]
            .iter()
            .map(|dx| rest.iter().map(|p| [p[0] + dx, p[1]]).collect())
            .collect();
        let s = sampler.step(&model, 0, 3, &bases).unwrap();
        for (k, pose) in s.vertices.iter().enumerate() {
            let base = &bases[k % 2];
            let off = pose
                .iter()
                .zip(base)
                .map(|(q, p)| {
                    let w = model.letterbox.to_work(*p);
                    (q[0] - w[0]).hypot(q[1] - w[1])
                })
                .fold(0.0, f32::max);
            assert!(off < 1e-4, "sample {k} is {off} working px from its base");
        }
    }

    #[test]
    fn samples_are_shown_until_the_schedule_ends() {
        let schedule = SampledPoses {
            share: 0.5,
            until: 0.7,
            ..SampledPoses::default()
        };
        let shown: Vec<bool> = (0..10).map(|step| schedule.shown_at(step, 10)).collect();
        assert_eq!(shown, [true, true, true, true, true, true, true, false, false, false]);
        assert!(
            (0..10).all(|step| !SampledPoses::default().shown_at(step, 10)),
            "off is never shown"
        );
    }

    #[test]
    fn settings_out_of_range_are_named() {
        for (bad, key) in [
            (
                SampledPoses {
                    share: -1.0,
                    ..SampledPoses::default()
                },
                "share",
            ),
            (
                SampledPoses {
                    max_degrees: 400.0,
                    ..SampledPoses::default()
                },
                "max_degrees",
            ),
            (
                SampledPoses {
                    scale: 0.95,
                    ..SampledPoses::default()
                },
                "scale",
            ),
            (
                SampledPoses {
                    vertex_weight: f64::NAN,
                    ..SampledPoses::default()
                },
                "vertex_weight",
            ),
            (
                SampledPoses {
                    until: 0.0,
                    ..SampledPoses::default()
                },
                "until",
            ),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains(&format!("train.sampled.{key}")), "{e}");
        }
        assert!(SampledPoses::default().validate().is_ok() && SampledPoses::default().is_off());
    }
}
