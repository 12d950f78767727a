//! `puppet inbetween --model M <a.png> <b.png> --steps N -o DIR [--gif out.gif]`: in-betweens by
//! latent interpolation (neural-puppet.md §4.1), with the vertex-space interpolation and the
//! nearest training frame beside each step (Figure 5).

use std::path::{Path, PathBuf};

use anyhow::Context;

use puppet::edit::inbetween::{comparison_sheet, inbetween, steps_t, write_inbetweens, InbetweenFiles, MAX_STEPS};
use puppet::eval::inbetween_eval::inbetween_scores;
use puppet::fit::frame::{frame_check, load_frame};
use puppet::fit::FitOptions;
use puppet::model::Model;
use puppet::progress::Progress;
use puppet::puppet::sequence::Frames;
use puppet::render::animation::AnimationFiles;

use super::args::{AnimationArgs, LatentFitArgs, ModelArgs, OutfitArgs};
use super::Session;

/// Make in-between frames of two frames by interpolating their latent codes.
///
/// Writes into OUTPUT: latent/step_NNN.png and .json (the decoded latent interpolation, end
/// frames included, and each pose), vertex/step_NNN.png (linear interpolation of the two
/// fitted meshes, for comparison), nearest/step_NNN.png (the training frame nearest each latent
/// step, with --training), sheet.png (rows: latent, vertex, nearest; at most 12 steps shown) and
/// sprites.png with its atlas sprites.json (the latent steps for game engines; further pages
/// sprites_2.png, … past 4096 px); with --gif / --apng, the latent steps played there and back.
#[derive(Debug, clap::Args)]
pub struct InbetweenArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The first frame (RGBA PNG of the puppet's frame size).
    #[arg(required_unless_present = "score")]
    pub a: Option<PathBuf>,
    /// The last frame.
    #[arg(required_unless_present = "score")]
    pub b: Option<PathBuf>,
    /// Score instead: on this sequence (frames in natural order), generate every odd-numbered
    /// frame from its two even neighbours at t = ½ and print the L2 to the true frame for latent
    /// interpolation, vertex interpolation, the nearest even frame, repeating the previous frame,
    /// and the model's own fit (for a model trained on the even frames only).
    #[arg(long, value_name = "SEQUENCE", conflicts_with_all = ["a", "b", "gif", "apng", "training"])]
    pub score: Option<PathBuf>,
    /// Number of in-between frames strictly between A and B.
    #[arg(long, default_value_t = 8)]
    pub steps: usize,
    /// The most in-betweens allowed (a guard against a typo's hour of rendering).
    #[arg(long, default_value_t = MAX_STEPS, value_name = "N")]
    pub max_steps: usize,
    /// Output folder (created if missing).
    #[arg(short, long, value_name = "DIR", required_unless_present = "score")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Training frames (a folder, or a sequence holding frames/): the nearest one (Euclidean
    /// image distance) is written beside each step.
    #[arg(long, value_name = "DIR")]
    pub training: Option<PathBuf>,
    /// Cells per row of sprites.png.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub columns: usize,
    #[command(flatten)]
    pub fit: LatentFitArgs,
    #[command(flatten)]
    pub outfit: OutfitArgs,
}

/// Runs `puppet inbetween`.
pub fn run(args: InbetweenArgs, s: &Session) -> anyhow::Result<()> {
    let t = steps_t(args.steps, args.max_steps).context("--steps")?;
    let device = puppet::backend::device();
    let dir = &args.model.model;
    let model = Model::load(dir, &device)?;
    let options = args.fit.options(dir)?;
    if let Some(seq) = &args.score {
        return score(&model, seq, &options, s);
    }
    let (Some(a_path), Some(b_path), Some(out)) = (&args.a, &args.b, &args.output) else {
        anyhow::bail!("give two frames A and B and an output folder (or --score SEQUENCE)");
    };
    let worn = args.outfit.model(&model, &s.ui)?;
    let a = load_frame(a_path, &model)?;
    let b = load_frame(b_path, &model)?;
    let training = match &args.training {
        Some(dir) => Frames::load(dir, &frame_check(&model))?.frames,
        None => Vec::new(),
    };
    let files = files(&args, out);
    let sheet_path = out.join("sheet.png");
    s.outputs.claim(&sheet_path)?;
    s.ui.stage("inbetween", 0);
    let mut ib = inbetween(&model, &a, &b, &t, &options, &device)?;
    if let Some(worn) = &worn {
        for pose in ib.latent.iter_mut().chain(&mut ib.vertex) {
            *pose = worn.pose_from(&model, pose);
        }
    }
    let drawn = worn.as_ref().unwrap_or(&model);
    write_inbetweens(drawn, &ib, &training, &files, &s.outputs, &s.ui)?;
    s.save_png(&sheet_path, &comparison_sheet(drawn, &ib, &training)?)?;
    s.ui.finish();
    for path in args.animation.animations() {
        s.ui.say(format!("wrote {}", path.display()))?;
    }
    s.ui.say(format!(
        "{} in-betweens ({} frames with the two ends) from {} to {} → {} (latent/, vertex/{}, sheet.png, sprites.png + sprites.json)",
        args.steps,
        t.len(),
        a_path.display(),
        b_path.display(),
        out.display(),
        if training.is_empty() { "" } else { ", nearest/" }
    ))
}

/// The in-between files under `out`.
fn files(args: &InbetweenArgs, out: &Path) -> InbetweenFiles {
    let frames = |sub: &str| AnimationFiles {
        frames: Some((out.join(sub), "step".into())),
        background: args.animation.background,
        ..AnimationFiles::default()
    };
    InbetweenFiles {
        latent: AnimationFiles {
            frames: Some((out.join("latent"), "step".into())),
            sprites: Some((out.join("sprites.png"), args.columns)),
            ..args.animation.files(true)
        },
        vertex: frames("vertex"),
        nearest: frames("nearest"),
        poses: Some(out.join("latent")),
    }
}

/// `--score`: the in-between table of `eval::inbetween_eval` on the odd frames of `seq`.
fn score(model: &Model, seq: &Path, options: &FitOptions, s: &Session) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let frames = Frames::load(seq, &frame_check(model))?;
    let n = frames.frames.len();
    let even: Vec<usize> = (0..n).step_by(2).collect();
    let odd: Vec<usize> = (1..n).step_by(2).collect();
    s.ui.stage("score", 0);
    let scores = inbetween_scores(model, &frames.frames, &even, &odd, options, &device)?;
    s.ui.finish();
    let mean = |f: fn(&puppet::eval::inbetween_eval::InbetweenScore) -> f64| scores.iter().map(f).sum::<f64>() / scores.len() as f64;
    s.ui.print(format!(
        "{} held-out frames of {}: mean L2 — latent {:.1}, vertex {:.1}, nearest even frame {:.1}, previous frame {:.1}, fit of the true frame {:.1}",
        scores.len(),
        seq.display(),
        mean(|s| s.latent),
        mean(|s| s.vertex),
        mean(|s| s.nearest),
        mean(|s| s.hold),
        mean(|s| s.fit)
    ))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_frames_or_a_score_sequence() {
        parses(&[
            "inbetween",
            "--model",
            "m",
            "a.png",
            "b.png",
            "-o",
            "out",
            "--steps",
            "4",
            "--gif",
            "x.gif",
            "--apng",
            "x.png",
            "--background",
            "transparent",
        ]);
        parses(&["inbetween", "--model", "m", "--score", "seq"]);
        for bad in [
            vec!["inbetween", "--model", "m", "a.png"],
            vec!["inbetween", "--model", "m", "--score", "seq", "--gif", "x.gif"],
            vec!["inbetween", "--model", "m", "a.png", "b.png", "-o", "o", "--background", "white"],
            vec!["inbetween", "--model", "m", "a.png", "b.png", "-o", "o", "--delay", "0"],
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
