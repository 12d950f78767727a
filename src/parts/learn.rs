//! Training the correspondence network (apes-part-extraction.md §3.1) with InfoNCE: for pairs
//! of poses of one character with known correspondences, each sampled pixel of one pose must
//! pick its true match in the other out of that match and many other pixels of the other pose,
//! by feature similarity over a temperature. Both directions of every pair count.
//!
//! Pairs come from a [`PairSource`] (the generator's sprite sheets, `synth`), indexed, so a
//! resumed run sees what an uninterrupted one would. Seeded, logged (with the held-out pairs'
//! match accuracy), checkpointed atomically, resumable, stopped on NaN — as the other trainers.
//!
//! A model folder: `config.toml`, `net.json` (the network's shape), `weights.bpk` (the newest
//! weights), `log.csv`, `curves.png`, `checkpoints/`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Int, Tensor, TensorData};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::matching::{features, nearest, Foreground};
use crate::atomic_file::{record, write_atomic, Outputs};
use crate::backend::scalar;
use crate::error::{Error, Result};
use crate::model::bundle::{load_weights, max_weights_bytes, weights_bytes};
use crate::model::correspondence::{CorrespondenceNet, CorrespondenceNetConfig};
use crate::objective::info_nce::{info_nce, Term};
use crate::progress::Progress;
use crate::rng::Rng;
use crate::train::checkpoint::{self, Checkpoint, CheckpointState, OPTIMIZER, WEIGHTS};
use crate::train::log::{plot_curves, CsvRow, Curve, TrainLog};
use crate::train::optim::{adam, learning_rate_at, optimizer_bytes, optimizer_from_bytes, AdamSettings};
use crate::user_file;

/// Two poses of one character in the network's working square, with the pixels of the first
/// whose point shows in the second.
#[derive(Clone, Debug)]
pub struct TrainingPair {
    /// The first pose's premultiplied planes `[4, S, S]`.
    pub a: Vec<f32>,
    /// The second's.
    pub b: Vec<f32>,
    /// (pixel of `a`, pixel of `b` showing the same point), row-major working indices.
    pub matches: Vec<[u32; 2]>,
    /// The working pixels of `a` and of `b` on the character.
    pub masks: [Vec<bool>; 2],
}

/// Where training pairs come from: pair `index` is always the same pair.
pub trait PairSource: Sync {
    /// The working size S of its pairs.
    fn size(&self) -> usize;
    /// Pair number `index`.
    ///
    /// # Errors
    /// Whatever making the pair reports.
    fn pair(&self, index: u64) -> Result<TrainingPair>;
}

/// The training config (`puppet train-parts -o DIR [config.toml]`). Every key is optional:
///
/// ```toml
/// steps = 3000            # optimiser steps
/// batch = 4               # pairs per step
/// anchors = 256           # sampled matched pixels per pair and direction
/// negatives = 1024        # other pixels of the other pose each anchor is told apart from
/// temperature = 0.07      # InfoNCE's τ (the usual value; APES does not give one)
/// learning_rate = 1e-3
/// learning_rate_end = 1e-5 # optional: half-cosine decay to this by the last step
/// seed = 1
/// held_out = 16           # pairs scored every eval_every steps
/// checkpoint_every = 100
/// eval_every = 100
/// features = 32           # the network: feature length, channels, downsamplings
/// base_channels = 16
/// max_channels = 64
/// depth = 5
/// input_size = 128
/// varied = false          # train on characters of wider variety (`puppet synth --varied`)
///
/// [adam]
/// beta_1 = 0.9
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LearnConfig {
    /// Optimiser steps.
    pub steps: u64,
    /// Pairs per step.
    pub batch: usize,
    /// Matched pixels sampled per pair and direction.
    pub anchors: usize,
    /// Pixels of the other pose each anchor's match is told apart from.
    pub negatives: usize,
    /// InfoNCE temperature.
    pub temperature: f64,
    /// Adam's learning rate (at the first step, when `learning_rate_end` is set).
    pub learning_rate: f64,
    /// If set, the learning rate falls from `learning_rate` to this along a half cosine over
    /// the run; constant otherwise.
    pub learning_rate_end: Option<f64>,
    /// Seeds the weights and the sampling.
    pub seed: u64,
    /// Held-out pairs scored during training.
    pub held_out: usize,
    /// Steps between checkpoints.
    pub checkpoint_every: u64,
    /// Steps between held-out scores.
    pub eval_every: u64,
    /// Feature length.
    pub features: usize,
    /// Channels of the first block.
    pub base_channels: usize,
    /// The channel ceiling.
    pub max_channels: usize,
    /// Downsamplings.
    pub depth: usize,
    /// Working size S.
    pub input_size: usize,
    /// Pairs of characters of wider variety (half bodies, robots, front views, held objects,
    /// accessories) instead of the one humanoid, for training and held-out pairs alike.
    pub varied: bool,
    /// The optimiser.
    pub adam: AdamSettings,
}

impl Default for LearnConfig {
    fn default() -> Self {
        let net = CorrespondenceNetConfig::new();
        LearnConfig {
            steps: 3000,
            batch: 4,
            anchors: 256,
            negatives: 1024,
            temperature: 0.07,
            learning_rate: 1e-3,
            learning_rate_end: None,
            seed: 1,
            held_out: 16,
            checkpoint_every: 100,
            eval_every: 100,
            features: net.features,
            base_channels: net.base_channels,
            max_channels: net.max_channels,
            depth: net.depth,
            input_size: net.input_size,
            varied: false,
            adam: AdamSettings::default(),
        }
    }
}

impl LearnConfig {
    /// Reads and checks a config file.
    ///
    /// # Errors
    /// [`Error::Io`]/[`Error::Format`] naming the file; [`Error::Setting`] for a bad value.
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses and checks config text read from `path` (named in errors).
    ///
    /// # Errors
    /// As [`LearnConfig::load`], but reading.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let config: LearnConfig = toml::from_str(text).map_err(|e| Error::format(path, e.to_string()))?;
        config.validate().map_err(|e| e.with_path(path))?;
        Ok(config)
    }

    /// The network it trains.
    pub fn net(&self) -> CorrespondenceNetConfig {
        CorrespondenceNetConfig::new()
            .with_input_size(self.input_size)
            .with_base_channels(self.base_channels)
            .with_max_channels(self.max_channels)
            .with_depth(self.depth)
            .with_features(self.features)
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the key, its value and what it must be.
    pub fn validate(&self) -> Result<()> {
        let end = self.learning_rate_end.map(|v| ("learning_rate_end", v));
        for (key, value) in [("temperature", self.temperature), ("learning_rate", self.learning_rate)]
            .into_iter()
            .chain(end)
        {
            if !(value > 0.0 && value.is_finite()) {
                return Err(Error::setting(key, value, "a positive number"));
            }
        }
        for (key, value, most) in [
            ("steps", self.steps, 10_000_000),
            ("batch", self.batch as u64, 64),
            ("anchors", self.anchors as u64, 4096),
            ("negatives", self.negatives as u64, 16384),
            ("held_out", self.held_out as u64, 1024),
            ("checkpoint_every", self.checkpoint_every, u64::MAX),
            ("eval_every", self.eval_every, u64::MAX),
        ] {
            if value == 0 || value > most {
                return Err(Error::setting(key, value, format!("1 to {most}")));
            }
        }
        self.net().validate()?;
        self.adam.validate()
    }
}

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct LearnOptions {
    /// Continue from the latest checkpoint.
    pub resume: bool,
    /// Pause after this many steps in total (checkpointed, resumable).
    pub pause_at: Option<u64>,
}

/// Match quality on held-out pairs: each matched pixel of the first pose goes to its nearest
/// feature in the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchScore {
    /// Share landing within 2 working pixels of the truth.
    pub within_2px: f64,
    /// Mean distance from the truth, working pixels.
    pub mean_error: f64,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct LearnSummary {
    /// Steps done in total.
    pub steps: u64,
    /// Whether all configured steps are done.
    pub finished: bool,
    /// Training seconds in total.
    pub seconds: f64,
    /// Pairs per second over this run's steps.
    pub pairs_per_second: f64,
    /// The held-out score at the end.
    pub held_out: MatchScore,
    /// The held-out score of the same network before training (its seeded initial weights).
    pub untrained: MatchScore,
    /// The network's parameters.
    pub parameters: usize,
}

/// One step's numbers in `log.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearnRow {
    /// Steps done.
    pub step: u64,
    /// Training seconds so far.
    pub seconds: f64,
    /// The InfoNCE loss.
    pub loss: f64,
    /// Held-out share within 2 px (NaN where not measured).
    pub within_2px: f64,
    /// Held-out mean error, px (NaN where not measured).
    pub mean_error: f64,
}

impl CsvRow for LearnRow {
    const HEADER: &'static str = "step,seconds,loss,held_out_within_2px,held_out_mean_error";
    const MIN_COLUMNS: usize = 5;

    fn step(&self) -> u64 {
        self.step
    }

    fn values(&self) -> Vec<f64> {
        vec![self.step as f64, self.seconds, self.loss, self.within_2px, self.mean_error]
    }

    fn from_values(v: &[f64]) -> Self {
        LearnRow {
            step: v[0] as u64,
            seconds: v[1],
            loss: v[2],
            within_2px: v[3],
            mean_error: v[4],
        }
    }
}

/// The files of a correspondence model folder.
#[derive(Clone, Debug)]
pub struct NetFolder(PathBuf);

impl NetFolder {
    /// The folder `dir`.
    pub fn new(dir: &Path) -> Self {
        NetFolder(dir.to_path_buf())
    }
    fn config(&self) -> PathBuf {
        self.0.join("config.toml")
    }
    /// The network's shape.
    pub fn net(&self) -> PathBuf {
        self.0.join("net.json")
    }
    /// The newest weights.
    pub fn weights(&self) -> PathBuf {
        self.0.join(WEIGHTS)
    }
    fn log(&self) -> PathBuf {
        self.0.join("log.csv")
    }
    fn plot(&self) -> PathBuf {
        self.0.join("curves.png")
    }
}

/// A trained network and its working size.
#[derive(Clone, Debug)]
pub struct TrainedNet {
    /// The network (inference).
    pub net: CorrespondenceNet,
    /// Its working size S.
    pub size: u32,
}

impl TrainedNet {
    /// Reads a network from its shape (`net.json`) and weights (burnpack) bytes, `source`
    /// naming them in errors.
    ///
    /// # Errors
    /// [`Error::Format`] naming `source` if either is not what a trained network writes.
    pub fn from_bytes(shape: &[u8], weights: Vec<u8>, source: &Path, device: &Device) -> Result<Self> {
        let config = read_shape(shape, source)?;
        Ok(TrainedNet {
            net: load_weights(config.init(device), weights, source)?,
            size: config.input_size as u32,
        })
    }

    /// The network shipped with puppet (data/parts-net/, built into the binary: trained by
    /// `puppet train-parts configs/parts-net.toml`).
    ///
    /// # Errors
    /// [`Error::Format`] if the built-in files do not make a network (a build from a broken
    /// checkout).
    pub fn shipped(device: &Device) -> Result<Self> {
        const SHAPE: &[u8] = include_bytes!("../../data/parts-net/net.json");
        const WEIGHTS: &[u8] = include_bytes!("../../data/parts-net/weights.bpk");
        Self::from_bytes(SHAPE, WEIGHTS.to_vec(), Path::new("data/parts-net (built in)"), device)
    }

    /// Reads the network trained in `dir`.
    ///
    /// # Errors
    /// As [`TrainedNet::from_bytes`]; [`Error::Io`] naming a missing file.
    pub fn load(dir: &Path, device: &Device) -> Result<Self> {
        let folder = NetFolder::new(dir);
        let config = read_shape(&user_file::read_bytes(&folder.net(), user_file::CONFIG)?, &folder.net())?;
        let net = config.init(device);
        let weights = user_file::read_bytes(&folder.weights(), max_weights_bytes(&net))?;
        Ok(TrainedNet {
            net: load_weights(net, weights, &folder.weights())?,
            size: config.input_size as u32,
        })
    }
}

/// A network shape (`net.json`) read from `source`, checked before any network is built.
fn read_shape(bytes: &[u8], source: &Path) -> Result<CorrespondenceNetConfig> {
    let config: CorrespondenceNetConfig =
        serde_json::from_slice(bytes).map_err(|e| Error::format(source, format!("not a network shape: {e}")))?;
    config.validate().map_err(|e| e.with_path(source))?;
    Ok(config)
}

/// Trains a correspondence network in `dir` on pairs from `train`, scoring pairs from
/// `held_out`.
///
/// # Errors
/// [`Error::RunExists`] if `dir` has a checkpoint and resuming was not asked for;
/// [`Error::Resume`] for a resume without a checkpoint or with another config (only `steps`
/// may change) — neither writes anything; [`Error::Diverged`] for a loss that is not finite;
/// whatever making pairs or writing reports, naming the file.
pub fn train_correspondence(
    dir: &Path,
    config: &LearnConfig,
    train: &dyn PairSource,
    held_out: &dyn PairSource,
    options: &LearnOptions,
    progress: &dyn Progress,
) -> Result<LearnSummary> {
    config.validate()?;
    if train.size() != config.input_size || held_out.size() != config.input_size {
        return Err(Error::setting(
            "input_size",
            config.input_size,
            format!("the pairs' working size {}", train.size()),
        ));
    }
    let folder = NetFolder::new(dir);
    let previous = checkpoint::latest(dir)?.map(|d| checkpoint::load(&d)).transpose()?;
    let config_json = serde_json::to_value(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    checkpoint::check_run(dir, previous.as_ref(), options.resume)?;
    match &previous {
        Some(c) => checkpoint::check_same_config(dir, c, &config_json, &["steps"])?,
        None => Outputs::new(false).claim_folder(dir)?,
    }
    let held: Vec<TrainingPair> = (0..config.held_out as u64)
        .into_par_iter()
        .map(|i| held_out.pair(i))
        .collect::<Result<_>>()?;
    let net_config = config.net();
    let mut run = Trainer::new(config, &crate::backend::train_device());
    let untrained = run.score(&held);
    let (mut step, mut elapsed) = (0u64, 0f64);
    match &previous {
        Some(c) => {
            run.restore(c)?;
            (step, elapsed) = (c.state.step, c.state.elapsed);
        }
        None => {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
            let absolute = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
            record(&absolute)?;
            let json = serde_json::to_vec_pretty(&net_config).map_err(|e| Error::format(folder.net(), e.to_string()))?;
            write_atomic(&folder.net(), &json)?;
        }
    }
    let toml = toml::to_string_pretty(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    write_atomic(&folder.config(), toml.as_bytes())?;
    let mut log = TrainLog::<LearnRow>::open(&folder.log(), step)?;
    let stop = options.pause_at.map_or(config.steps, |p| p.min(config.steps));
    progress.stage("correspondence network", config.steps);
    progress.resume(step);
    let (started, first) = (Instant::now(), step);
    let mut score = MatchScore {
        within_2px: f64::NAN,
        mean_error: f64::NAN,
    };
    let batch = |step: u64| -> Result<Vec<TrainingPair>> {
        (0..config.batch as u64)
            .into_par_iter()
            .map(|k| train.pair(step * config.batch as u64 + k))
            .collect()
    };
    let t0 = Instant::now();
    let mut pairs = if step < stop { batch(step)? } else { Vec::new() };
    elapsed += t0.elapsed().as_secs_f64();
    while step < stop {
        let t0 = Instant::now();
        // The next step's pairs are made while this one trains: the step leaves a core idle
        // for much of its time (Burn's operations between the kernels run on one).
        let (loss, next) = std::thread::scope(|scope| {
            let next = (step + 1 < stop).then(|| scope.spawn(|| batch(step + 1)));
            let loss = run.step(step, &pairs);
            let next = next.map(|handle| handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
            (loss, next)
        });
        let loss = loss?;
        if let Some(next) = next {
            pairs = next?;
        }
        step += 1;
        elapsed += t0.elapsed().as_secs_f64();
        let mut row = LearnRow {
            step,
            seconds: elapsed,
            loss,
            within_2px: f64::NAN,
            mean_error: f64::NAN,
        };
        if step % config.eval_every == 0 || step == config.steps {
            score = run.score(&held);
            (row.within_2px, row.mean_error) = (score.within_2px, score.mean_error);
        }
        log.push(row)?;
        progress.advance(1);
        progress.message(&format!("loss {loss:.3}, held-out within 2 px {:.3}", score.within_2px));
        if step % config.checkpoint_every == 0 && step < stop {
            save(&folder, &run, step, elapsed, &config_json, &log)?;
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    if score.within_2px.is_nan() {
        score = run.score(&held);
    }
    save(&folder, &run, step, elapsed, &config_json, &log)?;
    Ok(LearnSummary {
        steps: step,
        finished: step >= config.steps,
        seconds: elapsed,
        pairs_per_second: ((step - first) as usize * config.batch) as f64 / seconds.max(1e-9),
        held_out: score,
        untrained,
        parameters: run.net().num_params(),
    })
}

fn save(folder: &NetFolder, run: &Trainer, step: u64, elapsed: f64, config: &serde_json::Value, log: &TrainLog<LearnRow>) -> Result<()> {
    let weights = weights_bytes(run.net(), &folder.0)?;
    let optimizer = optimizer_bytes(&run.optimizer, &folder.0)?;
    let state = CheckpointState {
        step,
        elapsed,
        config: config.clone(),
    };
    checkpoint::save(&folder.0, &state, &[(WEIGHTS, &weights), (OPTIMIZER, &optimizer)])?;
    write_atomic(&folder.weights(), &weights)?;
    let rows = log.rows();
    let steps: Vec<u64> = rows.iter().map(|r| r.step).collect();
    let curve = |name, colour, value: fn(&LearnRow) -> f64| Curve {
        name,
        colour,
        values: rows.iter().map(value).collect(),
    };
    plot_curves(
        &steps,
        &[
            curve("loss", [0.0, 0.0, 0.0], |r| r.loss),
            curve("held-out within 2 px", [0.1, 0.35, 0.9], |r| r.within_2px),
            curve("held-out mean error / 10", [0.85, 0.1, 0.1], |r| r.mean_error / 10.0),
        ],
    )
    .save_png(&folder.plot())
}

/// The network and optimiser under training: one [`Trainer::step`] is one optimiser step on a
/// batch of pairs (what `benches/parts.rs` times).
pub struct Trainer {
    /// Always `Some` between steps (taken so the optimiser holds the only reference).
    net: Option<CorrespondenceNet>,
    optimizer: ModuleOptimizer,
    config: LearnConfig,
    device: Device,
}

impl Trainer {
    /// A fresh network of `config` (seeded) and its optimiser, on the training `device`.
    pub fn new(config: &LearnConfig, device: &Device) -> Self {
        device.seed(config.seed);
        Trainer {
            net: Some(config.net().init(device)),
            optimizer: adam(&config.adam),
            config: config.clone(),
            device: device.clone(),
        }
    }

    fn net(&self) -> &CorrespondenceNet {
        self.net.as_ref().expect("a network between steps")
    }

    /// Optimiser step number `step` (from 0; it seeds the sampling) on `pairs`; returns the loss.
    ///
    /// # Errors
    /// [`Error::Diverged`] for a loss that is not finite; [`Error::Format`] if no pair has a
    /// matched pixel.
    pub fn step(&mut self, step: u64, pairs: &[TrainingPair]) -> Result<f64> {
        let mut rng = Rng::new(self.config.seed).fork(step);
        let s = self.config.input_size;
        let n = pairs.len();
        let data: Vec<f32> = pairs
            .iter()
            .flat_map(|p| p.a.iter())
            .chain(pairs.iter().flat_map(|p| p.b.iter()))
            .copied()
            .collect();
        let x = Tensor::<4>::from_data(TensorData::new(data, [2 * n, 4, s, s]), &self.device);
        // The batch's raw features, flat in their own `[2n, F, S²]` order: the loss gathers the
        // few pixels it samples in one selection and normalises only those (the same values as
        // selecting from unit features, without normalising and back-propagating every pixel of
        // the batch, and without transposing the batch to pixel-major rows and back).
        let channels = self.config.features;
        let plane = s * s;
        let features = self.net().raw_forward(x).reshape([2 * n * channels * plane]);
        let mut samples = Vec::new();
        for (k, pair) in pairs.iter().enumerate() {
            let flipped: Vec<[u32; 2]> = pair.matches.iter().map(|m| [m[1], m[0]]).collect();
            for (from, to, matches, mask) in [(k, n + k, &pair.matches, &pair.masks[1]), (n + k, k, &flipped, &pair.masks[0])] {
                let offsets = [from * s * s, to * s * s];
                if let Some(sample) = self.sample(matches, mask, offsets, &mut rng) {
                    samples.push(sample);
                }
            }
        }
        if samples.is_empty() {
            return Err(Error::format(
                "training pairs",
                format!("step {}: no pair has a matched pixel", step + 1),
            ));
        }
        let rows = samples.iter().flat_map(|t| t.sources.iter().chain(&t.candidates)).copied();
        let indices = feature_indices(rows, channels, plane);
        let count = indices.len();
        let picked = Tensor::<1, Int>::from_data(TensorData::new(indices, [count]), &self.device);
        let gathered = features.select(0, picked).reshape([count / channels, channels]);
        let mut start = 0;
        let terms: Vec<Term> = samples
            .iter()
            .map(|sample| {
                let term = Term {
                    start,
                    anchors: sample.sources.len(),
                    candidates: sample.candidates.len(),
                };
                start += term.anchors + term.candidates;
                term
            })
            .collect();
        let loss = info_nce(gathered, &terms, self.config.temperature as f32)?;
        let value = scalar(&loss);
        if !value.is_finite() {
            return Err(Error::Diverged {
                step: step + 1,
                losses: format!("InfoNCE {value}"),
                checkpoint: None,
            });
        }
        let net = self.net.take().expect("a network between steps");
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        let c = &self.config;
        let rate = learning_rate_at(c.learning_rate, c.learning_rate_end, step, c.steps);
        self.net = Some(self.optimizer.step(rate, net, grads));
        Ok(value)
    }

    /// Samples one InfoNCE term's pixels: anchors drawn from `matches` (pixel of the first
    /// image, pixel of the second), each with its match and, shared by all, negatives drawn from
    /// the second image's character pixels `mask`. `offsets` place the two images' pixels among
    /// the batch's rows.
    fn sample(&self, matches: &[[u32; 2]], mask: &[bool], offsets: [usize; 2], rng: &mut Rng) -> Option<Sample> {
        let foreground: Vec<u32> = (0..mask.len() as u32).filter(|&i| mask[i as usize]).collect();
        if matches.is_empty() || foreground.is_empty() {
            return None;
        }
        let anchors = self.config.anchors.min(matches.len());
        let picked: Vec<[u32; 2]> = (0..anchors).map(|_| matches[rng.below(matches.len())]).collect();
        let row = |offset: usize, pixel: u32| (offset + pixel as usize) as i64;
        Some(Sample {
            sources: picked.iter().map(|m| row(offsets[0], m[0])).collect(),
            candidates: picked
                .iter()
                .map(|m| row(offsets[1], m[1]))
                .chain((0..self.config.negatives).map(|_| row(offsets[1], foreground[rng.below(foreground.len())])))
                .collect(),
        })
    }

    /// The held-out pairs' match score with the current weights.
    fn score(&self, pairs: &[TrainingPair]) -> MatchScore {
        let device = crate::backend::device();
        let net = self.net().valid();
        let s = self.config.input_size;
        let (mut near, mut total, mut error) = (0usize, 0usize, 0f64);
        for pair in pairs {
            let f = features(&net, &[&pair.a, &pair.b], s, &device);
            let channels = self.config.features;
            let matched = nearest(
                &Foreground::new(&f[0], &pair.masks[0], channels),
                &Foreground::new(&f[1], &pair.masks[1], channels),
                &device,
            );
            for m in &pair.matches {
                let Some(q) = matched[m[0] as usize] else { continue };
                let t = m[1] as usize;
                let d = ((q % s) as f64 - (t % s) as f64).hypot((q / s) as f64 - (t / s) as f64);
                near += usize::from(d <= 2.0);
                error += d;
                total += 1;
            }
        }
        let n = total.max(1) as f64;
        MatchScore {
            within_2px: near as f64 / n,
            mean_error: error / n,
        }
    }

    fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()> {
        let dir = &checkpoint.dir;
        let limit = max_weights_bytes(self.net());
        let net = load_weights(self.net().clone(), checkpoint.file(WEIGHTS, limit)?, &dir.join(WEIGHTS))?;
        self.net = Some(net);
        self.optimizer = optimizer_from_bytes(&self.optimizer, checkpoint.file(OPTIMIZER, 2 * limit)?, &dir.join(OPTIMIZER))?;
        Ok(())
    }
}

/// Where the features of each of `rows` lie in a flat `[B, F, P]` tensor of `channels` (F)
/// features per pixel: row r is pixel r % P of image r / P, and its feature f lies at
/// (image·F + f)·P + pixel. Row by row, the F features of each.
fn feature_indices(rows: impl Iterator<Item = i64>, channels: usize, plane: usize) -> Vec<i64> {
    let (channels, plane) = (channels as i64, plane as i64);
    rows.flat_map(|row| {
        let (image, pixel) = (row / plane, row % plane);
        (0..channels).map(move |f| (image * channels + f) * plane + pixel)
    })
    .collect()
}

/// One InfoNCE term's rows of the batch's features: its anchors, then their matches and the
/// negatives.
#[derive(Debug)]
struct Sample {
    sources: Vec<i64>,
    candidates: Vec<i64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Selecting the rows' features from the flat channel-first tensor gives what selecting
    /// rows of the pixel-major transpose gives.
    #[test]
    fn feature_indices_pick_the_rows_of_the_transpose() {
        let device = crate::backend::device();
        let (batch, channels, plane) = (3, 4, 5);
        let values: Vec<f32> = (0..batch * channels * plane).map(|i| (i * 37 % 101) as f32).collect();
        let features = Tensor::<3>::from_data(TensorData::new(values, [batch, channels, plane]), &device);
        let rows = [7i64, 0, 14, 9, 4];
        let pick = |indices: Vec<i64>| Tensor::<1, Int>::from_data(TensorData::new(indices.clone(), [indices.len()]), &device);
        let flat = features
            .clone()
            .reshape([batch * channels * plane])
            .select(0, pick(feature_indices(rows.into_iter(), channels, plane)))
            .reshape([rows.len(), channels]);
        let transposed = features
            .permute([0, 2, 1])
            .reshape([batch * plane, channels])
            .select(0, pick(rows.to_vec()));
        assert_eq!(flat.into_data(), transposed.into_data());
    }
}
