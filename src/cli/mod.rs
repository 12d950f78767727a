//! Subcommands, one file each: parse → validated library options → library call → report.

use clap::{Parser, Subcommand};

mod synth;
mod ui;

pub use ui::Ui;

/// Learn a layered 2D puppet of a cartoon character from a few drawn frames, then make new frames.
#[derive(Debug, Parser)]
#[command(name = "puppet", version, about)]
pub struct Cli {
    #[command(flatten)]
    common: Common,
    #[command(subcommand)]
    command: Command,
}

/// Flags every subcommand takes.
#[derive(Debug, clap::Args)]
pub struct Common {
    /// Print no progress bars or summaries (errors still go to stderr).
    #[arg(long, short, global = true)]
    pub quiet: bool,
}

#[derive(Debug, Subcommand)]
enum Command {
    Synth(synth::SynthArgs),
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let ui = Ui::new(cli.common.quiet);
    match cli.command {
        Command::Synth(args) => synth::run(args, &ui),
    }
}
