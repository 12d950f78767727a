//! `puppet train <config.toml>`: train a deformation network (neural-puppet.md §3.2).

use std::path::{Path, PathBuf};

use std::sync::Arc;

use puppet::fit::FitOptions;
use puppet::model::ModelFolder;
use puppet::prior::PriorGuide;
use puppet::train::guide::{UntrainedFit, PRIOR_WEIGHT};
use puppet::train::{self, TrainConfig, TrainOptions};

use super::Session;

/// Train the deformation network on a character's frames: `puppet train --artwork ART --frames
/// DIR -o MODEL` with the default settings (configs/train.toml), or `puppet train CONFIG` with a
/// config that names the puppet (or its artwork), the frames, the output model folder, and the
/// settings (see configs/); --artwork, --frames and -o then replace the config's.
///
/// Writes into the output: net.json, weights.bpk, puppet/, train.toml (the config used),
/// split.json, log.csv, loss.png (with the held-out frames' loss) and checkpoints/. A killed run
/// continues with --resume, losing at most `checkpoint_every` steps; a resume that does not match
/// the checkpoint (another config — only train.steps may change —, split or puppet) is refused
/// without touching a file.
///
/// `puppet train --from MODEL --frames DIR -o NEW --steps N` continues a trained model with
/// frames added (a drawing `puppet suggest` asked for): its config and weights, the frames in
/// DIR; the frames MODEL held out stay held out, all others train. MODEL is only read.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// The training config (TOML); without one, --artwork (or --from), --frames and -o are
    /// needed.
    #[arg(required_unless_present_any = ["artwork", "from"])]
    pub config: Option<PathBuf>,
    /// A trained model folder to continue: the run starts from its weights and, without a
    /// config, its settings and puppet.
    #[arg(long, value_name = "MODEL")]
    pub from: Option<PathBuf>,
    /// Optimiser steps (replaces the config's train.steps).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub steps: Option<u64>,
    /// The character: artwork (a folder with character.toml, .ora or .psd) or a built puppet
    /// folder.
    #[arg(long, value_name = "PATH")]
    pub artwork: Option<PathBuf>,
    /// The drawn frames (a folder of PNGs of the artwork's size, or one holding frames/).
    #[arg(long, value_name = "DIR")]
    pub frames: Option<PathBuf>,
    /// The model folder to write.
    #[arg(short, long, value_name = "DIR")]
    pub output: Option<PathBuf>,
    /// Continue from the output folder's latest checkpoint.
    #[arg(long)]
    pub resume: bool,
    /// Stop (checkpointed, resumable) once this many steps are done in total.
    #[arg(long, value_name = "STEPS")]
    pub pause_at: Option<u64>,
    /// Start from the prior: fit the training frames by the built-in prior first, and pull the
    /// network's poses of them toward those fits for the first fifth of the run (the config's
    /// `[train.guide]`, turned on with its default weight where the config leaves it off).
    #[arg(long, conflicts_with = "from")]
    pub prior: bool,
    /// With --prior: another prior than the built-in one, a `puppet prior train` run folder.
    #[arg(long, value_name = "DIR", requires = "prior")]
    pub prior_net: Option<PathBuf>,
}

impl TrainArgs {
    /// The config these arguments ask for.
    fn config(&self) -> anyhow::Result<TrainConfig> {
        let (artwork, frames, output) = (self.artwork.as_deref(), self.frames.as_deref(), self.output.as_deref());
        let mut config = match (&self.config, &self.from, artwork, frames, output) {
            (Some(path), ..) => TrainConfig::load(path)?.replacing_paths(artwork, frames, output),
            (None, Some(model), _, Some(frames), Some(output)) => {
                TrainConfig::load(&ModelFolder::open(model)?.config())?.replacing_paths(artwork, Some(frames), Some(output))
            }
            (None, None, Some(artwork), Some(frames), Some(output)) => TrainConfig::with_paths(
                TrainConfig::DEFAULT_SETTINGS,
                Path::new("configs/train.toml"),
                artwork,
                frames,
                output,
            )?,
            (None, ..) => anyhow::bail!("give a training config, or --artwork (or --from), --frames and -o"),
        };
        if let Some(model) = &self.from {
            config = config.continuing(model);
        } else if self.prior && config.train.guide.is_off() {
            config.train.guide.weight = PRIOR_WEIGHT;
        }
        if let Some(steps) = self.steps {
            config.train.steps = steps;
        }
        Ok(config)
    }
}

/// Runs `puppet train`.
pub fn run(args: TrainArgs, s: &Session) -> anyhow::Result<()> {
    let config = args.config()?;
    let guide = if config.train.guide.is_off() {
        None
    } else {
        let device = puppet::backend::device();
        // The fit the CLI gives a puppet nobody trained, with the run's loss (a masked one for
        // frames over a background).
        let options = FitOptions {
            latent_steps: 0,
            weights: config.loss.clone(),
            ..FitOptions::default()
        };
        Some(Arc::new(PriorGuide::new(
            puppet::prior::load_or_shipped(args.prior_net.as_deref(), &device)?,
            options,
            device,
        )) as Arc<dyn UntrainedFit>)
    };
    let options = TrainOptions {
        resume: args.resume,
        pause_at: args.pause_at,
        force: s.outputs.forced(),
        guide,
    };
    let summary = train::train(&config, &options, &s.ui)?;
    s.ui.finish();
    let (n_train, n_test) = summary.split;
    let last = summary.last.map_or(String::new(), |r| {
        let held_out = if r.held_out.is_finite() {
            format!(", held-out {:.4e}", r.held_out)
        } else {
            String::new()
        };
        format!(", last loss {:.4e} (rec {:.4e}{held_out})", r.total, r.rec)
    });
    let state = run_state(summary.finished);
    s.ui.say(format!(
        "{state}: {} steps on {n_train} frames ({n_test} held out), batch {}, {:.1} images/s{last} → {}",
        summary.steps,
        summary.batch,
        summary.images_per_second,
        config.output.display()
    ))
}

/// How a training run ended, for its summary line.
pub fn run_state(finished: bool) -> &'static str {
    if finished {
        "done"
    } else {
        "paused (continue with --resume)"
    }
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_resume_and_pause() {
        parses(&["train", "configs/kenney-robot.toml", "--resume", "--pause-at", "100"]);
        parses(&["train", "--artwork", "a.psd", "--frames", "f", "-o", "runs/a"]);
        parses(&["train", "c.toml", "-o", "runs/b"]);
        parses(&["train", "--from", "runs/a", "--frames", "f", "-o", "runs/b", "--steps", "300"]);
        parses(&["train", "configs/kenney-robot.toml", "--prior", "-o", "runs/c"]);
        assert!(
            clap::Parser::try_parse_from(["puppet", "train", "--from", "runs/a", "--prior", "--frames", "f", "-o", "x"])
                .map(|_: crate::cli::Cli| ())
                .is_err(),
            "a continued model is not guided by the prior"
        );
        parses(&[
            "train",
            "configs/kenney-robot.toml",
            "--prior",
            "--prior-net",
            "runs/prior",
            "-o",
            "runs/c",
        ]);
        assert!(
            clap::Parser::try_parse_from(["puppet", "train", "c.toml", "--prior-net", "runs/prior"])
                .map(|_: crate::cli::Cli| ())
                .is_err(),
            "another prior is only for a run guided by one"
        );
        let missing: crate::cli::Cli = clap::Parser::try_parse_from(["puppet", "train", "--artwork", "a.psd", "-o", "x"]).unwrap();
        let crate::cli::Command::Train(args) = missing.command else {
            panic!("parsed as another command")
        };
        assert!(args.config().is_err(), "without a config, --frames is needed too");
        assert!(clap::Parser::try_parse_from(["puppet", "train", "--frames", "f", "-o", "x"])
            .map(|_: crate::cli::Cli| ())
            .is_err());
        assert!(clap::Parser::try_parse_from(["puppet", "train", "c.toml", "--pause-at", "x"])
            .map(|_: crate::cli::Cli| ())
            .is_err());
    }
}
