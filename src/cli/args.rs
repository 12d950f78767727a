//! Arguments several commands share, declared once and flattened into each (STYLE.md §1): the
//! model folder, how frames are fitted, how animations are written, sizes, pins and colours.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use puppet::edit::pin::Pin;
use puppet::model::Model;
use puppet::parts::learn::TrainedNet;
use puppet::picture::ImageLimits;
use puppet::picture::Picture;
use puppet::prior::{fit_untrained, fit_with_prior, template_model, PriorFit, Start};
use puppet::puppet::{artwork, build::BuildOptions, LayerKind};
use puppet::render::animation::AnimationFiles;
use puppet::render::Background;
use puppet::rig::outfit::{dress, undress};
use puppet::rig::RigOptions;
use puppet::train::trainer::load_or_build_puppet;

use super::ui::Ui;
use burn::tensor::Device;
use puppet::fit::frame::training_poses;
use puppet::fit::hidden_limbs::{HiddenLimbs, DEFAULT_SLACK};
use puppet::fit::plausible::JointRanges;
use puppet::fit::{
    fit, limb_search::LimbSearch, FitOptions, DEFAULT_ACCESSORY_STEPS, DEFAULT_LATENT_STEPS, DEFAULT_MIN_ROUND_GAIN,
    DEFAULT_PLAUSIBILITY_WEIGHT, DEFAULT_PLAUSIBLE_MARGIN, DEFAULT_VERTEX_STEPS,
};

/// The trained model a command uses.
#[derive(Debug, clap::Args)]
pub struct ModelArgs {
    /// The model folder written by `puppet train` (or `puppet demo`: out/demo/model).
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
}

/// What fits a command's frames: a trained model, or a puppet nobody trained, placed by the
/// character-agnostic prior.
#[derive(Debug, clap::Args)]
pub struct FitSourceArgs {
    /// The model folder written by `puppet train` (or `puppet demo`: out/demo/model).
    #[arg(long, value_name = "DIR", required_unless_present = "puppet", conflicts_with = "puppet")]
    pub model: Option<PathBuf>,
    /// Fit a character nobody trained: a puppet folder, or artwork (built on the spot, with its
    /// accessory rig). Each frame is placed by the prior puppet ships, then fitted by the stages
    /// that need no network of the character (limb search and vertex steps).
    #[arg(long, value_name = "DIR")]
    pub puppet: Option<PathBuf>,
    /// With --model: fit each frame twice, from the network's pass and latent steps and from the
    /// prior's placement, and keep the fit that renders closer to the frame (twice the time).
    #[arg(long, requires = "model")]
    pub prior: bool,
    /// Another prior than the built-in one: a `puppet prior train` run folder.
    #[arg(long, value_name = "DIR")]
    pub prior_net: Option<PathBuf>,
}

/// What [`FitSourceArgs`] names, loaded.
pub struct FitSource {
    /// The trained model, or the puppet's template model.
    pub model: Model,
    /// The trained model's folder (`None` for a puppet nobody trained).
    pub dir: Option<PathBuf>,
    /// The prior, when it is used.
    pub prior: Option<TrainedNet>,
}

impl FitSourceArgs {
    /// Loads the model or builds the puppet's template model, and the prior if it is used.
    pub fn load(&self, device: &Device, ui: &Ui) -> anyhow::Result<FitSource> {
        let (model, dir) = match (&self.model, &self.puppet) {
            (Some(dir), _) => (Model::load(dir, device)?, Some(dir.clone())),
            (None, Some(path)) => {
                let puppet = load_or_build_puppet(path, &ImageLimits::default(), true, ui)
                    .with_context(|| format!("while reading the puppet {}", path.display()))?;
                (template_model(puppet, TEMPLATE_SIZE, device)?, None)
            }
            (None, None) => anyhow::bail!("give --model or --puppet"),
        };
        let prior = if self.prior || dir.is_none() {
            Some(puppet::prior::load_or_shipped(self.prior_net.as_deref(), device)?)
        } else {
            None
        };
        Ok(FitSource { model, dir, prior })
    }
}

/// The fits of [`FitSource::fit`].
pub struct Fits {
    /// Each frame's pose (frame pixels, global numbering).
    pub poses: Vec<Vec<[f32; 2]>>,
    /// Where both starts were tried (`--model` with `--prior`), the one each kept fit came from.
    pub starts: Option<Vec<Start>>,
}

impl FitSource {
    /// Fits `frames` as the source says: by the trained model, by it and from the prior's
    /// placement (keeping the closer fit), or, for a puppet nobody trained, from the prior's
    /// placement alone.
    pub fn fit(&self, frames: &[&Picture], options: &FitOptions, device: &Device, ui: &Ui) -> puppet::Result<Fits> {
        Ok(match (&self.dir, &self.prior) {
            (_, None) => Fits {
                poses: fit(&self.model, frames, options, device, ui)?,
                starts: None,
            },
            (Some(_), Some(prior)) => {
                let PriorFit { poses, starts } = fit_with_prior(prior, &self.model, frames, options, device, ui)?;
                Fits {
                    poses,
                    starts: Some(starts),
                }
            }
            (None, Some(prior)) => Fits {
                poses: fit_untrained(prior, &self.model, frames, options, device, ui)?,
                starts: None,
            },
        })
    }
}

/// The working square of a puppet fitted with no trained model: the size every shipped config
/// trains at.
const TEMPLATE_SIZE: usize = 128;

/// How an edit fits its frames: latent steps only, since in-betweens and drags move latents.
#[derive(Debug, clap::Args)]
pub struct LatentFitArgs {
    /// After the encoder, this many Adam steps on each frame's latent lowering the training
    /// objective for that frame (analysis by synthesis; the weights do not change). 0 = the
    /// encoder's one-pass fit, as the paper evaluates; ~0.1 s per step for 16 frames at 128².
    #[arg(long, default_value_t = DEFAULT_LATENT_STEPS, value_name = "N")]
    pub latent_steps: usize,
}

impl LatentFitArgs {
    /// Latent steps with the objective the model in `model_dir` was trained with.
    pub fn options(&self, model_dir: &Path) -> puppet::Result<FitOptions> {
        FitOptions::for_model(model_dir, self.latent_steps, 0)
    }
}

/// How a command whose result is a fit (`fit`, `eval`, `correspond`) fits frames.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    #[command(flatten)]
    pub latent: LatentFitArgs,
    /// Then this many Adam steps on the vertices themselves per round, σ falling from the
    /// training's first to its last: off the decoder's manifold, held by the ARAP and joint
    /// terms — a closer fit of poses the training frames never showed. 0 = stay on the manifold
    /// (no limb search either); ~0.03 s per step for 16 frames at 128².
    #[arg(long, default_value_t = DEFAULT_VERTEX_STEPS, value_name = "N")]
    pub vertex_steps: usize,
    /// Rounds of vertex steps, each after a search over limb turns about their joints (for
    /// limbs drawn far from where the network put them).
    #[arg(long, default_value_t = FitOptions::default().vertex_rounds, value_name = "N")]
    pub vertex_rounds: usize,
    /// The share (0–1) of each round's vertex steps, the first, wide-σ ones, taken at half the
    /// working size (a quarter of the pixels).
    #[arg(long, default_value_t = FitOptions::default().vertex_coarse_share, value_name = "SHARE")]
    pub vertex_coarse_share: f32,
    /// From the third round on, a frame whose previous round lowered its L2 by less than this
    /// (percent) takes no more rounds; 0 = every frame takes every round.
    #[arg(long, default_value_t = 100.0 * DEFAULT_MIN_ROUND_GAIN, value_name = "PERCENT")]
    pub min_round_gain: f64,
    /// With an accessory rig, then this many Adam steps on how far each accessory vertex is from
    /// where the rig puts it (a drawn accessory is seldom exactly there), the body and the rig's
    /// pins held, bending paid for as the body's is. 0 = accessories exactly where the rig puts
    /// them.
    #[arg(long, default_value_t = DEFAULT_ACCESSORY_STEPS, value_name = "N")]
    pub accessory_steps: usize,
    /// Skip the limb search: vertex steps only.
    #[arg(long)]
    pub no_limb_search: bool,
    /// The paper's one-pass fit: no latent or vertex steps (overrides the options of both), and no
    /// hidden limbs placed.
    #[arg(long)]
    pub one_pass: bool,
    /// Keep each limb's turn about its joint within this many degrees of the turns the network
    /// gives the training frames (read again from split.json): the limb search tries no turn
    /// past it and the steps pay for going past it, so a pose the character cannot take degrades
    /// to a near one instead of contorting.
    #[arg(long, default_value_t = DEFAULT_PLAUSIBLE_MARGIN, value_name = "DEGREES")]
    pub plausible_margin: f32,
    /// The weight of that plausibility term in the steps' objective; 0 = no term (`puppet fit`
    /// still names limbs turned past the range).
    #[arg(long, default_value_t = DEFAULT_PLAUSIBILITY_WEIGHT, value_name = "W")]
    pub plausibility_weight: f32,
    /// Leave limbs the frame hides (a back arm behind the torso) where the fit put them, instead
    /// of turning them to their twin's turn mirrored (the front arm's, as the training frames
    /// that show both relate them), as far as the render allows.
    #[arg(long)]
    pub no_hidden_limbs: bool,
    /// How much the rendered fit may move away from the frame (L2, percent) as a hidden limb is
    /// turned into place.
    #[arg(long, default_value_t = 100.0 * DEFAULT_SLACK, value_name = "PERCENT")]
    pub hidden_limb_slack: f64,
}

impl FitArgs {
    /// The fit options for `model`, read from `model_dir`: the objective it was trained with;
    /// with steps to take (more than the one pass) and the plausibility term on or hidden limbs
    /// placed, the network's poses of its training frames, for the turn ranges and the twins (a
    /// warning through `ui` if those frames are gone).
    ///
    /// Without a model folder (a puppet nobody trained): the default objective, no latent steps,
    /// no training poses.
    pub fn options(&self, model_dir: Option<&Path>, model: &Model, device: &Device, ui: &Ui) -> puppet::Result<FitOptions> {
        let (latent, vertex) = match (self.one_pass, model_dir) {
            (true, _) => (0, 0),
            (false, Some(_)) => (self.latent.latent_steps, self.vertex_steps),
            (false, None) => (0, self.vertex_steps),
        };
        let options = match model_dir {
            Some(dir) => FitOptions::for_model(dir, latent, vertex)?,
            None => FitOptions {
                latent_steps: 0,
                vertex_steps: vertex,
                ..FitOptions::default()
            },
        };
        for (name, v) in [
            ("--plausible-margin", self.plausible_margin),
            ("--plausibility-weight", self.plausibility_weight),
            ("--hidden-limb-slack", self.hidden_limb_slack as f32),
            ("--min-round-gain", self.min_round_gain as f32),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(puppet::Error::setting(name, v, "a finite number ≥ 0"));
            }
        }
        if !(0.0..=1.0).contains(&self.vertex_coarse_share) {
            return Err(puppet::Error::setting(
                "--vertex-coarse-share",
                self.vertex_coarse_share,
                "a number from 0 to 1",
            ));
        }
        // The training poses are read (and encoded) once, for whichever of the plausibility
        // ranges and the hidden limbs' twins needs them; the ranges are kept whenever they are
        // read, to name unseen poses even with the term off.
        let refines = latent > 0 || (vertex > 0 && self.vertex_rounds > 0);
        let plausible = refines && self.plausibility_weight > 0.0;
        let hidden = refines && !self.no_hidden_limbs;
        let purpose = match (plausible, hidden) {
            (true, true) => "fitting without the plausibility term, hidden limbs where the fit leaves them",
            (true, false) => "fitting without the plausibility term",
            _ => "hidden limbs stay where the fit leaves them",
        };
        let poses = match model_dir {
            Some(dir) if plausible || hidden => training_poses(dir, model, device, purpose, ui)?,
            _ => None,
        };
        Ok(FitOptions {
            vertex_rounds: self.vertex_rounds,
            vertex_coarse_share: self.vertex_coarse_share,
            min_round_gain: self.min_round_gain / 100.0,
            accessory_steps: self.accessory_steps,
            limb_search: (!self.no_limb_search).then(LimbSearch::default),
            ranges: poses
                .as_ref()
                .map(|p| JointRanges::from_poses(&model.puppet, p, self.plausible_margin)),
            plausibility_weight: self.plausibility_weight,
            hidden_limbs: poses
                .as_ref()
                .filter(|_| hidden)
                .map(|p| HiddenLimbs::learn(&model.puppet, p, self.hidden_limb_slack / 100.0)),
            ..options
        })
    }

    /// The turn ranges of `model`'s training frames widened by `--plausible-margin` (`None`, with
    /// a warning naming what `purpose` goes without, if those frames are gone).
    pub fn training_ranges(
        &self,
        model_dir: &Path,
        model: &Model,
        device: &Device,
        purpose: &str,
        ui: &Ui,
    ) -> puppet::Result<Option<JointRanges>> {
        let poses = training_poses(model_dir, model, device, purpose, ui)?;
        Ok(poses.map(|p| JointRanges::from_poses(&model.puppet, &p, self.plausible_margin)))
    }
}

/// Another outfit for what a command draws (the frames it reads show the model's own).
#[derive(Debug, Default, clap::Args)]
pub struct OutfitArgs {
    /// Draw the results in the accessories of this artwork instead (PNG layers + character.toml,
    /// .ora or .psd): the same body in another outfit, rigged against the model's body on the spot.
    /// Needs a model trained with the rig (or one without accessories).
    #[arg(long, value_name = "ARTWORK")]
    pub dress: Option<PathBuf>,
    /// Draw the results without these accessories (comma-separated layer names), and without
    /// whatever follows them.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub undress: Vec<String>,
}

impl OutfitArgs {
    /// The model drawing the outfit asked for, or `None` to draw the model's own. Vertex files
    /// written from it are poses of its puppet.
    pub fn model(&self, model: &Model, ui: &Ui) -> anyhow::Result<Option<Model>> {
        if self.dress.is_none() && self.undress.is_empty() {
            return Ok(None);
        }
        let started = std::time::Instant::now();
        let mut puppet = model.puppet.clone();
        if let Some(path) = &self.dress {
            let art = artwork::load_reporting(path, &artwork::ImportOptions::default(), ui)?;
            puppet = dress(&puppet, &art, &BuildOptions::default(), &RigOptions::default(), ui).context("--dress")?;
        }
        if !self.undress.is_empty() {
            puppet = undress(&puppet, &self.undress, ui).context("--undress")?;
        }
        let worn = model
            .wearing(puppet)
            .context(if self.dress.is_some() { "--dress" } else { "--undress" })?;
        ui.say(format!(
            "outfit: {} accessories, rigged in {:.0} ms",
            worn.puppet.layers.iter().filter(|l| l.kind == LayerKind::Accessory).count(),
            started.elapsed().as_secs_f64() * 1e3
        ))?;
        Ok(Some(worn))
    }
}

/// Parses `WIDTHxHEIGHT` (also `X` or `×`), each side 1 to 8192.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X', '×'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (1..=8192).contains(&w) && (1..=8192).contains(&h) => Ok((w, h)),
        _ => Err(format!("{s:?} is not a size WxH with sides from 1 to 8192 (e.g. 256x256)")),
    }
}

/// Parses a pin `X,Y:TX,TY` (frame pixels, finite).
pub fn parse_pin(s: &str) -> Result<Pin, String> {
    let bad = || format!("{s:?} is not a pin X,Y:TX,TY (e.g. 40,60:52,48)");
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let point = |t: &str| -> Result<[f32; 2], String> {
        let (x, y) = t.split_once(',').ok_or_else(bad)?;
        let (x, y) = (
            x.trim().parse::<f32>().map_err(|_| bad())?,
            y.trim().parse::<f32>().map_err(|_| bad())?,
        );
        if x.is_finite() && y.is_finite() {
            Ok([x, y])
        } else {
            Err(bad())
        }
    };
    Ok(Pin {
        from: point(a)?,
        to: point(b)?,
    })
}

/// How the frames a command makes are played and on what: shared by every command that writes
/// an animation.
#[derive(Debug, clap::Args)]
pub struct AnimationArgs {
    /// Also write an animated GIF (1-bit alpha: on a transparent background, pixels of alpha
    /// ≥ ½ are drawn in their own colour, the rest are transparent).
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// Also write an animated PNG (APNG: full alpha, played by browsers and engines).
    #[arg(long, value_name = "FILE")]
    pub apng: Option<PathBuf>,
    /// Frame time of the animations and sprite-sheet atlases, in milliseconds (80 if not given;
    /// `retarget` plays at the motion's frame rate).
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u32).range(1..=65535))]
    pub delay: Option<u32>,
    /// What every frame written is drawn on: `transparent`, or an opaque colour #RRGGBB.
    #[arg(long, default_value = "transparent", value_parser = parse_background, value_name = "transparent|#RRGGBB")]
    pub background: Background,
}

impl AnimationArgs {
    /// The animation files these arguments ask for, playing there and back if `there_and_back`
    /// (frames and sprites are left to the command).
    pub fn files(&self, there_and_back: bool) -> AnimationFiles {
        self.files_timed(there_and_back, AnimationFiles::default().delay_ms)
    }

    /// [`Self::files`] with `delay_ms` as the frame time unless one is given.
    pub fn files_timed(&self, there_and_back: bool, delay_ms: u32) -> AnimationFiles {
        AnimationFiles {
            gif: self.gif.clone(),
            apng: self.apng.clone(),
            delay_ms: self.delay.unwrap_or(delay_ms),
            background: self.background,
            there_and_back,
            ..AnimationFiles::default()
        }
    }

    /// The animated files asked for, to name in a report.
    pub fn animations(&self) -> Vec<&Path> {
        self.gif.iter().chain(&self.apng).map(PathBuf::as_path).collect()
    }
}

/// Parses `transparent` or `#rrggbb`.
pub fn parse_background(s: &str) -> Result<Background, String> {
    s.parse()
}

/// Parses a positive, finite number.
pub fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("{s:?} is not a positive number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_pins_and_colours_parse_and_bad_ones_are_explained() {
        assert_eq!(parse_size("256x128"), Ok((256, 128)));
        assert_eq!(parse_size("64X64"), Ok((64, 64)));
        assert_eq!(parse_size("64×32"), Ok((64, 32)));
        for bad in ["0x5", "12", "ax3", "9000x10"] {
            assert!(parse_size(bad).unwrap_err().contains("is not a size WxH"), "{bad}");
        }
        let p = parse_pin("40,60:52.5,48").unwrap();
        assert_eq!((p.from, p.to), ([40.0, 60.0], [52.5, 48.0]));
        for bad in ["40,60", "40:60", "a,b:c,d", "1,2:3", "nan,1:2,3"] {
            assert!(parse_pin(bad).unwrap_err().contains("is not a pin"), "{bad}");
        }
        assert_eq!(parse_background("#ff0000"), Ok(Background::Colour([1.0, 0.0, 0.0])));
        assert!(parse_background("red").is_err());
        assert_eq!(parse_background("Transparent"), Ok(Background::Transparent));
        assert_eq!(parse_background("#000000"), Ok(Background::Colour([0.0; 3])));
        assert!(parse_background("none").unwrap_err().contains("transparent"));
        assert!(positive_f32("0").is_err() && positive_f32("inf").is_err() && positive_f32("2.5") == Ok(2.5));
    }
}
