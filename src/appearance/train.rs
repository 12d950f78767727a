//! Training the appearance stage (neural-puppet.md §3.3): after, and independently of, the
//! deformation network, as the paper does. Each training frame of the model is fitted and
//! rendered ([`super::pairs`]); the generator learns to turn the render into the drawn frame,
//! against a critic, with two Adam optimisers. Seeded, and run by the training harness
//! ([`crate::train::harness`]: logged with the held-out frames' L1, checkpointed atomically,
//! resumable to the same weights as an uninterrupted run, stopped on NaN).

use std::path::Path;

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};

use super::config::{AppearanceConfig, TrainingFit};
use super::pairs::{split_pairs, Pairs};
use super::stage::{AppearanceStage, StageFolder, StageRecord};
use crate::atomic_file::write_atomic;
use crate::backend::scalar;
use crate::error::{Error, Result};
use crate::fit::FitOptions;
use crate::metrics::l2;
use crate::model::appearance::{Critic, Generator};
use crate::model::bundle::{load_weights, max_weights_bytes, weights_bytes};
use crate::model::Model;
use crate::objective::adversarial::{critic_loss, generator_loss, Batch};
use crate::picture::{contact_sheet, Picture};
use crate::progress::Progress;
use crate::rng::Rng;
use crate::train::checkpoint::Checkpoint;
use crate::train::harness::{Plan, Run, RunFolder};
use crate::train::log::{log_row, plot_rows};
use crate::train::optim::{adam, optimizer_bytes, optimizer_from_bytes};
use crate::train::trainer::BatchOrder;

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct AppearanceOptions {
    /// Continue from the stage's latest checkpoint.
    pub resume: bool,
    /// Pause after this many steps in total (checkpointed, resumable).
    pub pause_at: Option<u64>,
}

/// Mean L2 of the renders and of the generated frames against the drawn ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct L2Pair {
    /// The rendered fits.
    pub rendered: f64,
    /// The generator's redraws of them.
    pub generated: f64,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct AppearanceSummary {
    /// Generator steps done in total.
    pub steps: u64,
    /// Whether all configured steps are done.
    pub finished: bool,
    /// Frames per second over this run's steps (one critic + one generator step each).
    pub images_per_second: f64,
    /// Mean L2 on the training frames (NaN if none).
    pub train: L2Pair,
    /// Mean L2 on the held-out frames (NaN if none).
    pub held_out: L2Pair,
}

/// The checkpoint's files.
const GENERATOR: &str = "generator.bpk";
const CRITIC: &str = "critic.bpk";
const GENERATOR_OPTIMIZER: &str = "generator-optimizer.bpk";
const CRITIC_OPTIMIZER: &str = "critic-optimizer.bpk";

log_row! {
    /// One step's numbers in `appearance/log.csv`.
    pub struct AppearanceRow (min_columns = 10) {
        /// Generator steps done.
        step,
        /// Training seconds so far.
        seconds = "seconds",
        /// The generator's loss.
        generator = "generator",
        /// Its adversarial part, unweighted.
        adversarial = "adversarial",
        /// Its L1 part, unweighted (per-pixel mean).
        l1 = "l1",
        /// The critic's loss (its last step).
        critic = "critic",
        /// The critic's mean score of drawn frames.
        real = "real",
        /// Its mean score of generated frames.
        fake = "fake",
        /// The gradient penalty, unweighted.
        penalty = "penalty",
        /// The held-out frames' per-pixel mean L1 (NaN where not measured).
        held_out = "held_out_l1",
    }
}

/// Trains the appearance stage of the model in `model_dir` with `config`; `fit` is how the
/// frames are fitted when `config.fit` is the default fit (the caller's, as `eval` would).
///
/// # Errors
/// [`Error::RunExists`] if the stage has a checkpoint and resuming was not asked for;
/// [`Error::Resume`] for a resume without a checkpoint or with another config (only `epochs` may
/// change) — neither writes anything; [`Error::InUse`] while another process trains the stage;
/// [`Error::Diverged`] for a loss that is not finite; whatever
/// loading the model, fitting or writing reports, naming the file.
pub fn train_appearance(
    model_dir: &Path,
    config: &AppearanceConfig,
    fit: &FitOptions,
    options: &AppearanceOptions,
    progress: &dyn Progress,
) -> Result<AppearanceSummary> {
    config.validate()?;
    let folder = StageFolder::of_model(model_dir);
    let inference = crate::backend::device();
    let model = Model::load(model_dir, &inference)?;
    let config_json = serde_json::to_value(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    // A fresh run may fill only a folder puppet made, or an empty one.
    let run = RunFolder::claim(folder.dir(), config_json, &["epochs"], options.resume, false)?;
    let fit_options = match config.fit {
        TrainingFit::Default => fit.clone(),
        TrainingFit::OnePass => FitOptions::one_pass(),
    };
    let pairs = split_pairs(model_dir, &model, &fit_options, &inference, progress)?;
    if pairs.train.frames.is_empty() {
        return Err(Error::format(folder.dir(), "the model has no training frames"));
    }
    let inputs = planes(&model, &pairs.train.renders);
    let batch = config.batch.min(inputs.len());
    if batch < config.batch {
        progress.warn(&format!(
            "batch = {} is more than the {} training frames; each step uses all {batch} once",
            config.batch,
            inputs.len()
        ));
    }
    let total = (config.epochs * inputs.len() as u64).div_ceil(batch as u64);
    let device = crate::backend::train_device();
    device.seed(config.seed);
    let net = config.net(model.letterbox.size as usize);
    let mut training = Training {
        generator: net.init_generator(&device),
        critic: net.init_critic(&device),
        generator_optimizer: adam(&config.adam),
        critic_optimizer: adam(&config.adam),
        order: BatchOrder::new(inputs.len(), batch, config.seed),
        inputs,
        targets: planes(&model, &pairs.train.frames),
        held_out: (planes(&model, &pairs.held_out.renders), planes(&model, &pairs.held_out.frames)),
        size: model.letterbox.size as usize,
        config: config.clone(),
        device: device.clone(),
    };
    match run.previous() {
        Some(_) => run.restore(&mut training)?,
        None => {
            let json = serde_json::to_vec_pretty(&net).map_err(|e| Error::format(folder.net(), e.to_string()))?;
            write_atomic(&folder.net(), &json)?;
            StageRecord::of(&model).save(&folder)?;
        }
    }
    let toml = toml::to_string_pretty(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    write_atomic(&folder.config(), toml.as_bytes())?;
    let plan = Plan {
        stage: "appearance",
        steps: total,
        pause_at: options.pause_at,
        checkpoint_every: config.checkpoint_every,
        eval_every: config.eval_every,
        per_step: batch,
        log: folder.log(),
        plot: folder.plot(),
    };
    let summary = run.train(&mut training, &plan, progress)?;
    let stage = AppearanceStage::new(net, training.generator.valid(), model.letterbox);
    let (train_redraws, held_out_redraws) = (
        redraws(&stage, &pairs.train, &inference),
        redraws(&stage, &pairs.held_out, &inference),
    );
    let train = scores(&pairs.train, &train_redraws);
    let held_out = scores(&pairs.held_out, &held_out_redraws);
    sheet([(&pairs.train, &train_redraws), (&pairs.held_out, &held_out_redraws)]).save_png(&folder.sheet())?;
    Ok(AppearanceSummary {
        steps: summary.steps,
        finished: summary.finished,
        images_per_second: summary.per_second,
        train,
        held_out,
    })
}

/// Frames as network planes, `[4, S, S]` each.
fn planes(model: &Model, pictures: &[Picture]) -> Vec<Vec<f32>> {
    pictures.iter().map(|p| model.letterbox.premultiplied_planes(p)).collect()
}

/// Each pair's render redrawn by the stage.
fn redraws(stage: &AppearanceStage, pairs: &Pairs, device: &Device) -> Vec<Picture> {
    stage.redraw(&pairs.renders.iter().collect::<Vec<_>>(), device)
}

/// Mean L2 of renders and of their redraws `generated` against the drawn frames.
fn scores(pairs: &Pairs, generated: &[Picture]) -> L2Pair {
    let n = pairs.frames.len() as f64;
    let mean = |pictures: &[Picture]| pictures.iter().zip(&pairs.frames).map(|(p, f)| l2(p, f)).sum::<f64>() / n;
    L2Pair {
        rendered: mean(&pairs.renders),
        generated: mean(generated),
    }
}

/// Rows of (render, generated, drawn): the training frames, then the held-out ones.
fn sheet(sets: [(&Pairs, &[Picture]); 2]) -> Picture {
    let mut cells: Vec<Picture> = Vec::new();
    for (pairs, generated) in sets {
        for ((render, drawn), redrawn) in pairs.renders.iter().zip(&pairs.frames).zip(generated) {
            cells.extend([render.clone(), redrawn.clone(), drawn.clone()]);
        }
    }
    contact_sheet(&cells.iter().collect::<Vec<_>>(), 6)
}

/// The networks and optimisers under training, the data as planes, and the batches.
struct Training {
    generator: Generator,
    critic: Critic,
    generator_optimizer: ModuleOptimizer,
    critic_optimizer: ModuleOptimizer,
    order: BatchOrder,
    inputs: Vec<Vec<f32>>,
    targets: Vec<Vec<f32>>,
    held_out: (Vec<Vec<f32>>, Vec<Vec<f32>>),
    size: usize,
    config: AppearanceConfig,
    device: Device,
}

impl Training {
    fn tensor(&self, planes: &[&Vec<f32>], device: &Device) -> Tensor<4> {
        let data: Vec<f32> = planes.iter().flat_map(|p| p.iter().copied()).collect();
        Tensor::from_data(TensorData::new(data, [planes.len(), 4, self.size, self.size]), device)
    }

    /// The generator's per-pixel mean L1 on the held-out frames (NaN if none), without dropout.
    fn held_out_l1(&self) -> f64 {
        let (inputs, targets) = &self.held_out;
        if inputs.is_empty() {
            return f64::NAN;
        }
        let device = crate::backend::device();
        let generator = self.generator.valid();
        let mut sum = 0.0;
        for (x, y) in inputs.chunks(16).zip(targets.chunks(16)) {
            let n = x.len() as f64;
            let x = self.tensor(&x.iter().collect::<Vec<_>>(), &device);
            let y = self.tensor(&y.iter().collect::<Vec<_>>(), &device);
            sum += scalar(&(generator.forward(x) - y).abs().mean()) * n;
        }
        sum / inputs.len() as f64
    }
}

impl Run for Training {
    type Row = AppearanceRow;
    const NEWEST: &'static [&'static str] = &[GENERATOR, CRITIC];

    /// Generator step `step` on its batch of frames, after `critic_steps` critic steps.
    fn step(&mut self, step: u64) -> Result<AppearanceRow> {
        let batch = &self.order.batch(step);
        // Dropout and the penalty's mixing are functions of the step, so a resumed run draws
        // what an uninterrupted one would.
        self.device.seed(self.config.seed ^ step.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mut rng = Rng::new(self.config.seed).fork(step);
        let x = self.tensor(&batch.iter().map(|&i| &self.inputs[i]).collect::<Vec<_>>(), &self.device);
        let y = self.tensor(&batch.iter().map(|&i| &self.targets[i]).collect::<Vec<_>>(), &self.device);
        let fake = self.generator.forward(x.clone());
        let pair = Batch {
            real: y,
            fake,
            render: self.config.conditioned.then_some(x),
        };
        let loss = self.config.loss;
        let lr = self.config.learning_rate;
        let (mut critic_total, mut real, mut fake_score, mut penalty) = (0.0, f64::NAN, f64::NAN, 0.0);
        if loss.has_critic() {
            for _ in 0..self.config.critic_steps {
                let mix: Vec<f32> = batch.iter().map(|_| rng.unit()).collect();
                let mix = Tensor::from_data(TensorData::new(mix, [batch.len(), 1, 1, 1]), &self.device);
                let terms = critic_loss(loss, &self.critic, &pair, mix, self.config.penalty_weight);
                (critic_total, real, fake_score, penalty) = (
                    scalar(&terms.total),
                    scalar(&terms.real),
                    scalar(&terms.fake),
                    scalar(&terms.penalty),
                );
                let grads = GradientsParams::from_grads(terms.total.backward(), &self.critic);
                self.critic = self.critic_optimizer.step(lr, self.critic.take(), grads);
            }
        }
        let terms = generator_loss(loss, &self.critic.clone().no_grad(), &pair, self.config.l1_weight);
        let row = AppearanceRow {
            step: step + 1,
            seconds: 0.0,
            generator: scalar(&terms.total),
            adversarial: scalar(&terms.adversarial),
            l1: scalar(&terms.l1),
            critic: critic_total,
            real,
            fake: fake_score,
            penalty,
            held_out: f64::NAN,
        };
        let grads = GradientsParams::from_grads(terms.total.backward(), &self.generator);
        self.generator = self.generator_optimizer.step(lr, self.generator.take(), grads);
        Ok(row)
    }

    fn non_finite(&self, row: &AppearanceRow) -> Option<String> {
        let finite = row.generator.is_finite() && row.critic.is_finite();
        (!finite).then(|| format!("generator {}, critic {}, penalty {}", row.generator, row.critic, row.penalty))
    }

    fn held_out(&mut self, _step: u64, row: &mut AppearanceRow) -> Result<()> {
        row.held_out = self.held_out_l1();
        Ok(())
    }

    fn message(&self, row: &AppearanceRow) -> String {
        format!(
            "G {:.3} (L1 {:.4}) D {:.3} penalty {:.3}",
            row.generator, row.l1, row.critic, row.penalty
        )
    }

    fn state_files(&self, dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>> {
        let optimizer = |o: &ModuleOptimizer| optimizer_bytes(o, dir);
        Ok(vec![
            (GENERATOR, weights_bytes(&self.generator, dir)?),
            (CRITIC, weights_bytes(&self.critic, dir)?),
            (GENERATOR_OPTIMIZER, optimizer(&self.generator_optimizer)?),
            (CRITIC_OPTIMIZER, optimizer(&self.critic_optimizer)?),
        ])
    }

    fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()> {
        let dir = &checkpoint.dir;
        let (g_limit, d_limit) = (max_weights_bytes(&self.generator), max_weights_bytes(&self.critic));
        self.generator = load_weights(self.generator.clone(), checkpoint.file(GENERATOR, g_limit)?, &dir.join(GENERATOR))?;
        self.critic = load_weights(self.critic.clone(), checkpoint.file(CRITIC, d_limit)?, &dir.join(CRITIC))?;
        let optimizer = |o: &ModuleOptimizer, name: &str, limit: u64| -> Result<ModuleOptimizer> {
            optimizer_from_bytes(o, checkpoint.file(name, limit)?, &dir.join(name))
        };
        self.generator_optimizer = optimizer(&self.generator_optimizer, GENERATOR_OPTIMIZER, 2 * g_limit)?;
        self.critic_optimizer = optimizer(&self.critic_optimizer, CRITIC_OPTIMIZER, 2 * d_limit)?;
        Ok(())
    }

    fn plot(&self, rows: &[AppearanceRow]) -> Picture {
        plot_rows(
            rows,
            &[
                ("generator", [0.0, 0.0, 0.0], &|r| r.generator),
                ("l1", [0.1, 0.35, 0.9], &|r| r.l1),
                ("critic", [0.95, 0.5, 0.0], &|r| r.critic.abs()),
                ("penalty", [0.1, 0.65, 0.2], &|r| r.penalty),
                ("held-out l1", [0.85, 0.1, 0.1], &|r| r.held_out),
            ],
        )
    }
}
