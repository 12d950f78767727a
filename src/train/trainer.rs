//! The training loop of neural-puppet.md §3.2: encode a batch of frames, decode the template's
//! vertices, render them with the soft rasterizer, and minimise eq. 4 (or its masked variant)
//! with Adam; seeded, and run by the training harness ([`super::harness`]: logged with the
//! held-out frames' loss, checkpointed atomically, resumable, stopped on NaN).
//!
//! Nothing is written until everything that can be checked has been: a fresh run refuses a folder
//! holding anything puppet did not write; a resume refuses a changed config (only `train.steps`
//! may change), a changed split or puppet, and a checkpoint that does not load — each leaving
//! every file of the model folder as it was.

use std::path::Path;
use std::sync::Arc;

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use super::augment::moved_point;
use super::checkpoint::{self, Checkpoint};
use super::config::{canonical, TrainConfig};
use super::guide::{guide_sheet, UntrainedFit};
use super::harness::{Plan, Run, RunFolder};
use super::log::{plot, LogRow};
use super::optim::{adam, optimizer_bytes, optimizer_from_bytes};
use super::sampled::PoseSampler;
use super::split::{shuffled, split};
use crate::atomic_file::write_atomic;
use crate::backend::scalar;
use crate::error::{Context, Error, Result};
use crate::model::bundle::{load_weights, max_weights_bytes, weights_bytes};
use crate::model::decoder::Decoder;
use crate::model::deformation::{DeformationNet, DeformationNetConfig};
use crate::model::{Model, ModelFolder};
use crate::objective::{LossTerms, Objective};
use crate::picture::{contact_sheet, ImageLimits, Picture};
use crate::progress::Progress;
use crate::puppet::rig_data::Skinning;
use crate::puppet::sequence::Frames;
use crate::puppet::{artwork, build, format, Puppet};
use crate::render::render_crisp;
use crate::rig::{build_rigged, RigOptions};
use crate::rng::Rng;
use crate::user_file;

/// How to run (as opposed to what to train, which is the config).
#[derive(Clone, Debug, Default)]
pub struct TrainOptions {
    /// Continue from the model folder's latest checkpoint.
    pub resume: bool,
    /// Pause after this many steps in total (checkpointed, resumable), e.g. to split a long run.
    pub pause_at: Option<u64>,
    /// Write into an output folder even if it holds files puppet did not write.
    pub force: bool,
    /// The fit `[train.guide]` pulls the training frames' poses toward (the prior's zero-shot
    /// fit, `puppet::prior::PriorGuide`); a config that turns the guide on needs one.
    pub guide: Option<Arc<dyn UntrainedFit>>,
}

/// The frames a model trained on and those held out, by file name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitRecord {
    /// The folder holding the frame files (absolute).
    pub frames: std::path::PathBuf,
    /// Training frames' file names.
    pub train: Vec<String>,
    /// Held-out frames' file names.
    pub test: Vec<String>,
}

impl SplitRecord {
    /// Reads `split.json` of a model folder; `None` if the model has none (not trained here).
    ///
    /// # Errors
    /// [`Error::Format`] naming the file if it is not a split record; [`Error::Io`] if it cannot
    /// be read; [`Error::Limit`] if it is larger than [`user_file::DATA`].
    pub fn load(model_dir: &Path) -> Result<Option<Self>> {
        let path = ModelFolder::new(model_dir).split();
        if !path.is_file() {
            return Ok(None);
        }
        let text = user_file::read_bytes(&path, user_file::DATA)?;
        serde_json::from_slice(&text)
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
    /// Frames per step (the config's batch, or fewer if there are fewer training frames).
    pub batch: usize,
}

/// Loads a puppet folder, or builds a puppet from character artwork with default options
/// (images within `limits`) and, if `rig`, rigs its accessories; build warnings go to
/// `progress`.
///
/// # Errors
/// Whatever loading or building reports, naming the file.
pub fn load_or_build_puppet(path: &Path, limits: &ImageLimits, rig: bool, progress: &dyn Progress) -> Result<Puppet> {
    if path.join(format::PUPPET_FILE).is_file() || path.extension().is_some_and(|e| e == "json") {
        let puppet = format::load(path)?;
        if !rig && puppet.rig.is_some() {
            return Err(Error::setting(
                "model.rig",
                false,
                "true for a rigged puppet folder (give the artwork to train without the rig)",
            )
            .with_path(path));
        }
        Ok(puppet)
    } else {
        let options = artwork::ImportOptions {
            image: *limits,
            ..artwork::ImportOptions::default()
        };
        let art = artwork::load_reporting(path, &options, progress)?;
        if rig {
            build_rigged(&art, &build::BuildOptions::default(), &RigOptions::default(), progress)
        } else {
            Ok(build::build(&art, &build::BuildOptions::default(), progress)?.0)
        }
    }
}

/// Trains the model `config` describes into `config.output`.
///
/// # Errors
/// Bad inputs name their file (puppet, frames of another size, a split without test frames);
/// [`Error::RunExists`] for a folder with a checkpoint when not resuming; [`Error::Resume`] for a
/// resume that does not match the checkpoint; [`Error::WouldOverwrite`] for a folder holding
/// files puppet did not write; [`Error::InUse`] while another process trains into the folder;
/// [`Error::Diverged`] when the loss is not finite. None of these changes a file.
pub fn train(config: &TrainConfig, options: &TrainOptions, progress: &dyn Progress) -> Result<TrainSummary> {
    let folder = ModelFolder::new(&config.output);
    let out = folder.dir();
    // Through text, as the checkpoint stores it: an f32 (train.adam.beta_2 = 0.999) read back
    // from text is not the f32's exact value widened to f64.
    let config_json: serde_json::Value = serde_json::to_string(config)
        .and_then(|text| serde_json::from_str(&text))
        .map_err(|e| Error::format(folder.config(), e.to_string()))?;
    let run = RunFolder::claim(out, config_json.clone(), &["train.steps"], options.resume, options.force)?;

    let image_limits = ImageLimits {
        max_pixels: config.limits.max_image_pixels,
    };
    let puppet = load_or_build_puppet(&config.puppet, &image_limits, config.model.rig, progress)?;
    if puppet.rig.as_ref().is_some_and(|r| r.skinning == Skinning::Affine) {
        // docs/results.md "Affine skinning" has the measurement.
        progress.warn("the rig skins accessories by affine maps ([rig] skinning = \"affine\"): networks trained through it learn far worse than through the default translations");
    }
    let frames = Frames::load(&config.frames, &config.frame_check(puppet.width, puppet.height))?;
    let device = crate::backend::train_device();
    let start = config
        .start
        .as_deref()
        .map(|dir| StartModel::load(dir, &puppet, &device))
        .transpose()?;
    let (train_idx, test_idx) = match &start {
        Some(start) => start.split_of(&frames.names()).at_path(&config.frames)?,
        None => split(frames.frames.len(), config.test_fraction, config.split_seed.unwrap_or(config.seed)).at_path(&config.frames)?,
    };
    if config.test_fraction > 0.0 && test_idx.is_empty() {
        return Err(Error::setting("test_fraction", config.test_fraction, "one that leaves a test frame").with_path(&config.frames));
    }
    let batch = config.train.batch.min(train_idx.len());
    if batch < config.train.batch {
        progress.warn(&format!(
            "train.batch = {} is more than the {} training frames; each step uses all {batch} once",
            config.train.batch,
            train_idx.len()
        ));
    }
    let names = frames.names();
    let record = SplitRecord {
        frames: canonical(&frames.dir),
        train: train_idx.iter().map(|&i| names[i].clone()).collect(),
        test: test_idx.iter().map(|&i| names[i].clone()).collect(),
    };

    device.seed(config.seed);
    let net_config = DeformationNetConfig::new(puppet.free_vertices().len())
        .with_input_size(config.model.input_size)
        .with_latent(config.model.latent)
        .with_offset_scale(config.model.offset_scale);
    let mut model = Model::new(net_config, puppet, &device)?;
    if let Some(start) = start {
        model.net = start.net_for(&model)?;
    }
    let pick = |idx: &[usize]| idx.iter().map(|&i| &frames.frames[i]).collect::<Vec<_>>();
    // A run resumed past the guided steps needs no fits.
    let resumed_at = run.previous().map_or(0, |c| c.state.step);
    let guide = if !config.train.guide.shown_at(resumed_at, config.train.steps) {
        None
    } else {
        let fitter = options.guide.as_ref().ok_or_else(|| {
            Error::setting(
                "train.guide.weight",
                config.train.guide.weight,
                "0 here: this caller has no untrained fit to guide by (puppet train gives the prior's)",
            )
            .with_path(&config.output)
        })?;
        progress.stage("fitting the training frames from the prior", 0);
        Some(fitter.fit(&model, &pick(&train_idx), progress)?)
    };
    let mut trainer = Trainer::new(config, model, &pick(&train_idx), &pick(&test_idx), &device)?;
    if let Some(fits) = &guide {
        trainer.guide_by(fits)?;
    }
    match run.previous() {
        Some(c) => {
            // Everything is checked before anything is written.
            check_resume(&folder, &record, &trainer.model.puppet)?;
            run.restore(&mut trainer)?;
            if c.state.config.get("train").and_then(|t| t.get("steps")) != config_json.get("train").and_then(|t| t.get("steps")) {
                write_config(&folder, config)?;
            }
        }
        None => {
            trainer.model.save(out)?;
            write_config(&folder, config)?;
            let split_json = serde_json::to_vec_pretty(&record).map_err(|e| Error::format(folder.split(), e.to_string()))?;
            write_atomic(&folder.split(), &split_json)?;
            if let Some(sheet) = trainer.sampled_sheet()? {
                sheet.save_png(&folder.sampled())?;
            }
            if let Some(fits) = &guide {
                guide_sheet(&trainer.model, &pick(&train_idx), fits)?.save_png(&folder.guide())?;
            }
        }
    }
    let plan = Plan {
        stage: "training",
        steps: config.train.steps,
        pause_at: options.pause_at,
        checkpoint_every: config.train.checkpoint_every,
        eval_every: config.train.eval_every,
        per_step: batch,
        log: folder.log(),
        plot: folder.plot(),
    };
    let summary = run.train(&mut trainer, &plan, progress)?;
    Ok(TrainSummary {
        steps: summary.steps,
        finished: summary.finished,
        last: summary.last,
        images_per_second: summary.per_second,
        split: (train_idx.len(), test_idx.len()),
        batch,
    })
}

/// The trained model a run starts from ([`TrainConfig::start`]).
struct StartModel {
    model: Model,
    split: SplitRecord,
}

impl StartModel {
    /// Loads the model folder `dir`, which must be a trained model of `puppet`.
    fn load(dir: &Path, puppet: &Puppet, device: &Device) -> Result<Self> {
        let model = Model::load(dir, device)?;
        if let Some(difference) = template_difference(&model.puppet, puppet) {
            return Err(Error::mismatch(
                format!("the puppet of the model to start from ({})", dir.display()),
                difference,
                "the run's puppet",
            ));
        }
        let split = SplitRecord::load(dir)?.ok_or_else(|| {
            Error::format(
                ModelFolder::new(dir).split(),
                "missing: the model to start from was not trained by puppet train, so its held-out frames are unknown",
            )
        })?;
        Ok(StartModel { model, split })
    }

    /// The run's split of frames named `names`: those the model held out stay held out, the rest
    /// train.
    fn split_of(&self, names: &[String]) -> Result<(Vec<usize>, Vec<usize>)> {
        let (test, train): (Vec<usize>, Vec<usize>) = (0..names.len()).partition(|&i| self.split.test.contains(&names[i]));
        if train.is_empty() {
            return Err(Error::setting(
                "start",
                "a model",
                "one whose held-out frames leave a frame to train on",
            ));
        }
        Ok((train, test))
    }

    /// The model's network, if it has `model`'s settings.
    fn net_for(self, model: &Model) -> Result<DeformationNet> {
        // The config has no PartialEq; its Debug text lists every field.
        let (theirs, ours) = (format!("{:?}", self.model.config), format!("{:?}", model.config));
        if theirs != ours {
            return Err(Error::mismatch(
                "the network of the model to start from",
                theirs,
                format!("the run's [model] settings ({ours})"),
            ));
        }
        Ok(self.model.net)
    }
}

/// Refuses a resume whose split or puppet differs from what the folder was trained with (the
/// config was checked when the folder was claimed).
fn check_resume(folder: &ModelFolder, split: &SplitRecord, puppet: &Puppet) -> Result<()> {
    let refuse = |problem: String| Error::Resume {
        path: folder.dir().to_path_buf(),
        problem,
    };
    match SplitRecord::load(folder.dir())? {
        None => return Err(refuse(format!("{} is missing", ModelFolder::SPLIT))),
        Some(stored) if stored.train != split.train || stored.test != split.test => {
            return Err(refuse(format!("the frames split differently from {}", ModelFolder::SPLIT)))
        }
        Some(stored) if canonical(&stored.frames) != split.frames => {
            return Err(refuse(format!(
                "{} trained on frames in {}, the config names {}",
                ModelFolder::SPLIT,
                stored.frames.display(),
                split.frames.display()
            )))
        }
        Some(_) => {}
    }
    let stored = format::load(&folder.puppet())?;
    if let Some(difference) = template_difference(&stored, puppet) {
        return Err(refuse(format!(
            "the puppet differs from the one in {}/: {difference}",
            ModelFolder::PUPPET
        )));
    }
    Ok(())
}

/// The first difference between two puppets' templates (layers, meshes, joints), if any.
fn template_difference(a: &Puppet, b: &Puppet) -> Option<String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Some(format!("{}×{} vs {}×{}", a.width, a.height, b.width, b.height));
    }
    let names = |p: &Puppet| p.layers.iter().map(|l| l.name.clone()).collect::<Vec<_>>();
    if names(a) != names(b) {
        return Some(format!("layers {:?} vs {:?}", names(a), names(b)));
    }
    if let Some(l) = a.layers.iter().zip(&b.layers).find(|(x, y)| x.mesh != y.mesh) {
        return Some(format!("the mesh of layer {:?}", l.0.name));
    }
    (a.joints != b.joints || a.root != b.root).then(|| "the joints".to_string())
}

fn write_config(folder: &ModelFolder, config: &TrainConfig) -> Result<()> {
    let text = toml::to_string_pretty(config).map_err(|e| Error::format(folder.config(), e.to_string()))?;
    write_atomic(&folder.config(), text.as_bytes())
}

/// Poses on the sheet of sampled poses (two rows).
const SHEET_POSES: usize = 12;

/// One model under training: the network, its optimiser, the objective, and the training and
/// held-out frames as network inputs. Its [`Run::step`] is one optimiser step.
pub struct Trainer {
    /// The model being trained.
    pub model: Model,
    optimizer: ModuleOptimizer,
    /// The rest pose the network's offsets are added to and the rig's map, built once.
    decoder: Decoder,
    objective: Objective,
    inputs: Vec<Vec<f32>>,
    held_out: Vec<Vec<f32>>,
    batches: BatchOrder,
    /// Draws the poses shown beside the drawn frames, when the config asks for them.
    sampler: Option<PoseSampler>,
    /// Each training frame's untrained fit (working pixels) the guide pulls toward; empty when
    /// the guide is off.
    guide: Vec<Vec<[f32; 2]>>,
    config: TrainConfig,
    device: Device,
}

impl Trainer {
    /// Prepares training `model` on `frames` (the puppet's size) with `config`'s settings,
    /// measuring the loss on `held_out` frames when asked.
    ///
    /// # Errors
    /// A frame of the wrong size; a degenerate mesh.
    pub fn new(config: &TrainConfig, model: Model, frames: &[&Picture], held_out: &[&Picture], device: &Device) -> Result<Self> {
        for f in frames.iter().chain(held_out) {
            model.check_frame(f)?;
        }
        let size = model.letterbox.size as usize;
        // The rasterizer renders the working square: vertices in working pixels, textures by UV.
        let rest = model.rest_work_points();
        let objective = Objective::new(&model.puppet, &rest, size, config.loss.clone())?;
        let planes = |f: &[&Picture]| f.iter().map(|f| model.letterbox.premultiplied_planes(f)).collect();
        Ok(Trainer {
            inputs: planes(frames),
            held_out: planes(held_out),
            optimizer: adam(&config.train.adam),
            decoder: model.decoder(device),
            objective,
            batches: BatchOrder::new(frames.len(), config.train.batch.min(frames.len()), config.seed),
            sampler: (!config.train.sampled.is_off()).then(|| PoseSampler::new(&model, &config.train.sampled, config.seed)),
            guide: Vec::new(),
            config: config.clone(),
            device: device.clone(),
            model,
        })
    }

    /// Pulls the network's poses of the training frames toward `fits` (one per training frame,
    /// frame pixels) while `[train.guide]` is on.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if there is not one fit of every template vertex per training frame.
    pub fn guide_by(&mut self, fits: &[Vec<[f32; 2]>]) -> Result<()> {
        let vertices = self.model.puppet.vertex_count();
        if fits.len() != self.inputs.len() || fits.iter().any(|f| f.len() != vertices) {
            return Err(Error::mismatch(
                "the guide's fits",
                format!(
                    "{} fits of {:?} vertices",
                    fits.len(),
                    fits.iter().map(Vec::len).collect::<Vec<_>>()
                ),
                format!("one fit of {vertices} vertices per training frame ({})", self.inputs.len()),
            ));
        }
        let letterbox = &self.model.letterbox;
        self.guide = fits.iter().map(|f| f.iter().map(|&p| letterbox.to_work(p)).collect()).collect();
        Ok(())
    }

    /// A sheet of sampled poses as the network is shown them (`None` without sampling).
    ///
    /// # Errors
    /// As [`PoseSampler::step`].
    pub fn sampled_sheet(&self) -> Result<Option<Picture>> {
        let Some(sampler) = &self.sampler else { return Ok(None) };
        // A stream of its own: the sheet does not take any step's samples.
        let mut rng = Rng::new(self.config.seed).fork(u64::MAX);
        let puppet = &self.model.puppet;
        let renders = (0..SHEET_POSES)
            .map(|_| render_crisp(puppet, &sampler.pose(&self.model, None, &mut rng), puppet.width, puppet.height))
            .collect::<Result<Vec<_>>>()?;
        Ok(Some(contact_sheet(&renders.iter().collect::<Vec<_>>(), SHEET_POSES / 2)))
    }

    fn images(&self, planes: &[&Vec<f32>], device: &Device) -> Tensor<4> {
        let size = self.model.letterbox.size as usize;
        let mut data = Vec::with_capacity(planes.len() * 4 * size * size);
        for p in planes {
            data.extend_from_slice(p);
        }
        Tensor::from_data(TensorData::new(data, [planes.len(), 4, size, size]), device)
    }

    /// The forward pass of step `step` (its batch and σ): the losses as numbers, and as tensors
    /// for [`Trainer::update`].
    ///
    /// # Errors
    /// Shape errors from the rasterizer or ARAP operations.
    pub fn losses(&self, step: u64) -> Result<(LogRow, LossTerms)> {
        let order = self.batches.batch(step);
        let chosen: Vec<&Vec<f32>> = order.iter().map(|&i| &self.inputs[i]).collect();
        let drawn = chosen.len();
        let augment = &self.config.train.augment;
        let size = self.model.letterbox.size as usize;
        let augmented = (!augment.is_off()).then(|| augment.apply(&chosen, size, self.config.seed, step));
        let mut batch: Vec<&Vec<f32>> = match &augmented {
            Some(a) => a.inputs.iter().collect(),
            None => chosen,
        };
        // What the image loss compares the renders with: the drawn frames as the network sees
        // them, but for colour jitter (the input's only).
        let targets = |inputs: &Tensor<4>| match &augmented {
            Some(a) => self.images(&a.targets.iter().collect::<Vec<_>>(), &self.device),
            None => inputs.clone().narrow(0, 0, drawn),
        };
        let sigma = self.config.sigma_at(step);
        let net = &self.model.net;
        // Samples around the rest pose go through the network with the drawn frames, in one
        // forward; samples around the network's poses of the frames need those poses first.
        let sampled = &self.config.train.sampled;
        let sampler = self.sampler.as_ref().filter(|_| sampled.shown_at(step, self.config.train.steps));
        let beside = match sampler {
            Some(sampler) if !sampler.around_fits() => Some(sampler.step(&self.model, step, drawn, &[])?),
            _ => None,
        };
        if let Some(s) = &beside {
            batch.extend(&s.planes);
        }
        let images = self.images(&batch, &self.device);
        let vertices = self.decoder.vertices(net, net.encode(images.clone()));
        let on_frames = vertices.clone().narrow(0, 0, drawn);
        let vertex = match (sampler, beside) {
            (_, Some(s)) => Some(self.vertex_loss(vertices.narrow(0, drawn, s.vertices.len()), &s.vertices)),
            (Some(sampler), None) => {
                let s = sampler.step(&self.model, step, drawn, &self.frame_poses(&on_frames))?;
                let planes: Vec<&Vec<f32>> = s.planes.iter().collect();
                let predicted = self.decoder.vertices(net, net.encode(self.images(&planes, &self.device)));
                Some(self.vertex_loss(predicted, &s.vertices))
            }
            (None, None) => None,
        };
        let guide = &self.config.train.guide;
        let guided = (!self.guide.is_empty() && guide.shown_at(step, self.config.train.steps)).then(|| {
            let poses: Vec<Vec<[f32; 2]>> = order
                .iter()
                .enumerate()
                .map(|(k, &i)| match &augmented {
                    Some(a) => self.guide[i].iter().map(|&p| moved_point(a.moves[k], p, size)).collect(),
                    None => self.guide[i].clone(),
                })
                .collect();
            self.vertex_loss(on_frames.clone(), &poses)
        });
        let mut terms = self.objective.evaluate(on_frames, targets(&images), sigma, &self.device)?;
        if let Some(vertex) = &vertex {
            terms.total = terms.total + vertex.clone().mul_scalar(sampled.vertex_weight);
        }
        if let Some(guided) = &guided {
            terms.total = terms.total + guided.clone().mul_scalar(guide.weight);
        }
        let row = LogRow {
            step: step + 1,
            total: scalar(&terms.total),
            rec: scalar(&terms.rec),
            arap: scalar(&terms.arap),
            joints: scalar(&terms.joints),
            area: scalar(&terms.area),
            sigma: sigma as f64,
            seconds: 0.0,
            held_out: f64::NAN,
            vertex: vertex.as_ref().map_or(f64::NAN, scalar),
            guide: guided.as_ref().map_or(f64::NAN, scalar),
        };
        Ok((row, terms))
    }

    /// The mean squared distance (working pixels²) between `predicted` vertices `[K, V, 2]` and
    /// `poses` (working pixels).
    fn vertex_loss(&self, predicted: Tensor<3>, poses: &[Vec<[f32; 2]>]) -> Tensor<1> {
        let [_, count, _] = predicted.dims();
        let flat: Vec<f32> = poses.iter().flatten().flatten().copied().collect();
        let target = Tensor::<3>::from_data(TensorData::new(flat, [poses.len(), count, 2]), &self.device);
        (predicted - target).powi_scalar(2).mean()
    }

    /// Poses `[B, V, 2]` (working pixels) as frame-pixel vertex lists, one per frame.
    fn frame_poses(&self, vertices: &Tensor<3>) -> Vec<Vec<[f32; 2]>> {
        let [_, count, _] = vertices.dims();
        let values: Vec<f32> = vertices.to_data().convert::<f32>().try_to_vec::<f32>().unwrap_or_default();
        values
            .chunks_exact(2 * count)
            .map(|pose| pose.chunks_exact(2).map(|q| self.model.letterbox.to_frame([q[0], q[1]])).collect())
            .collect()
    }

    /// Eq. 4 on the held-out frames at step `step`'s σ, by the network as it is (no gradient);
    /// NaN when there are none.
    ///
    /// # Errors
    /// As [`Trainer::losses`].
    pub fn held_out_loss(&self, step: u64) -> Result<f64> {
        if self.held_out.is_empty() {
            return Ok(f64::NAN);
        }
        let net = self.model.net.valid();
        let device = crate::backend::device();
        let decoder = self.model.decoder(&device);
        let mut sum = 0.0;
        for chunk in self.held_out.chunks(16) {
            let images = self.images(&chunk.iter().collect::<Vec<_>>(), &device);
            let vertices = decoder.vertices(&net, net.encode(images.clone()));
            let terms = self.objective.evaluate(vertices, images, self.config.sigma_at(step), &device)?;
            sum += scalar(&terms.total) * chunk.len() as f64;
        }
        Ok(sum / self.held_out.len() as f64)
    }

    /// Backpropagates `terms.total` and takes Adam step number `step` (its learning rate).
    pub fn update(&mut self, terms: LossTerms, step: u64) {
        // Only the total is needed; the other terms' graph references go first.
        let LossTerms { total, .. } = terms;
        let grads = GradientsParams::from_grads(total.backward(), &self.model.net);
        let net = self.model.net.take();
        self.model.net = self.optimizer.step(self.config.learning_rate_at(step), net, grads);
    }
}

impl Run for Trainer {
    type Row = LogRow;
    const NEWEST: &'static [&'static str] = &[checkpoint::WEIGHTS];

    /// One whole optimiser step (forward, backward, update); returns its losses.
    fn step(&mut self, step: u64) -> Result<LogRow> {
        let (row, terms) = self.losses(step)?;
        self.update(terms, step);
        Ok(row)
    }

    fn non_finite(&self, row: &LogRow) -> Option<String> {
        (!row.total.is_finite()).then(|| format!("total {}, rec {}, arap {}, joints {}", row.total, row.rec, row.arap, row.joints))
    }

    fn held_out(&mut self, step: u64, row: &mut LogRow) -> Result<()> {
        row.held_out = self.held_out_loss(step)?;
        Ok(())
    }

    fn message(&self, row: &LogRow) -> String {
        let vertex = if row.vertex.is_nan() {
            String::new()
        } else {
            format!(", sampled poses' vertices {:.2e}", row.vertex)
        };
        let guide = if row.guide.is_nan() {
            String::new()
        } else {
            format!(", from the prior's fits {:.2e}", row.guide)
        };
        format!(
            "loss {:.3e} (rec {:.3e}, arap {:.2e}, joints {:.2e}{vertex}{guide}) σ {:.2}",
            row.total, row.rec, row.arap, row.joints, row.sigma
        )
    }

    fn state_files(&self, dir: &Path) -> Result<Vec<(&'static str, Vec<u8>)>> {
        Ok(vec![
            (checkpoint::WEIGHTS, weights_bytes(&self.model.net, dir)?),
            (checkpoint::OPTIMIZER, optimizer_bytes(&self.optimizer, dir)?),
        ])
    }

    /// Loads a checkpoint's weights and optimiser state; the optimiser's file may be twice as
    /// large as the largest weights of this network (Adam's two moments).
    fn restore(&mut self, checkpoint: &Checkpoint) -> Result<()> {
        let dir = &checkpoint.dir;
        let limit = max_weights_bytes(&self.model.net);
        let weights = checkpoint.file(checkpoint::WEIGHTS, limit)?;
        let optimizer = checkpoint.file(checkpoint::OPTIMIZER, 2 * limit)?;
        self.model.net = load_weights(self.model.net.clone(), weights, &dir.join(checkpoint::WEIGHTS))?;
        self.optimizer = optimizer_from_bytes(&self.optimizer, optimizer, &dir.join(checkpoint::OPTIMIZER))?;
        Ok(())
    }

    /// The loss curves, the regularisers weighted as the total sums them.
    fn plot(&self, rows: &[LogRow]) -> Picture {
        let loss = &self.config.loss;
        plot(rows, [loss.arap, loss.joints, if loss.masked { loss.area } else { 0.0 }])
    }
}

/// The frames of each step: passes over the training set, each in its own seeded order, cut
/// into batches — a function of the step alone, so a resumed run sees what an uninterrupted
/// one would.
pub struct BatchOrder {
    frames: usize,
    batch: usize,
    rng: Rng,
}

impl BatchOrder {
    /// Batches of `batch` of `frames` frames, in orders drawn from `seed`.
    pub fn new(frames: usize, batch: usize, seed: u64) -> Self {
        BatchOrder {
            frames,
            batch,
            rng: Rng::new(seed ^ 0x0BA7_C4E5),
        }
    }

    /// The frames of step `step`.
    pub fn batch(&self, step: u64) -> Vec<usize> {
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
