//! `puppet train <config.toml>`: train a deformation network (neural-puppet.md §3.2).

use std::path::PathBuf;

use puppet::train::{self, TrainConfig, TrainOptions};

use super::Ui;

/// Train the deformation network on a character's frames; the config names the puppet (or its
/// artwork), the frames, the output model folder, and the settings (see configs/).
///
/// Writes into the config's `output`: net.json, weights.bpk, puppet/, train.toml, split.json,
/// log.csv, loss.png and checkpoints/. A killed run continues with --resume, losing at most
/// `checkpoint_every` steps.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// The training config (TOML).
    pub config: PathBuf,
    /// Continue from the output folder's latest checkpoint.
    #[arg(long)]
    pub resume: bool,
    /// Stop (checkpointed, resumable) once this many steps are done in total.
    #[arg(long, value_name = "STEPS")]
    pub pause_at: Option<u64>,
}

/// Runs `puppet train`.
pub fn run(args: TrainArgs, ui: &Ui) -> anyhow::Result<()> {
    let config = TrainConfig::load(&args.config)?;
    let options = TrainOptions {
        resume: args.resume,
        pause_at: args.pause_at,
    };
    let summary = train::train(&config, &options, ui)?;
    ui.finish();
    let (n_train, n_test) = summary.split;
    let last = summary.last.map_or(String::new(), |r| format!(", last loss {:.4e} (rec {:.4e})", r.total, r.rec));
    let state = if summary.finished { "done" } else { "paused (continue with --resume)" };
    ui.say(format!(
        "{state}: {} steps on {n_train} frames ({n_test} held out), {:.1} images/s{last} → {}",
        summary.steps,
        summary.images_per_second,
        config.output.display()
    ));
    Ok(())
}
