//! The training config (`puppet train <config.toml>`): what to train on, how long, and the loss
//! weights of neural-puppet.md eq. 4, 10 and 11. Relative paths are relative to the config file.
//!
//! ```toml
//! puppet = "../data/kenney/robot"   # a puppet folder (puppet.json) or artwork to build one from
//! frames = "../data/kenney/robot"   # a sequence: a folder of frames (or one holding frames/)
//! output = "../runs/robot"          # the model folder written by training
//! seed = 1
//! test_fraction = 0.3               # held-out share of the frames (paper: 70/30)
//! split_seed = 1                    # optional: seeds the split alone (default: `seed`), so runs
//!                                   #   of other seeds hold out the same frames
//!
//! [model]                           # the network (DeformationNetConfig); all optional
//! input_size = 128                  # a multiple of 8; the network grows with its square (256: ~136 M weights, 512 is too many)
//! rig = true                        # false: accessories are free layers, not rigged
//!
//! [train]
//! steps = 2000
//! batch = 16                        # at most the number of training frames
//! learning_rate = 1e-4
//! learning_rate_end = 1e-5          # optional: half-cosine decay to this by the last step
//! sigma = [4.0, 0.5]                # σ (px² of the working square) at the first and last step
//! checkpoint_every = 100
//! eval_every = 100                  # the held-out frames' loss, logged and plotted
//!
//! [train.sampled]                   # poses the template draws itself (issue 19; not the
//! share = 0.0                       #   paper's): per drawn frame of a batch, 0 = off
//! vertex_weight = 10.0              # their vertex loss, per working px² of mean error
//! max_degrees = 20.0                # each limb turned about its joint within ± this
//! scale = 0.05                      # the figure scaled within 1 ± this
//! shift = 0.03                      # and shifted within ± this share of the frame
//! around = "fits"                   # turned from the network's poses of the batch, or "rest"
//! until = 1.0                       # shown for this share of the steps, then drawn frames only
//!
//! [train.augment]                   # the drawn frames moved and recoloured each step (issue
//! shift = 0.0                       #   19; not the paper's): within ± this share of the square
//! scale = 0.0                       # scaled within 1 ± this about the square's centre
//! max_degrees = 0.0                 # turned within ± this
//! colour = 0.0                      # the input's channels multiplied within 1 ± this
//!
//! [train.guide]                     # start from the prior (issue 56; not the paper's): the
//! weight = 0.0                      #   training frames' poses pulled toward the prior's fits
//! until = 0.2                       #   of them, 0 = off; for this share of the steps
//!
//! [train.adam]                      # the optimiser; all optional (PyTorch's defaults)
//! beta_1 = 0.9
//! beta_2 = 0.999
//! epsilon = 1e-8
//! weight_decay = 0.0
//!
//! [loss]                            # weights; see `LossWeights` for the units
//! arap = 2500.0
//! joints = 1e4
//! masked = false                    # eq. 10–11: frames drawn over a background
//! area = 2e-3
//!
//! [limits]                          # what a run may read; all optional
//! max_frames = 4096
//! max_total_pixels = 67108864       # over all frames (16 bytes each in memory)
//! max_image_pixels = 16777216       # one frame
//! ```
//!
//! Paths are stored canonical (absolute, links resolved) once the config is loaded, so a run
//! resumed from another working directory, or whose folder was moved, is recognised.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::picture::ImageLimits;
use crate::puppet::sequence::FrameCheck;
use crate::user_file;

use super::augment::Augment;
use super::guide::Guide;
use super::optim::AdamSettings;
use super::sampled::SampledPoses;
use crate::error::{Context, Error, Result};
use crate::model::deformation::DeformationNetConfig;
pub use crate::objective::LossWeights;

/// A whole training config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// A puppet folder, or character artwork (folder with character.toml, .ora or .psd) to build one
    /// from with the default build options.
    pub puppet: PathBuf,
    /// The frame sequence (all frames; the split picks the held-out ones).
    pub frames: PathBuf,
    /// The model folder to write (checkpoints, logs, the final model).
    pub output: PathBuf,
    /// A trained model folder the run starts from: its weights instead of fresh ones, its split
    /// kept (the frames it held out stay held out; every other frame of `frames`, new ones
    /// included, trains). Same puppet and `[model]` settings. `puppet train --from`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<PathBuf>,
    /// Seeds the weights, the batch order and, without `split_seed`, the split.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Seeds the train / test split alone, if set: runs that differ only in `seed` then hold out
    /// the same frames, and their spread is the run-to-run noise of a measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split_seed: Option<u64>,
    /// Share of frames held out for testing, in [0, 1).
    #[serde(default = "default_test_fraction")]
    pub test_fraction: f64,
    /// The network's hyper-parameters.
    #[serde(default)]
    pub model: ModelSettings,
    /// Optimisation settings.
    #[serde(default)]
    pub train: TrainSettings,
    /// Loss weights.
    #[serde(default)]
    pub loss: LossWeights,
    /// What the run may read.
    #[serde(default)]
    pub limits: Limits,
}

/// Bounds on what a training run reads, checked before the memory is spent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// The most frames in the sequence.
    pub max_frames: usize,
    /// The most pixels over all frames.
    pub max_total_pixels: u64,
    /// The most pixels of one frame (or artwork layer).
    pub max_image_pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_frames: crate::puppet::sequence::DEFAULT_MAX_FRAMES,
            max_total_pixels: crate::puppet::sequence::DEFAULT_MAX_TOTAL_PIXELS,
            max_image_pixels: crate::picture::DEFAULT_MAX_PIXELS,
        }
    }
}

/// The network settings a config may change (the rest are the paper's).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelSettings {
    /// Working resolution S (frames are letterboxed into S×S).
    pub input_size: usize,
    /// Latent size (paper: 512).
    pub latent: usize,
    /// Output scale of the decoder in working pixels.
    pub offset_scale: f32,
    /// Accessory layers follow the body through their rig (accessory-rigs.md) and the network
    /// predicts the body only; `false`: accessories are free layers of the network, hinged where
    /// they touch the body (the behaviour before rigs). Written only when `false`, so configs of
    /// runs from before the setting still resume.
    #[serde(skip_serializing_if = "is_true")]
    pub rig: bool,
}

fn is_true(b: &bool) -> bool {
    *b
}

impl Default for ModelSettings {
    fn default() -> Self {
        ModelSettings {
            input_size: 128,
            latent: 512,
            offset_scale: 16.0,
            rig: true,
        }
    }
}

/// Optimisation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainSettings {
    /// Optimiser steps.
    pub steps: u64,
    /// Frames per step (sampled without replacement, reshuffled every pass).
    pub batch: usize,
    /// Adam's step size (at the first step, when `learning_rate_end` is set).
    pub learning_rate: f64,
    /// If set, the step size falls from `learning_rate` to this along a half cosine over the run
    /// (a constant rate leaves the late fits jittering by Adam's step; decaying it settles them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub learning_rate_end: Option<f64>,
    /// Soft-rasterizer σ (px² of the working square) at the first and the last step; geometric
    /// in between. Wide early (gradients reach far), crisp late (sharp fits).
    pub sigma: [f32; 2],
    /// Steps between checkpoints (a killed run loses at most this many).
    pub checkpoint_every: u64,
    /// Steps between measurements of the loss on the held-out frames (logged and plotted).
    pub eval_every: u64,
    /// Adam's settings besides the learning rate.
    pub adam: AdamSettings,
    /// Poses the template draws itself, shown beside the drawn frames (off by default).
    #[serde(skip_serializing_if = "SampledPoses::is_off")]
    pub sampled: SampledPoses,
    /// The drawn frames moved and recoloured at each step (off by default).
    #[serde(skip_serializing_if = "Augment::is_off")]
    pub augment: Augment,
    /// The network's poses of the training frames pulled toward the prior's fits of them early in
    /// the run (off by default).
    #[serde(skip_serializing_if = "Guide::is_off")]
    pub guide: Guide,
}

impl Default for TrainSettings {
    fn default() -> Self {
        TrainSettings {
            steps: 2000,
            batch: 16,
            learning_rate: 1e-4,
            learning_rate_end: None,
            sigma: [4.0, 0.5],
            checkpoint_every: 100,
            eval_every: 100,
            adam: AdamSettings::new(),
            sampled: SampledPoses::default(),
            augment: Augment::default(),
            guide: Guide::default(),
        }
    }
}

/// The largest batch a config may ask for (memory grows with it; frames beyond the training set
/// repeat, see [`crate::train::trainer`]).
pub const MAX_BATCH: usize = 256;

/// `path` absolute, with links and `..` resolved: its longest existing ancestor canonically, the
/// rest (not yet created) lexically.
pub fn canonical(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = absolute.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(real) = std::fs::canonicalize(existing) {
            let mut out = real;
            for part in rest.iter().rev() {
                match part {
                    std::path::Component::ParentDir => {
                        out.pop();
                    }
                    std::path::Component::Normal(name) => out.push(name),
                    _ => {}
                }
            }
            return out;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                existing = parent;
            }
            _ => return absolute,
        }
    }
}

fn default_seed() -> u64 {
    1
}

fn default_test_fraction() -> f64 {
    0.3
}

/// Parses `text`, the TOML config file `path` (which only names it in errors), as a `T` and
/// checks it with `validate` (the appearance stage's and the parts network's configs, which hold
/// no paths to resolve).
///
/// # Errors
/// [`Error::Format`] naming `path` for TOML that does not parse or an unknown key; what
/// `validate` reports (e.g. [`Error::Setting`] for a value out of range), about `path`.
pub fn parse_checked<T: serde::de::DeserializeOwned>(text: &str, path: &Path, validate: impl FnOnce(&T) -> Result<()>) -> Result<T> {
    let config: T = toml::from_str(text).map_err(|e| Error::format(path, e.to_string()))?;
    validate(&config).map_err(|e| e.with_path(path))?;
    Ok(config)
}

impl TrainConfig {
    /// Reads `path`, resolves its relative paths against the file's folder (canonically, where
    /// they exist), and validates it.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::CONFIG`];
    /// [`Error::Format`] naming `path` for text that is not UTF-8, bad TOML or an unknown key;
    /// [`Error::Setting`] (about `path`) for an invalid value (see [`TrainConfig::validate`]).
    pub fn load(path: &Path) -> Result<Self> {
        let text = user_file::read_text(path, user_file::CONFIG)?;
        Self::parse(&text, path)
    }

    /// Parses the text of the config file `path` (relative paths in it are relative to the file's
    /// folder) and validates it.
    ///
    /// # Errors
    /// As [`TrainConfig::load`].
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let mut config: TrainConfig = toml::from_str(text).map_err(|e| Error::format(path, format!("invalid training config: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        for p in [&mut config.puppet, &mut config.frames, &mut config.output]
            .into_iter()
            .chain(config.start.as_mut())
        {
            if p.is_relative() {
                *p = base.join(&*p);
            }
            *p = canonical(p);
        }
        config.validate().at_path(path)?;
        Ok(config)
    }

    /// The settings used when no config file is given (`configs/train.toml`): every key but the
    /// three paths.
    pub const DEFAULT_SETTINGS: &'static str = include_str!("../../configs/train.toml");

    /// A config of `settings` (TOML text of every key but the paths, as
    /// [`TrainConfig::DEFAULT_SETTINGS`]; `source` names it in errors) for the given artwork or
    /// puppet, frames and output folder, each relative to the working directory.
    ///
    /// # Errors
    /// As [`TrainConfig::parse`]; [`Error::Format`] if `settings` names a path itself.
    pub fn with_paths(settings: &str, source: &Path, puppet: &Path, frames: &Path, output: &Path) -> Result<Self> {
        let mut table: toml::Table =
            toml::from_str(settings).map_err(|e| Error::format(source, format!("invalid training config: {e}")))?;
        for (key, path) in [("puppet", puppet), ("frames", frames), ("output", output)] {
            if table.contains_key(key) {
                return Err(Error::format(
                    source,
                    format!("names `{key}` itself, where the settings leave the paths to the caller"),
                ));
            }
            table.insert(key.into(), toml::Value::String(canonical(path).to_string_lossy().into_owned()));
        }
        let text = toml::to_string(&table).map_err(|e| Error::format(source, e.to_string()))?;
        Self::parse(&text, source)
    }

    /// This config with some of its paths replaced (each relative to the working directory).
    pub fn replacing_paths(mut self, puppet: Option<&Path>, frames: Option<&Path>, output: Option<&Path>) -> Self {
        for (field, new) in [(&mut self.puppet, puppet), (&mut self.frames, frames), (&mut self.output, output)] {
            if let Some(path) = new {
                *field = canonical(path);
            }
        }
        self
    }

    /// This config continuing the trained model `dir` ([`TrainConfig::start`]), with the guide
    /// off: the model's network already places its frames, and the guide is for one that starts
    /// untrained.
    pub fn continuing(mut self, dir: &Path) -> Self {
        self.start = Some(canonical(dir));
        self.train.guide = Guide::default();
        self
    }

    /// Checks values that TOML types cannot: ranges and the input size.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the key.
    pub fn validate(&self) -> Result<()> {
        let t = &self.train;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let checks = [
            (
                !(0.0..1.0).contains(&self.test_fraction),
                Error::setting("test_fraction", self.test_fraction, "in [0, 1)"),
            ),
            (t.steps == 0, Error::setting("train.steps", 0, "positive")),
            (
                !(1..=MAX_BATCH).contains(&t.batch),
                Error::setting("train.batch", t.batch, format!("from 1 to {MAX_BATCH}")),
            ),
            (t.checkpoint_every == 0, Error::setting("train.checkpoint_every", 0, "positive")),
            (t.eval_every == 0, Error::setting("train.eval_every", 0, "positive")),
            (
                !positive(t.learning_rate),
                Error::setting("train.learning_rate", t.learning_rate, "positive"),
            ),
            (
                t.learning_rate_end.is_some_and(|e| !positive(e)),
                Error::setting("train.learning_rate_end", t.learning_rate_end.unwrap_or(f64::NAN), "positive"),
            ),
            (
                !t.sigma.iter().all(|s| s.is_finite() && *s > 0.0),
                Error::setting("train.sigma", format!("{:?}", t.sigma), "two positive numbers"),
            ),
            (
                ![self.loss.arap, self.loss.joints, self.loss.area]
                    .iter()
                    .all(|w| w.is_finite() && *w >= 0.0),
                Error::setting(
                    "loss",
                    format!("[{}, {}, {}]", self.loss.arap, self.loss.joints, self.loss.area),
                    "weights that are finite and ≥ 0",
                ),
            ),
        ];
        if let Some((_, problem)) = checks.into_iter().find(|(bad, _)| *bad) {
            return Err(problem);
        }
        // The `[model]` keys are checked as the network the run will build (with one vertex: a
        // lower bound on its size), so a network that cannot fit is refused here, naming the file.
        DeformationNetConfig::new(1)
            .with_input_size(self.model.input_size)
            .with_latent(self.model.latent)
            .with_offset_scale(self.model.offset_scale)
            .validate()
            .map_err(|e| match e {
                Error::Setting { name, value, expected } => Error::Setting {
                    name: format!("model.{name}"),
                    value,
                    expected,
                },
                other => other,
            })?;
        t.adam.validate()?;
        t.sampled.validate()?;
        t.augment.validate()?;
        t.guide.validate()
    }

    /// The frame checks of this run for frames of a `width` × `height` puppet.
    pub fn frame_check(&self, width: u32, height: u32) -> FrameCheck {
        FrameCheck {
            size: Some((width, height)),
            image: ImageLimits {
                max_pixels: self.limits.max_image_pixels,
            },
            max_frames: self.limits.max_frames,
            max_total_pixels: self.limits.max_total_pixels,
        }
    }

    /// σ at `step` of `steps` (geometric from `sigma[0]` to `sigma[1]`).
    pub fn sigma_at(&self, step: u64) -> f32 {
        let [a, b] = self.train.sigma;
        a * (b / a).powf(super::optim::run_progress(step, self.train.steps) as f32)
    }

    /// Adam's step size at `step`: constant, or a half cosine down to `learning_rate_end`.
    pub fn learning_rate_at(&self, step: u64) -> f64 {
        super::optim::learning_rate_at(self.train.learning_rate, self.train.learning_rate_end, step, self.train.steps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("train.toml");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    #[test]
    fn the_default_settings_are_the_robots_recipe_with_the_paths_given() {
        let dir = tempfile::tempdir().unwrap();
        let source = Path::new("configs/train.toml");
        let config = TrainConfig::with_paths(
            TrainConfig::DEFAULT_SETTINGS,
            source,
            &dir.path().join("art.psd"),
            &dir.path().join("frames"),
            &dir.path().join("run"),
        )
        .unwrap();
        assert_eq!(config.output, canonical(&dir.path().join("run")));
        let robot = TrainConfig::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/kenney-robot.toml"))).unwrap();
        let same = robot.replacing_paths(Some(&config.puppet), Some(&config.frames), Some(&config.output));
        assert_eq!(config, same, "configs/train.toml keeps configs/kenney-robot.toml's settings");
        let named = "output = \"x\"\n[train]\nsteps = 5\n";
        let err = TrainConfig::with_paths(named, source, Path::new("a"), Path::new("f"), Path::new("o")).unwrap_err();
        assert!(err.to_string().contains("names `output` itself"), "{err}");
    }

    #[test]
    fn defaults_fill_in_and_paths_resolve_against_the_file() {
        let (dir, path) = write("puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train]\nsteps = 10\n");
        let c = TrainConfig::load(&path).unwrap();
        assert_eq!(c.puppet, dir.path().join("p"));
        assert_eq!(c.train.steps, 10);
        assert_eq!(c.train.batch, 16);
        assert_eq!(c.loss.arap, 2500.0);
        assert!((c.sigma_at(0) - 4.0).abs() < 1e-6 && (c.sigma_at(9) - 0.5).abs() < 1e-6);
        assert!((c.sigma_at(3) - 4.0 * (0.125f32).powf(3.0 / 9.0)).abs() < 1e-5);
        assert_eq!(c.learning_rate_at(5), c.train.learning_rate, "constant unless an end is set");
        let mut d = c.clone();
        d.train.learning_rate_end = Some(1e-5);
        let lr = |s| d.learning_rate_at(s);
        assert!((lr(0) - 1e-4).abs() < 1e-12 && (lr(9) - 1e-5).abs() < 1e-12);
        assert!((lr(3) - (1e-5 + 9e-5 * 0.5 * (1.0 + (std::f64::consts::PI / 3.0).cos()))).abs() < 1e-12);
        assert!((1..10).all(|s| lr(s) < lr(s - 1)), "falls monotonically");
    }

    #[test]
    fn bad_values_and_unknown_keys_name_the_file_and_key() {
        for (text, needle) in [
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\ntest_fraction = 1.0\n",
                "test_fraction",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train]\nbatch = 0\n",
                "train.batch",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[model]\ninput_size = 100\n",
                "input_size",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[model]\ninput_size = 1024\n",
                "model.weights",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[model]\noffset_scale = -1.0\n",
                "model.offset_scale",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train]\nlearning_rat = 1\n",
                "learning_rat",
            ),
            ("frames = \"f\"\noutput = \"o\"\n", "puppet"),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train]\nbatch = 100000\n",
                "from 1 to 256",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train.adam]\nbeta_1 = 1.5\n",
                "adam.beta_1",
            ),
            (
                "puppet = \"p\"\nframes = \"f\"\noutput = \"o\"\n[train.adam]\nbeta1 = 0.5\n",
                "beta1",
            ),
        ] {
            let (_dir, path) = write(text);
            let err = TrainConfig::load(&path).unwrap_err().to_string();
            assert!(err.contains("train.toml") && err.contains(needle), "{text:?} → {err}");
        }
    }
}
