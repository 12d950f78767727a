//! `puppet demo`: the whole pipeline on a bundled Kenney character, no arguments (see
//! [`puppet::demo`]).

use std::path::PathBuf;

use puppet::demo::{run as run_demo, DemoOptions};

use super::Session;

/// Run the whole pipeline on a bundled Kenney character and write out/demo/index.html.
///
/// Builds the character's puppet from its label map (the male adventurer's hair is an accessory
/// the rig carries), trains the deformation network for a short run (OUTPUT/train.toml, a few
/// minutes on two cores), fits every frame, makes in-betweens (GIF), a dragged pose with the
/// ARAP comparison and, if the character has an outfits/ folder, the walk in-between in its
/// first outfit, and writes an HTML page showing each result. A rerun replaces what an earlier
/// demo wrote in OUTPUT and nothing else.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, default_value = "out/demo", value_name = "DIR")]
    pub output: PathBuf,
    /// Training steps of the short run.
    #[arg(long, default_value_t = 300)]
    pub steps: u64,
    /// The character: artwork with a frames/ folder of drawn frames (default: the bundled male
    /// adventurer; data/kenney/robot is the other one with frames and a label map).
    #[arg(long, value_name = "DIR")]
    pub character: Option<PathBuf>,
    /// Also train the appearance stage (neural-puppet.md §3.3) for this many epochs (~0.6 s an
    /// epoch of nine frames) and show its redraws on the page.
    #[arg(long, value_name = "EPOCHS", num_args = 0..=1, default_missing_value = "50")]
    pub appearance: Option<u64>,
}

/// Runs `puppet demo`.
pub fn run(args: DemoArgs, s: &Session) -> anyhow::Result<()> {
    let defaults = DemoOptions::new(args.output);
    let options = DemoOptions {
        steps: args.steps,
        force: s.outputs.forced(),
        character: args.character.unwrap_or(defaults.character.clone()),
        appearance_epochs: args.appearance,
        ..defaults
    };
    let summary = run_demo(&options, &s.ui)?;
    s.ui.finish();
    s.ui.say(format!("demo done in {:.0} s → {}", summary.seconds, summary.index.display()))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_output_and_steps() {
        parses(&["demo"]);
        parses(&["demo", "-o", "x", "--steps", "5", "--character", "data/kenney/robot"]);
        parses(&["demo", "--appearance"]);
        parses(&["demo", "--appearance", "20"]);
    }
}
