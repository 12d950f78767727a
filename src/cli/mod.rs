//! Subcommands, one file each: parse → validated library options → library call → report.

use clap::{Parser, Subcommand};

mod build;
mod correspond;
mod demo;
mod eval;
mod fit;
mod inbetween;
mod info;
mod pose;
mod render;
mod synth;
mod train;
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

/// The subcommands.
#[derive(Debug, Subcommand)]
enum Command {
    Build(build::BuildArgs),
    Correspond(correspond::CorrespondArgs),
    Demo(demo::DemoArgs),
    Eval(eval::EvalArgs),
    Fit(fit::FitArgs),
    Inbetween(inbetween::InbetweenArgs),
    Info(info::InfoArgs),
    Pose(pose::PoseArgs),
    Render(render::RenderArgs),
    Synth(synth::SynthArgs),
    Train(train::TrainArgs),
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let ui = Ui::new(cli.common.quiet);
    match cli.command {
        Command::Build(args) => build::run(args, &ui),
        Command::Correspond(args) => correspond::run(args, &ui),
        Command::Demo(args) => demo::run(args, &ui),
        Command::Eval(args) => eval::run(args, &ui),
        Command::Fit(args) => fit::run(args, &ui),
        Command::Inbetween(args) => inbetween::run(args, &ui),
        Command::Info(args) => info::run(args, &ui),
        Command::Pose(args) => pose::run(args, &ui),
        Command::Render(args) => render::run(args, &ui),
        Command::Synth(args) => synth::run(args, &ui),
        Command::Train(args) => train::run(args, &ui),
    }
}
