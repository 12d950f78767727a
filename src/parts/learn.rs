//! Training the correspondence network (apes-part-extraction.md §3.1) with InfoNCE: for pairs
//! of poses of one character with known correspondences, each sampled pixel of one pose must
//! pick its true match in the other out of that match and many other pixels of the other pose,
//! by feature similarity over a temperature. Both directions of every pair count.
//!
//! Pairs come from a [`PairSource`] (the generator's sprite sheets, `synth`), indexed, so a
//! resumed run sees what an uninterrupted one would. Seeded, and run by the training harness
//! ([`crate::train::harness`]: logged with the held-out pairs' match accuracy, checkpointed
//! atomically, resumable, stopped on NaN).
//!
//! A model folder: `config.toml`, `net.json` (the network's shape), `weights.bpk` (the newest
//! weights), `log.csv`, `curves.png`, `checkpoints/`.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Int, Tensor, TensorData};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::matching::{features, nearest, Foreground};
use crate::atomic_file::write_atomic;
use crate::backend::scalar;
use crate::error::{Error, Result};
use crate::model::bundle::{load_weights, max_weights_bytes, weights_bytes};
use crate::model::correspondence::{CorrespondenceNet, CorrespondenceNetConfig};
use crate::objective::info_nce::{info_nce, Term};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::rng::Rng;
use crate::train::checkpoint::{Checkpoint, OPTIMIZER, WEIGHTS};
use crate::train::config::{canonical, parse_checked};
use crate::train::harness::{Plan, Run, RunFolder};
use crate::train::log::{log_row, plot_rows};
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
/// start = "../data/parts-net"  # optional: start from this trained network's weights
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
    /// A trained network's folder (its `net.json` must be this config's network) whose weights
    /// training starts from instead of seeded ones: the prior starts from the parts network.
    pub start: Option<PathBuf>,
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
            start: None,
        }
    }
}

impl LearnConfig {
    /// Reads and checks a config file.
    ///
    /// # Errors
    /// [`Error::Io`]/[`Error::Limit`] naming the file; as [`LearnConfig::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses and checks the text of the config file `path` (a relative `start` is made
    /// relative to its folder).
    ///
    /// # Errors
    /// As [`parse_checked`], with [`LearnConfig::validate`].
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let mut config: LearnConfig = parse_checked(text, path, Self::validate)?;
        config.resolve_paths(path);
        Ok(config)
    }

    /// Makes a relative `start` relative to the folder of the config file `path`.
    pub fn resolve_paths(&mut self, path: &Path) {
        if let Some(start) = self.start.as_mut().filter(|s| s.is_relative()) {
            *start = canonical(&path.parent().unwrap_or(Path::new(".")).join(&*start));
        }
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
    /// The held-out score of the network before training: its seeded weights, or those of the
    /// network `start` names.
    pub untrained: MatchScore,
    /// The network's parameters.
    pub parameters: usize,
}

log_row! {
    /// One step's numbers in `log.csv`.
    pub struct LearnRow (min_columns = 5) {
        /// Steps done.
        step,
        /// Training seconds so far.
        seconds = "seconds",
        /// The InfoNCE loss.
        loss = "loss",
        /// Held-out share within 2 px (NaN where not measured).
        within_2px = "held_out_within_2px",
        /// Held-out mean error, px (NaN where not measured).
        mean_error = "held_out_mean_error",
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
/// `held_out`. `data` describes where the pairs come from beyond `config` (the prior's
/// characters): recorded beside it in `config.toml`, and held to on a resume.
///
/// # Errors
/// [`Error::RunExists`] if `dir` has a checkpoint and resuming was not asked for;
/// [`Error::Resume`] for a resume without a checkpoint or with another config (only `steps`
/// may change) — neither writes anything; [`Error::InUse`] while another process trains into
/// `dir`; [`Error::Diverged`] for a loss that is not finite;
/// whatever making pairs or writing reports, naming the file.
pub fn train_correspondence(
    dir: &Path,
    config: &LearnConfig,
    train: &dyn PairSource,
    held_out: &dyn PairSource,
    data: serde_json::Map<String, serde_json::Value>,
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
    let mut config_json = serde_json::to_value(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    if let Some(keys) = config_json.as_object_mut() {
        keys.extend(data);
    }
    let run = RunFolder::claim(dir, config_json.clone(), &["steps"], options.resume, false)?;
    let held: Vec<TrainingPair> = (0..config.held_out as u64)
        .into_par_iter()
        .map(|i| held_out.pair(i))
        .collect::<Result<_>>()?;
    let device = crate::backend::train_device();
    let mut trainer = CorrespondenceTrainer::new(config, &device);
    if let Some(start) = config.start.as_ref().filter(|_| run.previous().is_none()) {
        trainer.start_from(start)?;
    }
    let untrained = trainer.score(&held);
    let plan = Plan {
        stage: "correspondence network",
        steps: config.steps,
        pause_at: options.pause_at,
        checkpoint_every: config.checkpoint_every,
        eval_every: config.eval_every,
        per_step: config.batch,
        log: folder.log(),
        plot: folder.plot(),
    };
    let mut learning = Learning {
        trainer,
        train,
        held,
        next: None,
        stop: plan.stop(),
        score: MatchScore {
            within_2px: f64::NAN,
            mean_error: f64::NAN,
        },
    };
    match run.previous() {
        Some(_) => run.restore(&mut learning)?,
        None => {
            let json = serde_json::to_vec_pretty(&config.net()).map_err(|e| Error::format(folder.net(), e.to_string()))?;
            write_atomic(&folder.net(), &json)?;
        }
    }
    // TOML has no null: an unset optional key is left out, as a config file leaves it out.
    if let Some(keys) = config_json.as_object_mut() {
        keys.retain(|_, v| !v.is_null());
    }
    let toml = toml::to_string_pretty(&config_json).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    write_atomic(&folder.config(), toml.as_bytes())?;
    let summary = run.train(&mut learning, &plan, progress)?;
    if learning.score.within_2px.is_nan() {
        learning.score = learning.trainer.score(&learning.held);
    }
    Ok(LearnSummary {
        steps: summary.steps,
        finished: summary.finished,
        seconds: summary.seconds,
        pairs_per_second: summary.per_second,
        held_out: learning.score,
        untrained,
        parameters: learning.trainer.net().num_params(),
    })
}

/// A correspondence network's training as the harness runs it: the trainer, where its pairs
/// come from, and the held-out pairs with their newest score.
struct Learning<'a> {
    trainer: CorrespondenceTrainer,
    train: &'a dyn PairSource,
    held: Vec<TrainingPair>,
    /// The next step's pairs (its number and them), made while the step before trained.
    next: Option<(u64, Vec<TrainingPair>)>,
    /// The step count this session stops at (no pairs are made past it).
    stop: u64,
    score: MatchScore,
}

/// The pairs of step `step` of batches of `batch` from `source`: a function of the step alone.
fn batch_pairs(source: &dyn PairSource, batch: usize, step: u64) -> Result<Vec<TrainingPair>> {
    (0..batch as u64)
        .into_par_iter()
        .map(|k| source.pair(step * batch as u64 + k))
        .collect()
}

impl Run for Learning<'_> {
    type Row = LearnRow;
    const NEWEST: &'static [&'static str] = &[WEIGHTS];

    fn step(&mut self, step: u64) -> Result<LearnRow> {
        let (train, batch) = (self.train, self.trainer.config.batch);
        let pairs = match self.next.take() {
            Some((s, pairs)) if s == step => pairs,
            _ => batch_pairs(train, batch, step)?,
        };
        // The next step's pairs are made while this one trains: the step leaves a core idle
        // for much of its time (Burn's operations between the kernels run on one).
        let (loss, next) = std::thread::scope(|scope| {
            let next = (step + 1 < self.stop).then(|| scope.spawn(|| batch_pairs(train, batch, step + 1)));
            let loss = self.trainer.step(step, &pairs);
            let next = next.map(|handle| handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
            (loss, next)
        });
        let loss = loss?;
        if let Some(next) = next {
            self.next = Some((step + 1, next?));
        }
        Ok(LearnRow {
            step: step + 1,
            seconds: 0.0,
            loss,
            within_2px: f64::NAN,
            mean_error: f64::NAN,
        })
    }

    fn non_finite(&self, row: &LearnRow) -> Option<String> {
        (!row.loss.is_finite()).then(|| format!("InfoNCE {}", row.loss))
    }

    fn held_out(&mut self, _step: u64, row: &mut LearnRow) -> Result<()> {
        self.score = self.trainer.score(&self.held);
        (row.within_2px, row.mean_error) = (self.score.within_2px, self.score.mean_error);
        Ok(())
    }

    fn message(&self, row: &LearnRow) -> String {
        format!("loss {:.3}, held-out within 2 px {:.3}", row.loss, self.score.within_2px)
    }

    fn state_files(&self, dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>> {
        Ok(vec![
            (WEIGHTS, weights_bytes(self.trainer.net(), dir)?),
            (OPTIMIZER, optimizer_bytes(&self.trainer.optimizer, dir)?),
        ])
    }

    fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()> {
        self.trainer.restore(checkpoint)
    }

    fn plot(&self, rows: &[LearnRow]) -> Picture {
        plot_rows(
            rows,
            &[
                ("loss", [0.0, 0.0, 0.0], &|r| r.loss),
                ("held-out within 2 px", [0.1, 0.35, 0.9], &|r| r.within_2px),
                ("held-out mean error / 10", [0.85, 0.1, 0.1], &|r| r.mean_error / 10.0),
            ],
        )
    }
}

/// The correspondence network and its optimiser under training: one
/// [`CorrespondenceTrainer::step`] is one optimiser step on a batch of pairs (what
/// `benches/parts.rs` times).
pub struct CorrespondenceTrainer {
    /// Always `Some` between steps (taken so the optimiser holds the only reference).
    net: Option<CorrespondenceNet>,
    optimizer: ModuleOptimizer,
    config: LearnConfig,
    device: Device,
}

impl CorrespondenceTrainer {
    /// A fresh network of `config` (seeded) and its optimiser, on the training `device`.
    pub fn new(config: &LearnConfig, device: &Device) -> Self {
        device.seed(config.seed);
        CorrespondenceTrainer {
            net: Some(config.net().init(device)),
            optimizer: adam(&config.adam),
            config: config.clone(),
            device: device.clone(),
        }
    }

    /// Continues from the weights of the network trained in `source`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if its network is not this config's; as [`TrainedNet::load`].
    pub fn start_from(&mut self, source: &Path) -> Result<()> {
        let shape = NetFolder::new(source).net();
        let theirs = read_shape(&user_file::read_bytes(&shape, user_file::CONFIG)?, &shape)?;
        let ours = self.config.net();
        if ours != theirs {
            return Err(Error::mismatch(
                format!("{}: the starting network's shape", shape.display()),
                format!("{theirs:?}"),
                format!("{ours:?}, the config's"),
            ));
        }
        self.net = Some(TrainedNet::load(source, &self.device)?.net);
        Ok(())
    }

    fn net(&self) -> &CorrespondenceNet {
        self.net.as_ref().expect("a network between steps")
    }

    /// Optimiser step number `step` (from 0; it seeds the sampling) on `pairs`; returns the loss
    /// (the harness stops a run whose loss is not finite).
    ///
    /// # Errors
    /// [`Error::Format`] if no pair has a matched pixel.
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
