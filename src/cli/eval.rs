//! `puppet eval --model M <sequence>`: the metrics of DESIGN.md on a model's held-out frames
//! (`--puppet P`: on a character nobody trained, fitted from the prior).

use std::path::PathBuf;

use anyhow::Context;
use puppet::appearance::AppearanceStage;
use puppet::eval::report::{evaluate, FitStart, Scoring};
use puppet::fit::frame::frame_check;
use puppet::puppet::sequence::Frames;
use puppet::synth::Truth;
use puppet::train::trainer::SplitRecord;

use super::args::{FitArgs, FitSource, FitSourceArgs};
use super::Session;

/// Score a trained model: fit each held-out frame, render it, and report L2, masked RMSE and
/// silhouette IoU (plus vertex error and PCK@0.1/0.05/0.025 where the sequence has truth.json).
/// For a puppet with accessories: vertex error of body and accessories apart, and how the
/// accessories keep hidden what they hid and stay attached on the fits, on in-betweens of
/// consecutive frames and on seeded drags.
/// With --puppet instead of --model, a character nobody trained is scored: each frame placed by
/// the prior, then fitted without a network (held-out frames are then those of --split-of, or
/// all). Frames that cannot be read are named and the rest scored; the command then exits with
/// status 1.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    #[command(flatten)]
    pub source: FitSourceArgs,
    /// With --puppet: score the frames a trained model of the same character held out (its
    /// split.json), so the figures sit beside that model's.
    #[arg(long, value_name = "MODEL", requires = "puppet")]
    pub split_of: Option<PathBuf>,
    /// With --puppet: start every fit from the rest pose instead of the prior's placement (the
    /// control that shows what the prior adds).
    #[arg(long, requires = "puppet")]
    pub from_rest: bool,
    /// The sequence: a folder of frames (or one holding frames/ and truth.json).
    pub sequence: PathBuf,
    /// Score every frame, not only those the model held out.
    #[arg(long)]
    pub all: bool,
    /// Also write the report as JSON here.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub fit: FitArgs,
    /// Also score the appearance stage's redraw of each fit (`puppet appearance train`).
    #[arg(long)]
    pub appearance: bool,
}

/// Runs `puppet eval`.
pub fn run(args: EvalArgs, s: &Session) -> anyhow::Result<()> {
    if let Some(out) = &args.output {
        s.outputs.claim(out)?;
    }
    let device = puppet::backend::device();
    let FitSource { model, dir, prior } = args.source.load(&device, &s.ui)?;
    let options = args.fit.options(dir.as_deref(), &model, &device, &s.ui)?;
    let stage = match (&dir, args.appearance) {
        (Some(dir), true) => Some(AppearanceStage::load(dir, &model, &device)?),
        (None, true) => anyhow::bail!("--appearance needs a trained model (--model): a puppet nobody trained has no appearance stage"),
        _ => None,
    };
    let start = match (&dir, &prior) {
        (None, _) if args.from_rest => FitStart::Rest,
        (_, None) => FitStart::Network,
        (Some(_), Some(prior)) => FitStart::NetworkOrPrior(prior),
        (None, Some(prior)) => FitStart::Prior(prior),
    };
    let (frames, bad) = Frames::load_each(&args.sequence, &frame_check(&model))?;
    let truth = Truth::for_sequence(&args.sequence)?;
    let names = frames.names();
    let split = match dir.as_ref().or(args.split_of.as_ref()) {
        Some(dir) => SplitRecord::load(dir)?,
        None => None,
    };
    let held_out = match (args.all, split) {
        (false, Some(split)) => Some(split.test),
        _ => None,
    };
    let (indices, which): (Vec<usize>, String) = match &held_out {
        Some(test) => {
            let present: Vec<usize> = (0..names.len()).filter(|&i| test.contains(&names[i])).collect();
            if present.is_empty() && bad.is_empty() {
                (
                    Vec::new(),
                    "all frames (the model's held-out frames are not in this sequence)".into(),
                )
            } else {
                (present, "held-out frames".into())
            }
        }
        None => (Vec::new(), "all frames".into()),
    };
    // A bad frame counts only if it is one that would have been scored.
    let scored = |file: &std::path::Path| {
        let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        held_out.as_ref().is_none_or(|test| test.contains(&name))
    };
    let bad: Vec<puppet::Error> = bad.into_iter().filter(|(f, _)| scored(f)).map(|(_, e)| e).collect();
    let report = if indices.is_empty() && held_out.is_some() && !bad.is_empty() {
        None
    } else {
        Some(evaluate(
            &model,
            &frames,
            &indices,
            truth.as_ref(),
            &Scoring {
                fit: &options,
                start,
                appearance: stage.as_ref(),
            },
            &device,
            &s.ui,
        )?)
    };
    s.ui.finish();
    if let Some(report) = &report {
        s.ui.say(format!("{} — {which}, {} of them:", args.sequence.display(), report.frames.len()))?;
        s.ui.print(report.table().trim_end())?;
        if let Some(count) = report.from_prior {
            s.ui.say(format!("{count} of {} fits came from the prior's placement", report.frames.len()))?;
        }
        if let Some(out) = &args.output {
            let json = serde_json::to_vec_pretty(report).context("while encoding the report")?;
            s.outputs.write(out, &json)?;
            s.ui.say(format!("report → {}", out.display()))?;
        }
    }
    puppet::Error::collect(bad)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_the_sequence_and_options() {
        parses(&["eval", "--model", "m", "seq", "--all", "-o", "r.json", "--one-pass"]);
        parses(&["eval", "--model", "m", "seq", "--vertex-rounds", "1"]);
        parses(&["eval", "--model", "m", "seq", "--one-pass", "--appearance"]);
        parses(&["eval", "--model", "m", "seq", "--prior"]);
        parses(&["eval", "--puppet", "p", "seq", "--split-of", "m", "--prior-net", "runs/prior"]);
        parses(&["eval", "--puppet", "p", "seq", "--from-rest"]);
    }
}
