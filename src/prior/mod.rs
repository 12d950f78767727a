//! The character-agnostic prior (issue 56; prior-design.md): one correspondence network trained
//! once on many drawn characters posed by the posing engine, each pose with its exact truth,
//! and shipped with puppet. It says where a point of one frame of a character lands in another
//! frame of it — above all, where each point of the rest pose is in a new frame — for a
//! character it never saw.
//!
//! The network is the one APES parts use ([`crate::model::correspondence`]: a gated U-Net to
//! unit features, trained with InfoNCE by [`crate::parts::learn`]); what is new is what it
//! learns from: [`pairs`] of real artwork posed with exact truth instead of the generator's
//! figures alone.

pub mod pairs;
pub mod place;

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::fit::{fit_from, fit_latents, FitOptions};
use crate::metrics::l2;
use crate::model::deformation::DeformationNetConfig;
use crate::model::Model;
use crate::parts::learn::{train_correspondence, LearnConfig, LearnOptions, LearnSummary, PairSource};
use crate::parts::matching::{features, nearest_scored, Foreground, WorkingPose};
use crate::parts::pose::SheetPose;
use crate::picture::{ImageLimits, Picture};
use crate::posing::{EngineSettings, PoseEngine};
use crate::progress::Progress;
use crate::puppet::Puppet;
use crate::render::render_crisp;
use crate::train::config::canonical;
use crate::train::guide::UntrainedFit;
use crate::train::trainer::load_or_build_puppet;
use crate::user_file;
use pairs::{MixedPairs, PosedPairs};

/// The prior is a correspondence network of the kind `puppet parts` uses (its trained weights
/// and working size).
pub use crate::parts::learn::TrainedNet;

/// Added to the seed for the held-out pairs: poses no training pair shows.
const HELD_OUT_SEEDS: u64 = 1 << 40;

/// The most characters a config may list.
const MAX_CHARACTERS: usize = 10_000;

/// The prior's training config (`puppet prior train configs/prior.toml`). Paths are relative to
/// the config file.
///
/// ```toml
/// characters = ["../data/rigs/dicebear/personas-1"]   # artwork or puppet folders posed for training
/// held_out = ["../data/rigs/dicebear/personas-6"]     # posed for the held-out score only
/// output = "../runs/prior"
/// rest_share = 0.5         # pairs whose first frame is the rest pose
/// generator_share = 0.25   # pairs drawn by the generator (`synth --varied`) instead
///
/// [engine]                 # how far poses go (puppet::EngineSettings)
/// max_degrees = 35.0
///
/// [net]                    # the network and its training (puppet train-parts' config)
/// steps = 3000
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorConfig {
    /// Characters posed for training.
    pub characters: Vec<PathBuf>,
    /// Characters posed for the held-out score, never trained on.
    pub held_out: Vec<PathBuf>,
    /// The run folder.
    pub output: PathBuf,
    /// The share of pairs whose first frame is the rest pose.
    #[serde(default = "half")]
    pub rest_share: f32,
    /// The share of pairs from the generator.
    #[serde(default)]
    pub generator_share: f32,
    /// How far the engine poses the characters.
    #[serde(default)]
    pub engine: EngineSettings,
    /// The network and its training.
    #[serde(default)]
    pub net: LearnConfig,
}

fn half() -> f32 {
    0.5
}

impl PriorConfig {
    /// Reads `path`, resolves its relative paths against the file's folder (canonically, where
    /// they exist), and validates it.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::CONFIG`]; as
    /// [`PriorConfig::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses the text of the config file `path` (relative paths in it are relative to the
    /// file's folder) and validates it.
    ///
    /// # Errors
    /// [`Error::Format`] naming `path` for bad TOML or an unknown key; as
    /// [`PriorConfig::validate`].
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let mut config: PriorConfig = toml::from_str(text).map_err(|e| Error::format(path, format!("invalid prior config: {e}")))?;
        config.validate().map_err(|e| e.with_path(path))?;
        let base = path.parent().unwrap_or(Path::new("."));
        for p in config.characters.iter_mut().chain(&mut config.held_out).chain([&mut config.output]) {
            if p.is_relative() {
                *p = base.join(&*p);
            }
            *p = canonical(p);
        }
        config.net.resolve_paths(path);
        Ok(config)
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the key, its value and what it must be.
    pub fn validate(&self) -> Result<()> {
        for (key, list) in [("characters", &self.characters), ("held_out", &self.held_out)] {
            if list.is_empty() || list.len() > MAX_CHARACTERS {
                return Err(Error::setting(
                    key,
                    list.len(),
                    format!("a list of 1 to {MAX_CHARACTERS} characters"),
                ));
            }
        }
        if let Some(shared) = self.held_out.iter().find(|p| self.characters.contains(p)) {
            return Err(Error::setting(
                "held_out",
                shared.display(),
                "characters not also in `characters` (a held-out score must not be trained on)",
            ));
        }
        for (key, share) in [("rest_share", self.rest_share), ("generator_share", self.generator_share)] {
            if !(0.0..=1.0).contains(&share) {
                return Err(Error::setting(key, share, "a share from 0 to 1"));
            }
        }
        self.engine.validate()?;
        self.net.validate()
    }
}

/// Trains the prior into `config.output`: pairs of the configured characters posed by the
/// engine, mixed with `generator`'s pairs at `generator_share` (the generator sits above this
/// layer, so the caller makes them), scored on pairs of the held-out characters.
///
/// # Errors
/// Whatever building a character reports, naming it; as [`train_correspondence`].
pub fn train_prior(
    config: &PriorConfig,
    generator: &dyn PairSource,
    options: &LearnOptions,
    progress: &dyn Progress,
) -> Result<LearnSummary> {
    config.validate()?;
    let size = config.net.input_size as u32;
    let engines = |paths: &[PathBuf]| -> Result<Vec<PoseEngine>> {
        paths
            .iter()
            .map(|path| {
                let puppet = load_or_build_puppet(path, &ImageLimits::default(), true, progress).map_err(|e| e.with_path(path))?;
                PoseEngine::new(&puppet, config.engine.clone())
            })
            .collect()
    };
    let posed = PosedPairs {
        engines: engines(&config.characters)?,
        size,
        seed: config.net.seed,
        rest_share: config.rest_share,
    };
    let train = MixedPairs {
        main: &posed,
        other: generator,
        other_share: config.generator_share,
        seed: config.net.seed,
    };
    // Held-out pairs: other characters, other seeds.
    let held_out = PosedPairs {
        engines: engines(&config.held_out)?,
        size,
        seed: config.net.seed.wrapping_add(HELD_OUT_SEEDS),
        rest_share: config.rest_share,
    };
    let mut data = serde_json::Map::new();
    for (key, value) in [
        ("characters", serde_json::to_value(&config.characters)),
        ("held_out", serde_json::to_value(&config.held_out)),
        ("rest_share", serde_json::to_value(config.rest_share)),
        ("generator_share", serde_json::to_value(config.generator_share)),
        ("engine", serde_json::to_value(&config.engine)),
    ] {
        data.insert(key.into(), value.map_err(|e| Error::format(&config.output, e.to_string()))?);
    }
    train_correspondence(&config.output, &config.net, &train, &held_out, data, options, progress)
}

/// Where a point of one frame lands in another, by the network.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Landing {
    /// The point in the second frame (its pixels).
    pub at: [f32; 2],
    /// How alike the two features are (cosine, −1 to 1).
    pub similarity: f32,
}

/// Where each of `points` (pixels of `from`) lands in `to`: the centre of the pixel of `to`'s
/// character whose feature is nearest the point's. `None` for a point off `from`'s character
/// in the network's working square, or when `to` shows no character.
pub fn landings(net: &TrainedNet, from: &Picture, to: &Picture, points: &[[f32; 2]], device: &Device) -> Vec<Option<Landing>> {
    let [a, b] = [from, to].map(|p| WorkingPose::new(&SheetPose::new("", p.clone()), net.size));
    let s = net.size as usize;
    let cells: Vec<Option<usize>> = points
        .iter()
        .map(|&p| {
            let q = a.letterbox.to_work(p);
            let (x, y) = (q[0].floor(), q[1].floor());
            let inside = x >= 0.0 && y >= 0.0 && x < s as f32 && y < s as f32;
            inside.then(|| y as usize * s + x as usize).filter(|&i| a.mask[i])
        })
        .collect();
    let mut asked = vec![false; s * s];
    for &i in cells.iter().flatten() {
        asked[i] = true;
    }
    let f = features(&net.net, &[&a.planes, &b.planes], s, device);
    let channels = f[0].len() / (s * s);
    let matched = nearest_scored(
        &Foreground::new(&f[0], &asked, channels),
        &Foreground::new(&f[1], &b.mask, channels),
        device,
    );
    cells
        .iter()
        .map(|cell| {
            let (j, similarity) = matched[(*cell)?]?;
            Some(Landing {
                at: b.letterbox.to_frame([(j % s) as f32 + 0.5, (j / s) as f32 + 0.5]),
                similarity,
            })
        })
        .collect()
}

/// The prior puppet ships (data/prior/, built into the binary: trained by
/// `puppet prior train configs/prior.toml`).
///
/// # Errors
/// [`Error::Format`] if the built-in files do not make a network (a build from a broken
/// checkout).
pub fn shipped(device: &Device) -> Result<TrainedNet> {
    const SHAPE: &[u8] = include_bytes!("../../data/prior/net.json");
    const WEIGHTS: &[u8] = include_bytes!("../../data/prior/weights.bpk");
    TrainedNet::from_bytes(SHAPE, WEIGHTS.to_vec(), Path::new("data/prior (built in)"), device)
}

/// The prior trained in the run folder `dir` by `puppet prior train`, or without one
/// [`shipped`].
///
/// # Errors
/// As [`TrainedNet::load`] and [`shipped`].
pub fn load_or_shipped(dir: Option<&Path>, device: &Device) -> Result<TrainedNet> {
    match dir {
        Some(dir) => TrainedNet::load(dir, device),
        None => shipped(device),
    }
}

/// A model that carries a puppet's template and no learned network (a one-unit placeholder):
/// what the fit's latent-free stages need — the puppet, its working square, the rig's map — for
/// a character nobody trained, working at `input_size`².
///
/// # Errors
/// [`Error::Setting`] for a working size out of range.
pub fn template_model(puppet: Puppet, input_size: usize, device: &Device) -> Result<Model> {
    let config = DeformationNetConfig::new(puppet.free_vertices().len())
        .with_input_size(input_size)
        .with_channels([1, 1, 1])
        .with_encoder_hidden([1, 1])
        .with_latent(1)
        .with_decoder_hidden([1, 1]);
    Model::new(config, puppet, device)
}

/// The fits of [`fit_with_prior`].
#[derive(Clone, Debug, PartialEq)]
pub struct PriorFit {
    /// Every template vertex of each frame, frame pixels.
    pub poses: Vec<Vec<[f32; 2]>>,
    /// Where each frame's fit started.
    pub starts: Vec<Start>,
}

/// Where a frame's fit started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// The prior's placement.
    Prior,
    /// The per-character network's pass (and latent steps).
    Network,
}

/// Fits `frames` of `model`'s character from the prior's placements ([`place`](place::place)),
/// by the latent-free stages of `options` ([`fit_from`]); no network of the character is used,
/// so `model` may be a [`template_model`].
///
/// # Errors
/// As [`place::place`] (a frame of another size) and [`fit_from`].
pub fn fit_untrained(
    prior: &TrainedNet,
    model: &Model,
    frames: &[&Picture],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Vec<Vec<[f32; 2]>>> {
    let starts = placements(prior, model, frames, device)?;
    fit_from(model, frames, &starts, options, device, progress)
}

/// Fits `frames` with a trained `model` twice — from the network's pass and
/// `options.latent_steps` latent steps, and from the prior's placement, each then through the
/// latent-free stages of `options` — and keeps for each frame the fit that renders closer to it
/// (lower crisp L2): a frame is never fitted worse than without the prior, and a pose the
/// network was never shown can start where the prior puts it.
///
/// # Errors
/// As [`fit_latents`], [`place::place`] and [`fit_from`].
pub fn fit_with_prior(
    prior: &TrainedNet,
    model: &Model,
    frames: &[&Picture],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<PriorFit> {
    let network = model.to_frame_vertices(model.decode(fit_latents(model, frames, options, device)?, device));
    progress.stage("fit from the network", frames.len() as u64);
    let from_network = fit_from(model, frames, &network, options, device, progress)?;
    keep_closer(prior, model, frames, from_network, options, device, progress)
}

/// Fits `frames` from the prior's placement by the latent-free stages of `options` and keeps,
/// for each frame, whichever of that fit and `fitted` (the network's fit of it, every template
/// vertex, frame pixels) renders closer to it (lower crisp L2).
///
/// # Errors
/// As [`place::place`] and [`fit_from`]; [`Error::Mismatch`] if `fitted` does not hold one
/// pose per frame.
pub fn keep_closer(
    prior: &TrainedNet,
    model: &Model,
    frames: &[&Picture],
    fitted: Vec<Vec<[f32; 2]>>,
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<PriorFit> {
    if fitted.len() != frames.len() {
        return Err(Error::mismatch(
            "the fits to compare with the prior's",
            fitted.len(),
            format!("{} frames", frames.len()),
        ));
    }
    progress.stage("fit from the prior", frames.len() as u64);
    let from_prior = fit_from(model, frames, &placements(prior, model, frames, device)?, options, device, progress)?;
    let puppet = &model.puppet;
    let mut fit = PriorFit {
        poses: Vec::with_capacity(frames.len()),
        starts: Vec::with_capacity(frames.len()),
    };
    for ((frame, network), prior) in frames.iter().zip(fitted).zip(from_prior) {
        let score = |pose: &[[f32; 2]]| -> Result<f64> { Ok(l2(&render_crisp(puppet, pose, puppet.width, puppet.height)?, frame)) };
        let (pose, start) = if score(&prior)? < score(&network)? {
            (prior, Start::Prior)
        } else {
            (network, Start::Network)
        };
        fit.poses.push(pose);
        fit.starts.push(start);
    }
    Ok(fit)
}

/// The prior's zero-shot fit ([`fit_untrained`]) as the fit `[train.guide]` pulls a network
/// toward: `puppet train --prior`.
pub struct PriorGuide {
    net: TrainedNet,
    options: FitOptions,
    device: Device,
}

impl PriorGuide {
    /// The guide of prior `net`, fitting by `options`' latent-free stages on `device`.
    pub fn new(net: TrainedNet, options: FitOptions, device: Device) -> Self {
        PriorGuide { net, options, device }
    }
}

impl std::fmt::Debug for PriorGuide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PriorGuide").field("options", &self.options).finish_non_exhaustive()
    }
}

impl UntrainedFit for PriorGuide {
    fn fit(&self, model: &Model, frames: &[&Picture], progress: &dyn Progress) -> Result<Vec<Vec<[f32; 2]>>> {
        fit_untrained(&self.net, model, frames, &self.options, &self.device, progress)
    }
}

/// The prior's placement of each frame, the body's free vertices as the model's stages take
/// them (the rig places the accessories).
fn placements(prior: &TrainedNet, model: &Model, frames: &[&Picture], device: &Device) -> Result<Vec<Vec<[f32; 2]>>> {
    let rest = place::RestPose::new(&model.puppet)?;
    frames.iter().map(|frame| Ok(rest.place(prior, frame, device)?.vertices)).collect()
}
