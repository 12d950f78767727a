//! Subcommands, one file each: parse → validated library options → library call → report.
//! Everything a command prints goes through [`Ui`]; everything it writes goes through the run's
//! [`Outputs`], which refuses to replace what puppet did not write unless `--force`.

use clap::{Parser, Subcommand};
use puppet::atomic_file::Outputs;
use puppet::error::FolderKind;

mod appearance;
mod args;
mod auto;
mod build;
#[cfg(test)]
mod commands_doc;
mod correspond;
mod demo;
mod eval;
mod eval_parts;
mod eval_rig;
mod export;
mod fit;
mod inbetween;
mod info;
mod parts;
mod pose;
mod prior;
mod render;
mod retarget;
mod rig;
mod serve;
mod suggest;
mod synth;
mod train;
mod train_parts;
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
    /// Print no progress or summaries (results and errors are still printed).
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Replace output files even if puppet did not write them (puppet lists what it wrote in
    /// each output folder's .puppet-outputs and otherwise replaces only those).
    #[arg(long, global = true)]
    pub force: bool,
}

/// One command run: its terminal and its outputs.
pub struct Session {
    /// Progress, warnings and printed lines.
    pub ui: Ui,
    /// The files it writes.
    pub outputs: Outputs,
}

impl Session {
    /// Writes `picture` as a PNG at `path`, claimed first (see [`Outputs::claim`]).
    ///
    /// # Errors
    /// As [`Outputs::write`].
    pub fn save_png(&self, path: &std::path::Path, picture: &puppet::picture::Picture) -> puppet::Result<()> {
        self.outputs.write(path, &picture.png_bytes(path)?)
    }
}

/// The subcommands.
#[derive(Debug, Subcommand)]
enum Command {
    Appearance(appearance::AppearanceArgs),
    Auto(auto::AutoArgs),
    Build(build::BuildArgs),
    Correspond(correspond::CorrespondArgs),
    Demo(demo::DemoArgs),
    Eval(eval::EvalArgs),
    EvalParts(eval_parts::EvalPartsArgs),
    EvalRig(eval_rig::EvalRigArgs),
    Export(export::ExportArgs),
    Fit(fit::FitArgs),
    Inbetween(inbetween::InbetweenArgs),
    Info(info::InfoArgs),
    Parts(parts::PartsArgs),
    Pose(pose::PoseArgs),
    Prior(prior::PriorArgs),
    Render(render::RenderArgs),
    Retarget(retarget::RetargetArgs),
    Rig(rig::RigArgs),
    Serve(serve::ServeArgs),
    Suggest(suggest::SuggestArgs),
    Synth(synth::SynthArgs),
    Train(train::TrainArgs),
    TrainParts(train_parts::TrainPartsArgs),
}

/// Runs the parsed command line.
///
/// # Errors
/// Whatever the command reports.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let session = Session {
        ui: Ui::new(cli.common.quiet),
        outputs: Outputs::new(cli.common.force),
    };
    let s = &session;
    let result = match cli.command {
        Command::Appearance(args) => appearance::run(args, s),
        Command::Auto(args) => auto::run(args, s),
        Command::Build(args) => build::run(args, s),
        Command::Correspond(args) => correspond::run(args, s),
        Command::Demo(args) => demo::run(args, s),
        Command::Eval(args) => eval::run(args, s),
        Command::EvalParts(args) => eval_parts::run(args, s),
        Command::EvalRig(args) => eval_rig::run(args, s),
        Command::Export(args) => export::run(args, s),
        Command::Fit(args) => fit::run(args, s),
        Command::Inbetween(args) => inbetween::run(args, s),
        Command::Info(args) => info::run(args, s),
        Command::Parts(args) => parts::run(args, s),
        Command::Pose(args) => pose::run(args, s),
        Command::Prior(args) => prior::run(args, s),
        Command::Render(args) => render::run(args, s),
        Command::Retarget(args) => retarget::run(args, s),
        Command::Rig(args) => rig::run(args, s),
        Command::Serve(args) => serve::run(args, s),
        Command::Suggest(args) => suggest::run(args, s),
        Command::Synth(args) => synth::run(args, s),
        Command::Train(args) => train::run(args, s),
        Command::TrainParts(args) => train_parts::run(args, s),
    };
    session.ui.finish();
    result
}

/// Whether `err` is stdout closed by its reader (`puppet eval … | head`): not worth a message.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The message for `err`: its causes, outermost first, and what to do about it in this
/// command line's words where the library's error says enough.
pub fn describe(err: &anyhow::Error) -> String {
    let advice = err
        .chain()
        .find_map(|e| e.downcast_ref::<puppet::Error>())
        .and_then(|e| advice(e.innermost()));
    match advice {
        Some(advice) => format!("{err:#} ({advice})"),
        None => format!("{err:#}"),
    }
}

/// What to run or pass, for the errors whose remedy is a command or a flag.
fn advice(err: &puppet::Error) -> Option<&'static str> {
    use puppet::Error as E;
    Some(match err {
        E::RunExists { .. } => "continue it with --resume, or choose another output",
        E::WouldOverwrite { .. } => "choose another output, or pass --force to replace it",
        E::WrongFolder {
            expected: FolderKind::Model,
            ..
        } => "train one with `puppet train --artwork ART --frames DIR -o MODEL`, or run `puppet demo` to make out/demo/model",
        E::WrongFolder {
            expected: FolderKind::Puppet,
            ..
        } => "build one with `puppet build <artwork> -o <dir>`",
        E::WrongFolder {
            expected: FolderKind::Sequence,
            ..
        } => "make one with `puppet synth -o <dir>`, or give a folder of PNG frames",
        E::Diverged { .. } => "try a lower train.learning_rate, then --resume",
        E::SheetLayout { .. } => "pass --grid COLUMNSxROWS",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses a command line, panicking with clap's message if it does not parse.
    pub fn parses(args: &[&str]) -> Cli {
        Cli::try_parse_from(std::iter::once("puppet").chain(args.iter().copied())).unwrap_or_else(|e| panic!("{args:?}: {e}"))
    }

    #[test]
    fn every_command_has_help_and_global_flags_go_anywhere() {
        for command in [
            "build",
            "correspond",
            "demo",
            "eval",
            "eval-parts",
            "eval-rig",
            "fit",
            "inbetween",
            "info",
            "parts",
            "pose",
            "prior",
            "render",
            "retarget",
            "rig",
            "serve",
            "synth",
            "train",
        ] {
            let err = Cli::try_parse_from(["puppet", command, "--help"]).unwrap_err();
            assert_eq!(err.kind(), clap::error::ErrorKind::DisplayHelp, "{command}");
        }
        let cli = parses(&["info", "x", "--quiet", "--force"]);
        assert!(cli.common.quiet && cli.common.force);
    }

    #[test]
    fn errors_carry_the_remedy_in_the_command_lines_words() {
        let err = anyhow::Error::new(puppet::Error::RunExists {
            path: "runs/x".into(),
            step: 3,
        });
        let text = describe(&err);
        assert!(text.contains("runs/x") && text.contains("--resume"), "{text}");
        let wrapped = anyhow::Error::new(
            puppet::Error::WrongFolder {
                path: "m".into(),
                expected: FolderKind::Model,
                problem: "no net.json".into(),
            }
            .with_path("m"),
        );
        assert!(describe(&wrapped).contains("puppet train"), "{}", describe(&wrapped));
        let pipe = anyhow::Error::new(std::io::Error::from(std::io::ErrorKind::BrokenPipe)).context("cannot write");
        assert!(is_broken_pipe(&pipe));
    }
}
