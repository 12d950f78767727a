//! `puppet train <config.toml>`: train a deformation network (neural-puppet.md §3.2).

use std::path::PathBuf;

use puppet::train::{self, TrainConfig, TrainOptions};

use super::Session;

/// Train the deformation network on a character's frames; the config names the puppet (or its
/// artwork), the frames, the output model folder, and the settings (see configs/).
///
/// Writes into the config's `output`: net.json, weights.bpk, puppet/, train.toml, split.json,
/// log.csv, loss.png (with the held-out frames' loss) and checkpoints/. A killed run continues
/// with --resume, losing at most `checkpoint_every` steps; a resume that does not match the
/// checkpoint (another config — only train.steps may change —, split or puppet) is refused
/// without touching a file.
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
pub fn run(args: TrainArgs, s: &Session) -> anyhow::Result<()> {
    let config = TrainConfig::load(&args.config)?;
    let options = TrainOptions {
        resume: args.resume,
        pause_at: args.pause_at,
        force: s.outputs.forced(),
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
        assert!(clap::Parser::try_parse_from(["puppet", "train", "c.toml", "--pause-at", "x"])
            .map(|_: crate::cli::Cli| ())
            .is_err());
    }
}
