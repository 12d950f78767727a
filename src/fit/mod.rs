//! Fitting frames with a trained model (neural-puppet.md §3.2, §4): the encoder's one pass,
//! `v = D(E(x))`, then optional stages that lower the training objective (eq. 4: L_rec +
//! λ1·ARAP + λ2·joints) for each frame alone — analysis by synthesis through the decoder and the
//! soft rasterizer, the machinery §4.2 uses for dragged poses:
//!
//! 1. latent steps: Adam on each frame's latent z; the weights do not change and the pose stays
//!    on the decoder's manifold;
//! 2. rounds of a limb search ([`limb_search`]: limbs turned about their joints, for limbs drawn
//!    far from where the network put them) and vertex steps (Adam on the vertices themselves,
//!    held only by the ARAP and joint terms);
//! 3. limbs the frame hides turned to their twins' mirrored turns ([`hidden_limbs`]), as far as
//!    the render allows (after the latent steps when there are no vertex rounds);
//! 4. with an accessory rig and vertex steps, Adam on the accessories' moves from where the rig
//!    puts them, the body held ([`accessory_moves`]).
//!
//! Frames are fitted in batches of at most [`BATCH`], side by side on the cores. Reading a frame
//! for a model: [`frame`].

pub mod accessory_moves;
pub mod frame;
pub mod hidden_limbs;
pub mod limb_search;
pub mod plausible;

use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::model::decoder::Decoder;
use crate::model::{Model, ModelFolder};
use crate::objective::{downsample, LossWeights, Objective};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::render::soft_raster::SoftRasterizer;
use crate::train::optim::{AdamSettings, FlatAdam};
use crate::user_file;
use accessory_moves::AccessoryMoves;
use hidden_limbs::HiddenLimbs;
use limb_search::LimbSearch;
use plausible::JointRanges;

/// Every template vertex of each of some frames, frame pixels.
type Poses = Vec<Vec<[f32; 2]>>;

/// The most frames fitted in one batch (one rasterizer, objective and network input each).
pub const BATCH: usize = 16;

/// Latent steps unless asked otherwise: most of what latent steps gain comes in the first fifty
/// (docs/results.md "Fitting the synthetic walker").
pub const DEFAULT_LATENT_STEPS: usize = 50;

/// Vertex steps per round after the latent ones unless asked otherwise (docs/results.md
/// "Fitting the synthetic walker" and "Cheaper settings on the walker").
pub const DEFAULT_VERTEX_STEPS: usize = 100;

/// The share of each round's vertex steps taken at half size unless asked otherwise: as good a
/// fit as all steps at full size, in less time (docs/results.md "Half-size vertex steps").
pub const DEFAULT_VERTEX_COARSE_SHARE: f32 = 0.75;

/// The least share by which a round must lower a frame's L2 for it to take the next unless asked
/// otherwise: rounds that stop paying are skipped (docs/results.md "Rounds that stop paying").
pub const DEFAULT_MIN_ROUND_GAIN: f64 = 0.005;

/// Steps on a rigged model's accessories after its body's fit unless asked otherwise
/// (docs/results.md "The dressed walk").
pub const DEFAULT_ACCESSORY_STEPS: usize = 50;

/// How much smaller the square of the coarse vertex steps is ([`FitOptions::vertex_coarse_share`]).
const COARSE_FACTOR: usize = 2;

/// The plausibility term's weight unless asked otherwise: off, as it did not win on the Kenney
/// robot's held-out frames (docs/results.md "Plausible fits").
pub const DEFAULT_PLAUSIBILITY_WEIGHT: f32 = 0.0;

/// How far past the training poses' turns a fit may turn a limb unless asked otherwise (degrees).
pub const DEFAULT_PLAUSIBLE_MARGIN: f32 = 30.0;

/// How to fit frames.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Adam steps on the latents (0 = the encoder's fit unchanged).
    pub latent_steps: usize,
    /// Adam's step size in latent units.
    pub learning_rate: f32,
    /// Adam steps on the vertices after the latents, for fits (0 = stay on the decoder's
    /// manifold). Edits — in-betweens and drags — move latents and ignore it.
    pub vertex_steps: usize,
    /// Adam's step size in working-square pixels.
    pub vertex_learning_rate: f32,
    /// Rounds of (limb search, `vertex_steps` vertex steps); a later round lets the search see
    /// limbs the earlier steps have settled. 0 = no vertex stage.
    pub vertex_rounds: usize,
    /// The global search over limb turns before each round's vertex steps (`None`: steps only).
    pub limb_search: Option<LimbSearch>,
    /// σ at the first vertex step, falling geometrically to `sigma` at the last (a wide σ lets a
    /// limb far from its drawn place feel it).
    pub vertex_sigma_start: f32,
    /// The share (0–1) of each round's vertex steps, the first ones, taken at half the working
    /// size (when it is even): while σ is wide the render is blurred anyway, and a quarter of the
    /// pixels costs less. 0 = every step at full size.
    pub vertex_coarse_share: f32,
    /// Soft-rasterizer σ (px² of the working square); the end of a training schedule suits.
    pub sigma: f32,
    /// The objective's weights (the paper's by default; frames over a background want `masked`).
    pub weights: LossWeights,
    /// The plausibility term: limbs kept inside these turn ranges (the limb search tries no turn
    /// out of them; the latent and vertex steps pay `plausibility_weight` × the penalty).
    /// `None`: no term.
    pub ranges: Option<JointRanges>,
    /// The weight of [`JointRanges::penalty`] in the objective; 0 leaves the fit free of the
    /// ranges (they are then only there to report against).
    pub plausibility_weight: f32,
    /// From the third round on, a frame whose previous round lowered its crisp L2 by less than
    /// this share (e.g. 0.005) takes no more rounds. 0 = every frame takes every round.
    pub min_round_gain: f64,
    /// After the vertex rounds, with an accessory rig, Adam steps on how far each accessory
    /// vertex is from where the rig puts it, the body and the pins held, the accessories' ARAP
    /// energy paid ([`AccessoryMoves`]), the first `vertex_coarse_share` of them at half size, at
    /// the final σ; a frame keeps the moves if they lower its crisp L2. 0 = the rig's placement
    /// exactly.
    pub accessory_steps: usize,
    /// Last, limbs the frame hides are turned towards their twins' mirrored turns
    /// ([`HiddenLimbs`]). `None`: left where the fit put them.
    pub hidden_limbs: Option<HiddenLimbs>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            latent_steps: DEFAULT_LATENT_STEPS,
            learning_rate: 0.02,
            vertex_steps: DEFAULT_VERTEX_STEPS,
            vertex_learning_rate: 0.3,
            vertex_sigma_start: 4.0,
            vertex_coarse_share: DEFAULT_VERTEX_COARSE_SHARE,
            min_round_gain: DEFAULT_MIN_ROUND_GAIN,
            accessory_steps: DEFAULT_ACCESSORY_STEPS,
            vertex_rounds: 3,
            limb_search: Some(LimbSearch::default()),
            sigma: 0.5,
            weights: LossWeights::default(),
            ranges: None,
            plausibility_weight: DEFAULT_PLAUSIBILITY_WEIGHT,
            hidden_limbs: None,
        }
    }
}

impl FitOptions {
    /// `latent_steps` latent and `vertex_steps` vertex steps with the loss weights and the σ
    /// schedule the model in `dir` was trained with (its `train.toml`: a model trained on frames
    /// over a background must fit with the masked loss too), or the defaults if it has none.
    ///
    /// # Errors
    /// [`Error::Io`] naming `train.toml` if it cannot be read, [`Error::Limit`] if it is larger
    /// than [`user_file::CONFIG`], [`Error::Format`] if it or its `[loss]` or `train.sigma` do not
    /// parse.
    pub fn for_model(dir: &Path, latent_steps: usize, vertex_steps: usize) -> Result<Self> {
        let path = ModelFolder::new(dir).config();
        let mut options = FitOptions {
            latent_steps,
            vertex_steps,
            ..FitOptions::default()
        };
        if !path.is_file() {
            return Ok(options);
        }
        let text = user_file::read_text(&path, user_file::CONFIG)?;
        let config: toml::Value = toml::from_str(&text).map_err(|e| Error::format(&path, e.to_string()))?;
        if let Some(loss) = config.get("loss") {
            options.weights = loss.clone().try_into().map_err(|e| Error::format(&path, format!("[loss]: {e}")))?;
        }
        if let Some(sigma) = config.get("train").and_then(|t| t.get("sigma")) {
            let [start, end]: [f32; 2] = sigma
                .clone()
                .try_into()
                .map_err(|e| Error::format(&path, format!("train.sigma: {e}")))?;
            (options.vertex_sigma_start, options.sigma) = (start, end);
        }
        Ok(options)
    }

    /// The encoder's one-pass fit, as the paper evaluates it.
    pub fn one_pass() -> Self {
        FitOptions {
            latent_steps: 0,
            vertex_steps: 0,
            ..FitOptions::default()
        }
    }

    /// These options placing the limbs a frame hides by their twins ([`HiddenLimbs`], learned
    /// from the network's poses of the frames the model in `model_dir` was trained on), the
    /// crisp L2 allowed to rise by `slack` (relative), if they are more than the encoder's pass
    /// ([`FitOptions::refines`]); unchanged, with a warning through `progress`, if those frames
    /// are gone.
    ///
    /// # Errors
    /// As [`frame::training_poses`].
    pub fn with_hidden_limbs(self, model_dir: &Path, model: &Model, slack: f64, device: &Device, progress: &dyn Progress) -> Result<Self> {
        if !self.refines() {
            return Ok(self);
        }
        let poses = frame::training_poses(model_dir, model, device, "hidden limbs stay where the fit leaves them", progress)?;
        Ok(FitOptions {
            hidden_limbs: poses.map(|p| HiddenLimbs::learn(&model.puppet, &p, slack)),
            ..self
        })
    }

    /// The ranges the fit keeps limbs in, if the plausibility term is on.
    pub fn plausible_ranges(&self) -> Option<&JointRanges> {
        self.ranges.as_ref().filter(|_| self.plausibility_weight > 0.0)
    }

    /// Whether the options go past the decoder's manifold (vertex steps in some round).
    pub fn moves_vertices(&self) -> bool {
        self.vertex_steps > 0 && self.vertex_rounds > 0
    }

    /// Whether the fit is more than the encoder's one pass (latent or vertex steps).
    pub fn refines(&self) -> bool {
        self.latent_steps > 0 || self.moves_vertices()
    }
}

/// Fits `frames` (the puppet's size) in batches fitted side by side (one for fewer than four
/// frames; otherwise two, or more of at most [`BATCH`]), advancing `progress` by each batch:
/// encoder, then `options.latent_steps` Adam steps per latent, then `options.vertex_rounds`
/// rounds of a limb search ([`LimbSearch`]) and `options.vertex_steps` Adam steps on the
/// vertices themselves. Returns the template vertices of each frame in frame pixels.
///
/// ```no_run
/// # fn main() -> puppet::Result<()> {
/// use std::path::Path;
/// let device = puppet::backend::device();
/// // A model folder written by `puppet train` (or `puppet demo`: out/demo/model).
/// let model = puppet::Model::load(Path::new("out/demo/model"), &device)?;
/// let frame = puppet::fit::frame::load_frame(Path::new("my_drawing.png"), &model)?;
/// let options = puppet::FitOptions::for_model(Path::new("out/demo/model"), 50, 100)?;
/// let poses = puppet::fit(&model, &[&frame], &options, &device, &puppet::Silent)?;
/// let drawn = puppet::render_crisp(&model.puppet, &poses[0], model.puppet.width, model.puppet.height)?;
/// drawn.save_png(Path::new("fitted.png"))?;
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// As [`fit_latents`].
pub fn fit(
    model: &Model,
    frames: &[&Picture],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Vec<Vec<[f32; 2]>>> {
    Ok(fit_with_latents(model, frames, options, device, progress)?.1)
}

/// [`fit`] that also returns each frame's latent `[N, Z]` after the latent steps: the point on
/// the decoder's manifold the vertex stage started from (an in-between's learned path runs
/// between these and is carried onto the fits by their residuals).
///
/// # Errors
/// As [`fit_latents`].
pub fn fit_with_latents(
    model: &Model,
    frames: &[&Picture],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<(Tensor<2>, Vec<Vec<[f32; 2]>>)> {
    if frames.is_empty() {
        return Ok((model.encode(frames, device)?, Vec::new()));
    }
    let (latents, poses) = fit_batches(model, frames, None, options, device, progress)?;
    Ok((Tensor::cat(latents.into_iter().flatten().collect(), 0), poses))
}

/// The latent-free stages of [`fit`] — vertex rounds (limb search and vertex steps), hidden
/// limbs, accessory moves — from `starts` (one pose per frame, frame pixels) instead of the
/// network's pass: how a pose placed by other means (the character-agnostic prior) is fitted.
/// `options.latent_steps` is ignored.
///
/// # Errors
/// [`Error::Mismatch`] if `starts` is not one pose of the puppet's vertex count per frame; as
/// [`fit_latents`].
pub fn fit_from(
    model: &Model,
    frames: &[&Picture],
    starts: &[Vec<[f32; 2]>],
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Vec<Vec<[f32; 2]>>> {
    if starts.len() != frames.len() {
        return Err(Error::mismatch(
            "the starting poses",
            starts.len(),
            format!("{}, one per frame", frames.len()),
        ));
    }
    let count = model.puppet.vertex_count();
    if let Some(bad) = starts.iter().find(|p| p.len() != count) {
        return Err(Error::mismatch("a starting pose's vertices", bad.len(), count));
    }
    if frames.is_empty() {
        return Ok(Vec::new());
    }
    Ok(fit_batches(model, frames, Some(starts), options, device, progress)?.1)
}

/// [`fit_with_latents`] or, with `starts`, [`fit_from`]: the batches' latents (none from
/// starts) and every frame's pose.
fn fit_batches(
    model: &Model,
    frames: &[&Picture],
    starts: Option<&[Vec<[f32; 2]>]>,
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<(Vec<Option<Tensor<2>>>, Poses)> {
    // One batch's many small steps keep about one core busy, so from four frames on they are split
    // into batches fitted side by side: two, or more of at most `BATCH`. A frame's fit does not
    // depend on the frames beside it (`Analysis::descend`) as long as it has company: a frame
    // fitted alone lands a little elsewhere (docs/results.md "Frames in two batches side by side";
    // Burn's kernels for a single row sum in another order, the likely cause). So no batch holds
    // one frame unless one is all there is, and the split depends on the frame count, not on the
    // machine's cores: a fit is the same wherever it runs.
    let n = frames.len();
    let count = if n < 4 { 1 } else { n.div_ceil(BATCH).max(2) };
    let batches: Vec<(Option<Tensor<2>>, Poses)> = (0..count)
        .into_par_iter()
        .map(|k| {
            let range = k * n / count..(k + 1) * n / count;
            let chunk = &frames[range.clone()];
            let fitted = match starts {
                Some(starts) => (None, fit_batch_from(model, chunk, starts[range].to_vec(), options, device)?),
                None => {
                    let (z, poses) = fit_batch(model, chunk, options, device)?;
                    (Some(z), poses)
                }
            };
            progress.advance(chunk.len() as u64);
            Ok(fitted)
        })
        .collect::<Result<_>>()?;
    let (latents, poses): (Vec<_>, Vec<_>) = batches.into_iter().unzip();
    Ok((latents, poses.into_iter().flatten().collect()))
}

/// One batch of [`fit`]: the latents after the latent steps and the fitted poses.
fn fit_batch(model: &Model, frames: &[&Picture], options: &FitOptions, device: &Device) -> Result<(Tensor<2>, Vec<Vec<[f32; 2]>>)> {
    if !options.refines() || frames.is_empty() {
        let z = model.encode(frames, device)?;
        let mut poses = model.to_frame_vertices(model.decode(z.clone(), device));
        if let Some(hidden) = options.hidden_limbs.as_ref().filter(|_| !frames.is_empty()) {
            place_hidden_limbs(hidden, &SoftRasterizer::new(&model.puppet)?, model, frames, &mut poses)?;
        }
        return Ok((z, poses));
    }
    // One analysis (rasterizer, objective, network input) for every stage.
    let analysis = Analysis::new(model, frames, options, device)?;
    let z = analysis.latents(model.net.encode(analysis.images.clone()))?;
    let poses = model.to_frame_vertices(model.decode(z.clone(), device));
    Ok((z, latent_free_stages(&analysis, frames, poses)?))
}

/// One batch of [`fit_from`].
fn fit_batch_from(
    model: &Model,
    frames: &[&Picture],
    starts: Vec<Vec<[f32; 2]>>,
    options: &FitOptions,
    device: &Device,
) -> Result<Vec<Vec<[f32; 2]>>> {
    let analysis = Analysis::new(model, frames, options, device)?;
    latent_free_stages(&analysis, frames, starts)
}

/// The stages after the latents, from `poses`: vertex rounds, hidden limbs, accessory moves.
fn latent_free_stages(analysis: &Analysis, frames: &[&Picture], mut poses: Vec<Vec<[f32; 2]>>) -> Result<Vec<Vec<[f32; 2]>>> {
    let (model, options) = (analysis.model, analysis.options);
    if options.moves_vertices() {
        vertex_rounds(analysis, frames, &mut poses)?;
    }
    if let Some(hidden) = &options.hidden_limbs {
        place_hidden_limbs(hidden, analysis.objective.raster(), model, frames, &mut poses)?;
    }
    if options.moves_vertices() && options.accessory_steps > 0 {
        move_accessories(analysis, frames, &mut poses)?;
    }
    Ok(poses)
}

/// With an accessory rig, each pose's accessories moved from where the rig puts them
/// ([`AccessoryMoves`]), moves that turn triangles over taken back; a frame keeps the moves only
/// if they lower its crisp L2 too (the steps lower the soft objective, and the rig's placement
/// is often the drawing's already).
fn move_accessories(analysis: &Analysis, frames: &[&Picture], poses: &mut [Vec<[f32; 2]>]) -> Result<()> {
    let model = analysis.model;
    let Some(moves) = AccessoryMoves::new(model, analysis.device)? else {
        return Ok(());
    };
    let free = model.to_work_free(poses, analysis.device);
    let moved = model.to_frame_vertices(analysis.accessories(free, &moves)?);
    for ((pose, mut moved), frame) in poses.iter_mut().zip(moved).zip(frames) {
        accessory_moves::unfold(&model.puppet, pose, &mut moved);
        let scores =
            limb_search::CrispScorer::new(analysis.objective.raster(), &model.puppet, frame).full(&[pose.as_slice(), &moved].concat())?;
        if scores[1] < scores[0] {
            *pose = moved;
        }
    }
    Ok(())
}

/// `options.vertex_rounds` rounds of a limb search and vertex steps on `poses` (frame pixels), one
/// per frame of `analysis`; from the third round on, a frame whose previous round gained less
/// than `options.min_round_gain` takes no more.
fn vertex_rounds(analysis: &Analysis, frames: &[&Picture], poses: &mut [Vec<[f32; 2]>]) -> Result<()> {
    let (model, options, device) = (analysis.model, analysis.options, analysis.device);
    // The frames still in the rounds, and each one's crisp L2 after its last two rounds.
    let mut active: Vec<usize> = (0..frames.len()).collect();
    let mut scores: Vec<[f64; 2]> = vec![[f64::INFINITY; 2]; frames.len()];
    let raster = analysis.objective.raster().clone();
    for round in 0..options.vertex_rounds {
        if round >= 2 && options.min_round_gain > 0.0 {
            // A frame whose last round lowered its L2 by less than the gain asked for is done.
            active.retain(|&i| scores[i][0] - scores[i][1] > options.min_round_gain * scores[i][0]);
            if active.is_empty() {
                break;
            }
        }
        let subset: Vec<&Picture> = active.iter().map(|&i| frames[i]).collect();
        let mut moving: Vec<Vec<[f32; 2]>> = active.iter().map(|&i| poses[i].clone()).collect();
        if let Some(search) = &options.limb_search {
            for (pose, frame) in moving.iter_mut().zip(&subset) {
                search.improve(
                    &raster,
                    &model.puppet,
                    model.expansion.rig_map(),
                    options.plausible_ranges(),
                    frame,
                    pose,
                )?;
            }
        }
        let moved = if active.len() == frames.len() {
            analysis.vertices(model.to_work_free(&moving, device))?
        } else {
            Analysis::new(model, &subset, options, device)?.vertices(model.to_work_free(&moving, device))?
        };
        for (&i, pose) in active.iter().zip(model.to_frame_vertices(analysis.decoder.expand(moved))) {
            poses[i] = pose;
        }
        if options.min_round_gain > 0.0 && round + 1 < options.vertex_rounds {
            for &i in &active {
                let now = limb_search::CrispScorer::new(&raster, &model.puppet, frames[i]).full(&poses[i])?[0];
                scores[i] = [scores[i][1], now];
            }
        }
    }
    Ok(())
}

/// Each pose's hidden limbs turned towards their twins' mirrored turns ([`HiddenLimbs::place`]).
fn place_hidden_limbs(
    hidden: &HiddenLimbs,
    raster: &SoftRasterizer,
    model: &Model,
    frames: &[&Picture],
    poses: &mut [Vec<[f32; 2]>],
) -> Result<()> {
    for (pose, frame) in poses.iter_mut().zip(frames) {
        hidden.place(raster, &model.puppet, model.expansion.rig_map(), frame, pose)?;
    }
    Ok(())
}

/// The latents `[B, Z]` of `frames` (one batch): the encoder's, then `options.latent_steps`
/// Adam steps each.
///
/// # Errors
/// As [`Model::input`]; [`Error::Setting`] for a non-positive σ or step size.
pub fn fit_latents(model: &Model, frames: &[&Picture], options: &FitOptions, device: &Device) -> Result<Tensor<2>> {
    if options.latent_steps == 0 || frames.is_empty() {
        return model.encode(frames, device);
    }
    let analysis = Analysis::new(model, frames, options, device)?;
    analysis.latents(model.net.encode(analysis.images.clone()))
}

/// `options.latent_steps` Adam steps on the latents `z0` `[B, Z]` of `frames` (one batch): the
/// latent stage of [`fit_latents`] from a start found another way (a pose pulled onto the
/// manifold).
///
/// # Errors
/// As [`fit_latents`]; [`Error::Mismatch`] if `z0` is not one latent of the model's size per
/// frame.
pub fn refine_latents(model: &Model, frames: &[&Picture], z0: Tensor<2>, options: &FitOptions, device: &Device) -> Result<Tensor<2>> {
    let expected = [frames.len(), model.config.latent];
    if z0.dims() != expected {
        return Err(Error::mismatch(
            "the starting latents",
            format!("{:?}", z0.dims()),
            format!("{expected:?}"),
        ));
    }
    if options.latent_steps == 0 || frames.is_empty() {
        return Ok(z0);
    }
    Analysis::new(model, frames, options, device)?.latents(z0)
}

/// Analysis by synthesis of a batch of frames: the training objective through the soft
/// rasterizer, lowered by Adam on the latents or on the vertices.
struct Analysis<'a> {
    model: &'a Model,
    options: &'a FitOptions,
    device: &'a Device,
    images: Tensor<4>,
    objective: Objective,
    /// The objective and targets at 1/[`COARSE_FACTOR`] of the working size, for the first
    /// vertex steps of each round (`None` when none are taken there, or the factor does not
    /// divide the working size).
    coarse: Option<(Objective, Tensor<4>)>,
    decoder: Decoder,
}

impl<'a> Analysis<'a> {
    fn new(model: &'a Model, frames: &[&Picture], options: &'a FitOptions, device: &'a Device) -> Result<Self> {
        let positive = |name: &str, v: f32| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(Error::setting(format!("fit {name}"), v, "positive"))
            }
        };
        positive("sigma", options.sigma)?;
        positive("latent learning rate", options.learning_rate)?;
        positive("vertex learning rate", options.vertex_learning_rate)?;
        let share = options.vertex_coarse_share;
        if !(0.0..=1.0).contains(&share) {
            return Err(Error::setting("fit vertex coarse share", share, "a number from 0 to 1"));
        }
        let size = model.letterbox.size as usize;
        let rest_points = model.rest_work_points();
        let images = model.input(frames, device)?;
        let coarse = if options.moves_vertices() && share > 0.0 && size.is_multiple_of(COARSE_FACTOR) {
            let objective = Objective::downsampled(&model.puppet, &rest_points, size, options.weights.clone(), COARSE_FACTOR)?;
            Some((objective, downsample(images.clone(), COARSE_FACTOR)))
        } else {
            None
        };
        Ok(Analysis {
            model,
            options,
            device,
            images,
            objective: Objective::new(&model.puppet, &rest_points, size, options.weights.clone())?,
            coarse,
            decoder: model.decoder(device),
        })
    }

    /// `options.latent_steps` Adam steps on the latents `z0` through the decoder.
    fn latents(&self, z0: Tensor<2>) -> Result<Tensor<2>> {
        let level = Level {
            objective: &self.objective,
            images: &self.images,
            scale: 1.0,
            sigma: self.options.sigma,
        };
        self.descend(
            z0,
            self.options.latent_steps,
            self.options.learning_rate,
            |_| level.clone(),
            |z| Ok((self.decoder.vertices(&self.model.net, z), None)),
        )
    }

    /// `options.vertex_steps` Adam steps on the working-square free vertices `[B, Vb, 2]`
    /// themselves (the body's, with a rig: the accessories follow it).
    fn vertices(&self, free: Tensor<3>) -> Result<Tensor<3>> {
        let steps = self.options.vertex_steps;
        self.descend(
            free,
            steps,
            self.options.vertex_learning_rate,
            |k| self.vertex_level(k, steps),
            |v| Ok((self.decoder.expand(v), None)),
        )
    }

    /// `options.accessory_steps` Adam steps on the moves of the accessories of `moves` from where
    /// the rig puts them on the body `free` `[B, Vb, 2]` (held); every vertex `[B, V, 2]`.
    fn accessories(&self, free: Tensor<3>, moves: &AccessoryMoves) -> Result<Tensor<3>> {
        let steps = self.options.accessory_steps;
        let zero = Tensor::<3>::zeros([free.dims()[0], moves.count(), 2], self.device);
        let weight = self.options.weights.arap;
        let fitted = self.descend(
            zero,
            steps,
            self.options.vertex_learning_rate,
            // At the end of the σ schedule throughout: the body is in place, and the moves are
            // small.
            |k| self.level(k, steps, self.options.sigma),
            |m| {
                let all = self.decoder.expand_moved(free.clone(), moves.pinned(m));
                let bending = moves.energy(all.clone())?.mul_scalar(weight);
                Ok((all, Some(bending)))
            },
        )?;
        Ok(self.decoder.expand_moved(free, moves.pinned(fitted)))
    }

    /// Where step `k` of `steps` on the vertices is scored: σ falls geometrically from the
    /// schedule's start to its end ([`Analysis::level`]).
    fn vertex_level(&self, k: usize, steps: usize) -> Level<'_> {
        let (start, end) = (self.options.vertex_sigma_start.max(self.options.sigma), self.options.sigma);
        self.level(k, steps, start * (end / start).powf(k as f32 / (steps.max(2) - 1) as f32))
    }

    /// Where step `k` of `steps` is scored at `sigma` (px² of the working square): the first
    /// `vertex_coarse_share` of the steps at half size.
    fn level(&self, k: usize, steps: usize, sigma: f32) -> Level<'_> {
        let coarse_steps = (self.options.vertex_coarse_share * steps as f32).round() as usize;
        match &self.coarse {
            // σ is in px² of the square rendered.
            Some((objective, images)) if k < coarse_steps => Level {
                objective,
                images,
                scale: 1.0 / COARSE_FACTOR as f32,
                sigma: sigma / (COARSE_FACTOR * COARSE_FACTOR) as f32,
            },
            _ => Level {
                objective: &self.objective,
                images: &self.images,
                scale: 1.0,
                sigma,
            },
        }
    }

    /// Adam on `x`, whose image under `to_vertices` — every vertex, and a term of its own if
    /// any, a batch mean — is scored by the objective. The objective is
    /// a batch mean, so each frame's unknowns see only its own frame's terms, scaled by 1/B; the
    /// total is multiplied back by B because Adam's ε is not scale-free: without it a frame's fit
    /// depended on how many frames shared its batch.
    fn descend<'s, const D: usize>(
        &'s self,
        x0: Tensor<D>,
        steps: usize,
        learning_rate: f32,
        level: impl Fn(usize) -> Level<'s>,
        to_vertices: impl Fn(Tensor<D>) -> Result<(Tensor<3>, Option<Tensor<1>>)>,
    ) -> Result<Tensor<D>> {
        let shape = x0.dims();
        let mut x = to_vec(x0);
        // PyTorch's defaults (ε = 1e-8), as in training.
        let mut adam = FlatAdam::new(AdamSettings::default(), x.len());
        let batch = shape[0] as f32;
        for k in 0..steps {
            let xt = Tensor::<D>::from_data(TensorData::new(x.clone(), shape), self.device)
                .autodiff()
                .require_grad();
            let (vertices, own_term) = to_vertices(xt.clone())?;
            let at = level(k);
            let scaled = if at.scale == 1.0 {
                vertices.clone()
            } else {
                vertices.clone().mul_scalar(at.scale)
            };
            let mut total = at.objective.evaluate(scaled, at.images.clone(), at.sigma, self.device)?.total;
            if let Some(ranges) = self.options.plausible_ranges() {
                total = total + ranges.penalty(vertices, self.device).mul_scalar(self.options.plausibility_weight);
            }
            if let Some(term) = own_term {
                total = total + term;
            }
            let grads = total.mul_scalar(batch).backward();
            let g = xt
                .grad(&grads)
                .ok_or_else(|| Error::backend("fit", "no gradient reached the unknowns"))?;
            adam.step(&mut x, &to_vec(g), f64::from(learning_rate));
        }
        Ok(Tensor::<D>::from_data(TensorData::new(x, shape), self.device))
    }
}

/// Where one step is scored: an objective, its targets, the scale from working pixels to its
/// square, and σ there.
#[derive(Clone)]
struct Level<'a> {
    objective: &'a Objective,
    images: &'a Tensor<4>,
    scale: f32,
    sigma: f32,
}

fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().convert::<f32>().try_into_vec::<f32>().unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_follow_the_models_training_objective_and_name_a_bad_config() {
        let dir = tempfile::tempdir().unwrap();
        let defaults = FitOptions::for_model(dir.path(), 7, 3).unwrap();
        assert_eq!(
            defaults,
            FitOptions {
                latent_steps: 7,
                vertex_steps: 3,
                ..FitOptions::default()
            }
        );
        let config = "puppet = \"p\"\n[train]\nsigma = [2.0, 0.25]\n[loss]\narap = 10.0\nmasked = true\n";
        let config_file = ModelFolder::new(dir.path()).config();
        std::fs::write(&config_file, config).unwrap();
        let o = FitOptions::for_model(dir.path(), 7, 3).unwrap();
        assert_eq!((o.latent_steps, o.vertex_sigma_start, o.sigma), (7, 2.0, 0.25));
        assert_eq!((o.weights.arap, o.weights.masked), (10.0, true));
        assert_eq!(o.weights.joints, LossWeights::default().joints, "unset weights keep their defaults");
        std::fs::write(&config_file, "[loss]\narap = \"strong\"\n").unwrap();
        let err = FitOptions::for_model(dir.path(), 7, 3).unwrap_err().to_string();
        assert!(err.contains(ModelFolder::CONFIG) && err.contains("[loss]"), "{err}");
    }

    /// A model of [`crate::test_util::layered_puppet`] whose working square is the puppet's own
    /// 48 pixels (at 16, `tiny_model`'s, a limb would be a pixel wide at half size), untrained
    /// (it decodes the rest pose), and a frame of it shifted with the front arm lowered further.
    fn model_and_frame() -> (Model, Device, Picture) {
        let (model, device) = crate::test_util::untrained_model(crate::test_util::layered_puppet(), 48);
        let puppet = &model.puppet;
        let arm = puppet.layer_index("arm_front").unwrap();
        let drawn: Vec<[f32; 2]> = puppet
            .layers
            .iter()
            .enumerate()
            .flat_map(|(l, layer)| {
                let dy = if l == arm { 4.0 } else { 1.5 };
                layer.mesh.vertices.iter().map(move |v| [v[0] + 2.0, v[1] + dy])
            })
            .collect();
        let frame = crate::render::render_crisp(puppet, &drawn, puppet.width, puppet.height).unwrap();
        (model, device, frame)
    }

    #[test]
    fn vertex_steps_at_half_size_fit_as_close_as_at_full_size_and_a_bad_share_is_refused() {
        let (model, device, frame) = model_and_frame();
        let puppet = &model.puppet;
        let l2 = |pose: &[[f32; 2]]| {
            crate::metrics::l2(
                &crate::render::render_crisp(puppet, pose, puppet.width, puppet.height).unwrap(),
                &frame,
            )
        };
        let fit_with = |share: f32| {
            let options = FitOptions {
                latent_steps: 0,
                vertex_steps: 60,
                vertex_rounds: 1,
                limb_search: None,
                vertex_coarse_share: share,
                ..FitOptions::default()
            };
            fit(&model, &[&frame], &options, &device, &crate::progress::Silent).map(|mut poses| poses.remove(0))
        };
        let start = l2(&fit(&model, &[&frame], &FitOptions::one_pass(), &device, &crate::progress::Silent).unwrap()[0]);
        let (full, coarse) = (l2(&fit_with(0.0).unwrap()), l2(&fit_with(0.75).unwrap()));
        assert!(full < 0.5 * start, "the steps fit: {start} → {full}");
        assert!(
            coarse < 1.15 * full,
            "half-size steps first: {coarse} against {full} (from {start})"
        );
        let err = fit_with(1.5).unwrap_err().to_string();
        assert!(err.contains("coarse share") && err.contains("0 to 1"), "{err}");
    }

    #[test]
    fn frames_whose_round_gained_too_little_take_no_more_rounds() {
        let (model, device, shifted) = model_and_frame();
        // The pose the untrained model decodes: nothing for a round to gain.
        let puppet = &model.puppet;
        let rest = crate::render::render_crisp(puppet, &puppet.rest_vertices(), puppet.width, puppet.height).unwrap();
        let fit_with = |frames: &[&Picture], rounds: usize, min_round_gain: f64| {
            let options = FitOptions {
                latent_steps: 0,
                vertex_steps: 20,
                vertex_rounds: rounds,
                min_round_gain,
                ..FitOptions::default()
            };
            fit(&model, frames, &options, &device, &crate::progress::Silent).unwrap()
        };
        let both = [&shifted, &rest];
        let two = fit_with(&both, 2, 0.0);
        // No round gains all of the L2: every frame stops after its second round.
        assert_eq!(fit_with(&both, 3, 1.0), two);
        let three = fit_with(&both, 3, 0.0);
        assert_ne!(three[0], two[0], "a third round moves the shifted frame's pose");
        // With a small gain asked for, the frame at rest stops and the shifted one goes on, each
        // as if fitted alone (a frame's terms are its own).
        let some = fit_with(&both, 3, 1e-4);
        let close = |a: &[[f32; 2]], b: &[[f32; 2]]| {
            let worst = crate::test_util::largest_distance(a, b);
            assert!(worst < 1e-3, "{worst} px apart");
        };
        close(&some[1], &fit_with(&[&rest], 2, 0.0)[0]);
        close(&some[0], &fit_with(&[&shifted], 3, 0.0)[0]);
    }

    /// `fit` splits four frames or more into batches; each frame's pose and latent are exactly
    /// what one batch of all the frames gives.
    #[test]
    fn frames_split_into_batches_fit_as_in_one() {
        let (model, device, shifted) = model_and_frame();
        let puppet = &model.puppet;
        let rest = crate::render::render_crisp(puppet, &puppet.rest_vertices(), puppet.width, puppet.height).unwrap();
        let options = FitOptions {
            latent_steps: 5,
            vertex_steps: 20,
            vertex_rounds: 2,
            ..FitOptions::default()
        };
        for frames in [
            vec![&shifted, &rest, &shifted, &rest],
            vec![&rest, &shifted, &shifted, &rest, &shifted],
        ] {
            let (z, split) = fit_with_latents(&model, &frames, &options, &device, &crate::progress::Silent).unwrap();
            let (z_one, one) = fit_batch(&model, &frames, &options, &device).unwrap();
            assert_eq!(split, one, "{} frames", frames.len());
            assert_eq!(z.into_data(), z_one.into_data(), "{} frames", frames.len());
        }
    }
}
