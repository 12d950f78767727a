//! `puppet train-parts -o DIR [config.toml]`: train the correspondence network of `puppet parts`
//! (APES §3.1) on the generator's sprite sheets.

use std::path::{Path, PathBuf};

use puppet::parts::learn::{train_correspondence, LearnConfig, LearnOptions, LearnSummary};
use puppet::synth::sheet_flow::SyntheticPairs;

use super::train::run_state;
use super::Session;

/// The generator's seed of the first training pair; pair k uses seed TRAINING_SEEDS + k, far
/// from every seed a test, a tuning run or an evaluation uses (all below 10 000).
const TRAINING_SEEDS: u64 = 1_000_000;
/// The seed of the first held-out pair scored during training.
const HELD_OUT_SEEDS: u64 = 2_000_000;

/// Train the correspondence network `puppet parts --net` uses: a gated U-Net giving every pixel
/// of a pose a feature, so the same point of the character in two poses gets the same feature
/// (InfoNCE on pairs of random poses of the generator's characters, with their exact
/// correspondences). Writes DIR/: config.toml, net.json, weights.bpk, log.csv, curves.png and
/// checkpoints/. A killed run continues with --resume.
#[derive(Debug, clap::Args)]
pub struct TrainPartsArgs {
    /// The training config (TOML; keys in src/parts/learn.rs); without one, the defaults.
    pub config: Option<PathBuf>,
    /// The network's folder.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Continue from the latest checkpoint.
    #[arg(long)]
    pub resume: bool,
    /// Stop (checkpointed, resumable) once this many steps are done in total.
    #[arg(long, value_name = "STEPS")]
    pub pause_at: Option<u64>,
}

/// Runs `puppet train-parts`.
pub fn run(args: TrainPartsArgs, s: &Session) -> anyhow::Result<()> {
    let config = match &args.config {
        Some(path) => LearnConfig::load(path)?,
        None => LearnConfig::default(),
    };
    let size = u32::try_from(config.input_size)?;
    let options = LearnOptions {
        resume: args.resume,
        pause_at: args.pause_at,
    };
    let train = SyntheticPairs {
        first_seed: TRAINING_SEEDS,
        size,
        varied: config.varied,
    };
    let held_out = SyntheticPairs {
        first_seed: HELD_OUT_SEEDS,
        size,
        varied: config.varied,
    };
    let summary = train_correspondence(&args.output, &config, &train, &held_out, serde_json::Map::new(), &options, &s.ui)?;
    say_summary(&summary, &args.output, "held-out pairs", s)
}

/// Prints what a correspondence network's training did: its steps, speed and size, and the
/// held-out score of `pairs` beside that of the network it started as.
pub(super) fn say_summary(summary: &LearnSummary, output: &Path, pairs: &str, s: &Session) -> anyhow::Result<()> {
    s.ui.finish();
    s.ui.say(format!(
        "{}: {} steps in {:.0} s ({:.2} pairs/s), {} parameters → {}",
        run_state(summary.finished),
        summary.steps,
        summary.seconds,
        summary.pairs_per_second,
        summary.parameters,
        output.display()
    ))?;
    s.ui.say(format!(
        "{pairs}: {:.1} % of matched pixels land within 2 px of the truth, mean error {:.2} px \
         (the network it started as: {:.1} %, {:.2} px)",
        100.0 * summary.held_out.within_2px,
        summary.held_out.mean_error,
        100.0 * summary.untrained.within_2px,
        summary.untrained.mean_error
    ))?;
    Ok(())
}
