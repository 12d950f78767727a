//! `puppet eval --model M <sequence>`: the metrics of DESIGN.md on a model's held-out frames.

use std::path::PathBuf;

use anyhow::Context;
use puppet::eval::report::evaluate;
use puppet::model::Model;
use puppet::train::trainer::SplitRecord;
use puppet::train::Frames;

use super::fit::FitRefineArgs;
use super::Ui;

/// Score a trained model: fit each held-out frame, render it, and report L2, masked RMSE and
/// silhouette IoU (plus vertex error and PCK@0.1/0.05/0.025 where the sequence has truth.json).
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The model folder written by `puppet train`.
    #[arg(long)]
    pub model: PathBuf,
    /// The sequence: a folder of frames (or one holding frames/ and truth.json).
    pub sequence: PathBuf,
    /// Score every frame, not only those the model held out.
    #[arg(long)]
    pub all: bool,
    /// Where to write the report as JSON (default: <model>/eval.json).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub refine: FitRefineArgs,
}

/// Runs `puppet eval`.
pub fn run(args: EvalArgs, ui: &Ui) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let model = Model::load(&args.model, &device)?;
    let frames = Frames::load(&args.sequence)?;
    let names = frames.names();
    let held_out = match (args.all, SplitRecord::load(&args.model)?) {
        (false, Some(split)) => split.test_indices(&names),
        _ => None,
    };
    let (indices, which) = match held_out {
        Some(i) => (i, "held-out frames"),
        None if args.all => (Vec::new(), "all frames"),
        None => (Vec::new(), "all frames (the model's held-out frames are not in this sequence)"),
    };
    let report = evaluate(&model, &frames, &indices, &args.refine.options(&args.model)?, &device)?;
    let out = args.output.unwrap_or_else(|| args.model.join("eval.json"));
    let json = serde_json::to_vec_pretty(&report).context("while encoding the report")?;
    puppet::atomic_file::write_atomic(&out, &json)?;
    ui.say(format!("{} — {which}, {} of them:", args.sequence.display(), report.frames.len()));
    print!("{}", report.table());
    ui.say(format!("report → {}", out.display()));
    Ok(())
}
