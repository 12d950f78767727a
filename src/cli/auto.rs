//! `puppet auto <poses> -o DIR`: from drawn poses to a trained puppet in one command (see
//! [`puppet::demo::auto`]).

use std::path::PathBuf;

use puppet::demo::auto::{run as run_auto, AutoOptions};
use puppet::parts::pose::Layout;
use puppet::parts::{PartsOptions, ESTIMATED_RIGID_CHECK};

use super::args::parse_size;
use super::Session;

/// From drawn poses to a puppet: find the character's parts (the built-in correspondence
/// network and the part finder of `puppet parts`), write them as artwork (OUTPUT/artwork: label
/// map, reference frame, character.toml with joints and layer order, parts.png, and the poses
/// as frames/), then build, train, fit, in-between and drag the puppet as `puppet demo` does and
/// write OUTPUT/index.html. No label map, no rigging by hand.
#[derive(Debug, clap::Args)]
pub struct AutoArgs {
    /// The poses: a sprite sheet (PNG) or a folder of pose PNGs (their names are kept: a frame
    /// named walk0 is used as a walk frame).
    pub input: PathBuf,
    /// Output folder.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Cut the sheet into a COLUMNSxROWS grid of equal cells instead of by its alpha.
    #[arg(long, value_name = "CxR", value_parser = parse_size)]
    pub grid: Option<(u32, u32)>,
    /// The correspondence network trained in DIR by `puppet train-parts` (default: built in).
    #[arg(long, value_name = "DIR")]
    pub net: Option<PathBuf>,
    /// Merge until this many parts are left (default: merge while the motion residual allows).
    #[arg(long, value_name = "N")]
    pub parts: Option<usize>,
    /// Training steps.
    #[arg(long, default_value_t = 300)]
    pub steps: u64,
}

/// Runs `puppet auto`.
pub fn run(args: AutoArgs, s: &Session) -> anyhow::Result<()> {
    let mut parts = PartsOptions {
        rigid_check: ESTIMATED_RIGID_CHECK,
        ..PartsOptions::default()
    };
    parts.segment.parts = args.parts;
    let options = AutoOptions {
        input: args.input,
        layout: args.grid.map(|(columns, rows)| Layout::Grid { columns, rows }),
        output: args.output,
        net: args.net,
        parts,
        steps: args.steps,
        force: s.outputs.forced(),
    };
    let summary = run_auto(&options, &s.ui)?;
    s.ui.finish();
    s.ui.say(format!(
        "{} parts found from {} poses in {:.1} s; puppet trained, fitted and animated in {:.0} s → {}",
        summary.found.parts,
        summary.found.poses,
        summary.found.seconds,
        summary.demo.seconds,
        summary.demo.index.display()
    ))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_poses_and_options() {
        parses(&["auto", "frames", "-o", "out"]);
        parses(&[
            "auto",
            "sheet.png",
            "-o",
            "out",
            "--grid",
            "4x3",
            "--parts",
            "8",
            "--steps",
            "50",
            "--net",
            "n",
        ]);
    }
}
