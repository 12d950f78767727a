//! `puppet appearance train --model M [config.toml]`: train the appearance stage
//! (neural-puppet.md §3.3) of a trained model.

use std::path::PathBuf;

use puppet::appearance::{train_appearance, AppearanceConfig, AppearanceOptions, StageFolder};
use puppet::fit::{FitOptions, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS};

use super::args::ModelArgs;
use super::train::run_state;
use super::Session;

/// The appearance stage: a conditional GAN that redraws the rendered puppet as the artist drew it.
#[derive(Debug, clap::Args)]
pub struct AppearanceArgs {
    #[command(subcommand)]
    pub command: AppearanceCommand,
}

/// What to do with the appearance stage.
#[derive(Debug, clap::Subcommand)]
pub enum AppearanceCommand {
    Train(AppearanceTrainArgs),
}

/// Train the appearance stage of a model on the frames the model was trained on: each is fitted
/// as `puppet eval` fits (cached), rendered, and the generator learns to turn the render into the
/// drawn frame against a critic (WGAN-GP by default; see the config keys in
/// src/appearance/config.rs). Writes <model>/appearance/: net.json, generator.bpk, critic.bpk,
/// stage.json, train.toml, fits.json, log.csv, loss.png, sheet.png (render | generated | drawn,
/// training frames then held-out ones) and checkpoints/. A killed run continues with --resume.
#[derive(Debug, clap::Args)]
pub struct AppearanceTrainArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The stage's training config (TOML); without one, the defaults.
    pub config: Option<PathBuf>,
    /// Continue from the stage's latest checkpoint.
    #[arg(long)]
    pub resume: bool,
    /// Stop (checkpointed, resumable) once this many generator steps are done in total.
    #[arg(long, value_name = "STEPS")]
    pub pause_at: Option<u64>,
}

/// Runs `puppet appearance`.
pub fn run(args: AppearanceArgs, s: &Session) -> anyhow::Result<()> {
    match args.command {
        AppearanceCommand::Train(args) => train(args, s),
    }
}

fn train(args: AppearanceTrainArgs, s: &Session) -> anyhow::Result<()> {
    let config = match &args.config {
        Some(path) => AppearanceConfig::load(path)?,
        None => AppearanceConfig::default(),
    };
    let dir = &args.model.model;
    let fit = FitOptions::for_model(dir, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS)?;
    let options = AppearanceOptions {
        resume: args.resume,
        pause_at: args.pause_at,
    };
    let summary = train_appearance(dir, &config, &fit, &options, &s.ui)?;
    s.ui.finish();
    s.ui.say(format!(
        "{}: {} steps, {:.1} images/s → {}",
        run_state(summary.finished),
        summary.steps,
        summary.images_per_second,
        StageFolder::of_model(dir).dir().display()
    ))?;
    for (which, pair) in [("training", summary.train), ("held-out", summary.held_out)] {
        if pair.rendered.is_finite() {
            s.ui.say(format!(
                "{which} frames, mean L2: rendered {:.1}, generated {:.1} (ratio {:.3})",
                pair.rendered,
                pair.generated,
                pair.generated / pair.rendered
            ))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_train_with_and_without_a_config() {
        parses(&["appearance", "train", "--model", "m"]);
        parses(&["appearance", "train", "--model", "m", "c.toml", "--resume", "--pause-at", "10"]);
    }
}
