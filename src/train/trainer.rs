//! The training loop of neural-puppet.md §3.2: encode a batch of frames, decode the template's
//! vertices, render them with the soft rasterizer, and minimise eq. 4 (or its masked variant)
//! with Adam; seeded, logged, checkpointed atomically, resumable, and stopped on NaN.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Bytes, Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use super::checkpoint::{self, CheckpointState};
use super::config::TrainConfig;
use super::log::{plot, LogRow, TrainLog};
use super::loss::{LossTerms, Objective};
use super::optim::{adam, AdamSettings};
use super::sequence::{shuffled, split, Frames};
use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::model::bundle::{load_weights, weights_bytes};
use crate::model::deformation::{rest_tensor, DeformationNetConfig};
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::{artwork, build, format, Puppet};
use crate::render::burn_op::soft_raster;
use crate::render::soft_raster::{Background, Params, SoftRasterizer};
use crate::synth::rng::Rng;

/// The copy of the config a model folder keeps.
pub const CONFIG_FILE: &str = "train.toml";
/// Which frames trained and which are held out.
pub const SPLIT_FILE: &str = "split.json";
/// The per-step log.
pub const LOG_FILE: &str = "log.csv";
/// The loss curves.
pub const PLOT_FILE: &str = "loss.png";

/// How to run (as opposed to what to train, which is the config).
#[derive(Clone, Debug, Default)]
pub struct TrainOptions {
    /// Continue from the model folder's latest checkpoint.
    pub resume: bool,
    /// Pause after this many steps in total (checkpointed, resumable), e.g. to split a long run.
    pub pause_at: Option<u64>,
}

/// The frames a model trained on and those held out, by file name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitRecord {
    /// The folder holding the frame files (absolute).
    pub frames: PathBuf,
    /// Training frames' file names.
    pub train: Vec<String>,
    /// Held-out frames' file names.
    pub test: Vec<String>,
}

impl SplitRecord {
    /// Reads `split.json` of a model folder; `None` if the model has none (not trained here).
    ///
    /// # Errors
    /// [`Error::Format`] naming the file if it is not a split record.
    pub fn load(model_dir: &Path) -> Result<Option<Self>> {
        let path = model_dir.join(SPLIT_FILE);
        if !path.is_file() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| Error::format(&path, format!("invalid split record: {e}")))
    }

    /// Indices into `names` of the held-out frames, if every one of them is there.
    pub fn test_indices(&self, names: &[String]) -> Option<Vec<usize>> {
        self.test.iter().map(|t| names.iter().position(|n| n == t)).collect()
    }
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct TrainSummary {
    /// Steps done in total (including those before a resume).
    pub steps: u64,
    /// Whether all configured steps are done (the final model is written).
    pub finished: bool,
    /// The last step's losses.
    pub last: Option<LogRow>,
    /// Frames per second over this run's steps.
    pub images_per_second: f64,
    /// Split sizes (train, test).
    pub split: (usize, usize),
}

/// Loads a puppet folder, or builds a puppet from character artwork with default options.
///
/// # Errors
/// Whatever loading or building reports, naming the file.
pub fn load_or_build_puppet(path: &Path, progress: &dyn Progress) -> Result<Puppet> {
    if path.join(format::PUPPET_FILE).is_file() || path.extension().is_some_and(|e| e == "json") {
        format::load(path)
    } else {
        let art = artwork::load(path, &artwork::ImportOptions::default())?;
        Ok(build::build(&art, &build::BuildOptions::default(), progress)?.0)
    }
}

/// Trains the model `config` describes into `config.output`.
///
/// # Errors
/// Bad inputs name their file (puppet, frames of another size, a split without test frames);
/// an existing checkpoint without `resume` (or `resume` without one) is an error rather than
/// overwriting work; a non-finite loss stops the run naming the step and the last good
/// checkpoint.
pub fn train(config: &TrainConfig, options: &TrainOptions, progress: &dyn Progress) -> Result<TrainSummary> {
    let out = &config.output;
    let previous = checkpoint::latest(out)?;
    match (&previous, options.resume) {
        (Some(dir), false) => {
            return Err(Error::Invalid(format!(
                "{}: holds a checkpoint of an earlier run ({}); pass --resume to continue it, or choose another output",
                out.display(),
                dir.display()
            )))
        }
        (None, true) => {
            return Err(Error::Invalid(format!(
                "{}: --resume, but there is no checkpoint to resume from",
                out.display()
            )))
        }
        _ => {}
    }

    let puppet = load_or_build_puppet(&config.puppet, progress)?;
    let frames = Frames::load(&config.frames)?;
    if let Some((file, f)) = frames
        .files
        .iter()
        .zip(&frames.frames)
        .find(|(_, f)| (f.width, f.height) != (puppet.width, puppet.height))
    {
        return Err(Error::format(
            file,
            format!(
                "frame is {}×{}, but the puppet {} was made from {}×{} frames (a different character?)",
                f.width,
                f.height,
                config.puppet.display(),
                puppet.width,
                puppet.height
            ),
        ));
    }
    let (train_idx, test_idx) = split(frames.frames.len(), config.test_fraction, config.seed)
        .map_err(|e| Error::Invalid(format!("{}: {e}", config.frames.display())))?;
    if config.test_fraction > 0.0 && test_idx.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: the split leaves no test frame",
            config.frames.display()
        )));
    }

    let device = crate::backend::train_device();
    device.seed(config.seed);
    let net_config = DeformationNetConfig::new(puppet.vertex_count())
        .with_input_size(config.model.input_size)
        .with_latent(config.model.latent)
        .with_offset_scale(config.model.offset_scale);
    let model = Model::new(net_config, puppet, &device)?;
    model.save(out)?;
    write_atomic(
        &out.join(CONFIG_FILE),
        toml::to_string_pretty(config)
            .map_err(|e| Error::Invalid(e.to_string()))?
            .as_bytes(),
    )?;
    let names = frames.names();
    let record = SplitRecord {
        frames: std::fs::canonicalize(&frames.dir).unwrap_or_else(|_| frames.dir.clone()),
        train: train_idx.iter().map(|&i| names[i].clone()).collect(),
        test: test_idx.iter().map(|&i| names[i].clone()).collect(),
    };
    write_atomic(
        &out.join(SPLIT_FILE),
        &serde_json::to_vec_pretty(&record).map_err(|e| Error::Invalid(e.to_string()))?,
    )?;

    let mut trainer = Trainer::new(
        config,
        model,
        &train_idx.iter().map(|&i| &frames.frames[i]).collect::<Vec<_>>(),
        &device,
    )?;
    let config_json = serde_json::to_value(config).map_err(|e| Error::Invalid(e.to_string()))?;
    let (mut step, mut elapsed) = (0u64, 0f64);
    if let Some(dir) = previous {
        let c = checkpoint::load(&dir)?;
        if !same_run(&c.state.config, &config_json) {
            return Err(Error::format(
                dir.join("state.json"),
                "this checkpoint was written with a different config (only train.steps may change for --resume)",
            ));
        }
        trainer.restore(c.weights, c.optimizer, &dir)?;
        (step, elapsed) = (c.state.step, c.state.elapsed);
    }
    let mut log = TrainLog::open(&out.join(LOG_FILE), step)?;
    let weights = [
        config.loss.arap,
        config.loss.joints,
        if config.loss.masked { config.loss.area } else { 0.0 },
    ];

    let stop = options.pause_at.map_or(config.train.steps, |p| p.min(config.train.steps));
    progress.stage("training", config.train.steps);
    progress.advance(step);
    let started = Instant::now();
    let first_step = step;
    let mut last = None;
    while step < stop {
        let t0 = Instant::now();
        let (losses, terms) = trainer.losses(step)?;
        if !losses.total.is_finite() {
            let keep = checkpoint::latest(out)?.map_or("none was written yet".to_string(), |d| d.display().to_string());
            return Err(Error::Invalid(format!(
                "step {}: the loss is not finite (total {}, rec {}, arap {}, joints {}); stopped — the last good checkpoint is {keep} (try a lower train.learning_rate)",
                step + 1,
                losses.total,
                losses.rec,
                losses.arap,
                losses.joints
            )));
        }
        // The weights that produced this finite loss are checkpointed before they change (the
        // untrained ones too, so a run that diverges at once still has one to resume from).
        if (step > first_step || step == 0) && step % config.train.checkpoint_every == 0 {
            save_checkpoint(out, &trainer, step, elapsed, &config_json, &log, weights)?;
        }
        trainer.update(terms, step);
        step += 1;
        elapsed += t0.elapsed().as_secs_f64();
        let row = LogRow {
            step,
            seconds: elapsed,
            ..losses
        };
        log.push(row)?;
        last = Some(row);
        progress.advance(1);
        progress.message(&format!(
            "loss {:.3e} (rec {:.3e}, arap {:.2e}, joints {:.2e}) σ {:.2}",
            row.total, row.rec, row.arap, row.joints, row.sigma
        ));
    }
    let seconds = started.elapsed().as_secs_f64();
    let finished = step >= config.train.steps;
    save_checkpoint(out, &trainer, step, elapsed, &config_json, &log, weights)?;
    Ok(TrainSummary {
        steps: step,
        finished,
        last,
        images_per_second: ((step - first_step) as usize * config.train.batch) as f64 / seconds.max(1e-9),
        split: (train_idx.len(), test_idx.len()),
    })
}

fn save_checkpoint(
    out: &Path,
    trainer: &Trainer,
    step: u64,
    elapsed: f64,
    config: &serde_json::Value,
    log: &TrainLog,
    weights: [f64; 3],
) -> Result<()> {
    let dir = out.join(checkpoint::CHECKPOINT_DIR);
    let (net, optim) = trainer.state_bytes(&dir)?;
    let state = CheckpointState {
        step,
        elapsed,
        config: config.clone(),
    };
    checkpoint::save(out, &state, &net, &optim)?;
    // The model folder always holds the newest weights, so `fit`/`eval` work during training.
    write_atomic(&out.join(crate::model::bundle::WEIGHTS_FILE), &net)?;
    plot(log.rows(), weights).save_png(&out.join(PLOT_FILE))
}

/// One model under training: the network, its optimiser, the rasterizer and the losses, and the
/// training frames as network inputs. [`Trainer::step`] is one optimiser step.
pub struct Trainer {
    /// The model being trained.
    pub model: Model,
    optimizer: ModuleOptimizer,
    raster: Arc<SoftRasterizer>,
    /// Rest vertices in working pixels `[V, 2]`, built once (the decoder adds offsets to them).
    rest: Tensor<2>,
    objective: Objective,
    inputs: Vec<Vec<f32>>,
    batches: BatchOrder,
    config: TrainConfig,
    device: Device,
}

impl Trainer {
    /// Prepares training `model` on `frames` (the puppet's size) with `config`'s settings.
    ///
    /// # Errors
    /// A frame of the wrong size; a degenerate mesh.
    pub fn new(config: &TrainConfig, model: Model, frames: &[&Picture], device: &Device) -> Result<Self> {
        let size = model.letterbox.size as usize;
        for f in frames {
            model.check_frame(f)?;
        }
        // The rasterizer renders the working square: vertices in working pixels, textures by UV.
        let raster = Arc::new(SoftRasterizer::new(&model.puppet)?);
        let rest = model.rest_work_points();
        let rest_area = rest_coverage(&raster, &rest, size)?;
        let objective = Objective::new(&model.puppet, &rest, size, rest_area, config.loss.clone())?;
        let inputs = frames.iter().map(|f| model.letterbox.premultiplied_planes(f)).collect();
        Ok(Trainer {
            model,
            optimizer: adam(&AdamSettings::new()),
            raster,
            rest: rest_tensor(&rest, device),
            objective,
            inputs,
            batches: BatchOrder::new(frames.len(), config.train.batch, config.seed),
            config: config.clone(),
            device: device.clone(),
        })
    }

    /// Loads a checkpoint's weights and optimiser state (read from `dir`, for messages).
    ///
    /// # Errors
    /// [`Error::Format`] naming the file that does not fit.
    pub fn restore(&mut self, weights: Vec<u8>, optimizer: Vec<u8>, dir: &Path) -> Result<()> {
        self.model.net = load_weights(self.model.net.clone(), weights, &dir.join("weights.bpk"))?;
        self.optimizer = self
            .optimizer
            .clone()
            .from_bytes(Bytes::from_bytes_vec(optimizer))
            .map_err(|e| Error::format(dir.join("optimizer.bpk"), format!("cannot read optimiser state: {e:?}")))?;
        Ok(())
    }

    /// The network's and the optimiser's state as burnpack bytes.
    ///
    /// # Errors
    /// [`Error::Format`] naming `dir` if Burn cannot encode them.
    pub fn state_bytes(&self, dir: &Path) -> Result<(Vec<u8>, Vec<u8>)> {
        let optim = self
            .optimizer
            .into_bytes()
            .map_err(|e| Error::format(dir, format!("cannot encode optimiser state: {e:?}")))?;
        Ok((weights_bytes(&self.model.net, dir)?, optim.to_vec()))
    }

    /// The forward pass of step `step` (its batch and σ): the losses as numbers, and as tensors
    /// for [`Trainer::update`].
    ///
    /// # Errors
    /// Shape errors from the rasterizer or ARAP operations.
    pub fn losses(&self, step: u64) -> Result<(LogRow, LossTerms)> {
        let size = self.model.letterbox.size as usize;
        let batch = self.batches.batch(step);
        let mut data = Vec::with_capacity(batch.len() * 4 * size * size);
        for &i in &batch {
            data.extend_from_slice(&self.inputs[i]);
        }
        let images: Tensor<4> = Tensor::from_data(TensorData::new(data, [batch.len(), 4, size, size]), &self.device);
        let sigma = self.config.sigma_at(step);
        let net = &self.model.net;
        let vertices = net.vertices(net.encode(images.clone()), &self.rest);
        let params = Params {
            sigma,
            background: Background::Transparent,
            ..Params::default()
        };
        let rendered = soft_raster(vertices.clone(), &self.raster, size, size, params)?;
        let terms = self.objective.evaluate(vertices, &rendered, images, &self.device)?;
        let value = |t: &Tensor<1>| {
            t.clone()
                .into_data()
                .convert::<f64>()
                .try_to_vec::<f64>()
                .map_or(f64::NAN, |v| v[0])
        };
        let row = LogRow {
            step: step + 1,
            total: value(&terms.total),
            rec: value(&terms.rec),
            arap: value(&terms.arap),
            joints: value(&terms.joints),
            area: value(&terms.area),
            sigma: sigma as f64,
            seconds: 0.0,
        };
        Ok((row, terms))
    }

    /// Backpropagates `terms.total` and takes Adam step number `step` (its learning rate).
    pub fn update(&mut self, terms: LossTerms, step: u64) {
        // Only the total is needed; the other terms' graph references go first.
        let LossTerms { total, .. } = terms;
        let grads = GradientsParams::from_grads(total.backward(), &self.model.net);
        let net = self.model.net.take();
        self.model.net = self.optimizer.step(self.config.learning_rate_at(step), net, grads);
    }

    /// One whole optimiser step (forward, backward, update); returns its losses.
    ///
    /// # Errors
    /// As [`Trainer::losses`].
    pub fn step(&mut self, step: u64) -> Result<LogRow> {
        let (row, terms) = self.losses(step)?;
        self.update(terms, step);
        Ok(row)
    }
}

/// Configs of the same run, ignoring `train.steps` (which a resume may extend).
fn same_run(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    let strip = |v: &serde_json::Value| {
        let mut v = v.clone();
        if let Some(t) = v.get_mut("train").and_then(|t| t.as_object_mut()) {
            t.remove("steps");
        }
        v
    };
    strip(a) == strip(b)
}

/// The rest pose's silhouette area as a fraction of the S×S square (eq. 11's Σ R(V_init)).
pub(crate) fn rest_coverage(raster: &SoftRasterizer, rest: &[[f32; 2]], size: usize) -> Result<f32> {
    let flat: Vec<f32> = rest.iter().flatten().copied().collect();
    let f = raster.forward(&flat, 1, size, size, &Params::crisp(Background::Transparent))?;
    Ok(f.mask.iter().sum::<f32>() / (size * size) as f32)
}

/// The frames of each step: passes over the training set, each in its own seeded order, cut
/// into batches — a function of the step alone, so a resumed run sees what an uninterrupted
/// one would.
struct BatchOrder {
    frames: usize,
    batch: usize,
    rng: Rng,
}

impl BatchOrder {
    fn new(frames: usize, batch: usize, seed: u64) -> Self {
        BatchOrder {
            frames,
            batch,
            rng: Rng::new(seed ^ 0x0BA7_C4E5),
        }
    }

    fn batch(&self, step: u64) -> Vec<usize> {
        let first = step as usize * self.batch;
        let mut order: Option<(usize, Vec<usize>)> = None;
        (first..first + self.batch)
            .map(|p| {
                let pass = p / self.frames;
                if order.as_ref().is_none_or(|(q, _)| *q != pass) {
                    order = Some((pass, shuffled(self.frames, &mut self.rng.fork(pass as u64))));
                }
                order.as_ref().map_or(0, |(_, o)| o[p % self.frames])
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_cover_each_pass_once_and_depend_only_on_the_step() {
        let order = BatchOrder::new(5, 3, 9);
        let first_two: Vec<usize> = [order.batch(0), order.batch(1)].concat();
        let mut pass: Vec<usize> = first_two[..5].to_vec();
        pass.sort_unstable();
        assert_eq!(pass, [0, 1, 2, 3, 4]);
        assert_eq!(BatchOrder::new(5, 3, 9).batch(1), order.batch(1));
        assert_ne!(BatchOrder::new(5, 3, 10).batch(0), order.batch(0));
    }
}
