//! `puppet inbetween --model M <a.png> <b.png> --steps N -o DIR [--gif out.gif]`: in-betweens
//! along the learned manifold (neural-puppet.md §4.1's latent interpolation, routed through the
//! training frames' poses: `edit::manifold_path`), with the vertex-space and as-rigid-as-possible
//! interpolations and the nearest training frame beside each step (Figure 5).

use std::path::{Path, PathBuf};

use anyhow::Context;

use puppet::appearance::AppearanceStage;
use puppet::edit::inbetween::{along, comparison_sheet, write_inbetweens, InbetweenFiles, InbetweenPath, Interpolator, MAX_STEPS};
use puppet::edit::manifold_path::Waypoints;
use puppet::edit::timing::{eased_t, spacing_t, Easing};
use puppet::eval::inbetween_eval::{score_sequence, InbetweenScore};
use puppet::fit::frame::{frame_check, load_frame, training_frames};
use puppet::fit::FitOptions;
use puppet::metrics::l2;
use puppet::model::Model;
use puppet::prior::{keep_closer, Start};
use puppet::progress::Progress;
use puppet::puppet::sequence::Frames;
use puppet::render::animation::{AnimationFiles, AnimationWriter};
use puppet::render::render_crisp;

use super::args::{AnimationArgs, FitArgs, ModelArgs, OutfitArgs};
use super::Session;

/// Make in-between frames of two keyframes along the pose manifold the model learned.
///
/// The keyframes are fitted as `puppet fit` fits them, and the in-betweens start and end on
/// those fits. Between them the path runs through the poses of the model's training frames
/// that lie between the keyframes (none: straight), as-rigid-as-possible between its corners,
/// or with --path latent along the latents (carrying each fit's offset from its latent's
/// decode). Writes into OUTPUT: inbetween/step_NNN.png and .json (the path, keyframes included,
/// and each pose), vertex/step_NNN.png and arap/step_NNN.png (linear and as-rigid-as-possible
/// interpolation of the two fitted meshes, straight, for comparison), nearest/step_NNN.png (the
/// training frame nearest each step, with --training), sheet.png (rows: path, vertex, arap,
/// nearest; at most 12 steps shown) and sprites.png with its atlas sprites.json (the steps for
/// game engines; further pages sprites_2.png, … past 4096 px); with --gif / --apng, the steps
/// played there and back.
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
    /// frame between two even keyframes GAP + 1 apart, at its place in time, and print the mean
    /// L2 to the true frames for both paths (--path), the latent path through the keyframes'
    /// fits straight, the plain latent path, vertex and as-rigid-as-possible interpolation, the
    /// nearest even frame, holding the first keyframe, and the model's own fit (for a model
    /// trained on the even frames only).
    #[arg(long, value_name = "SEQUENCE", conflicts_with_all = ["a", "b", "gif", "apng", "training"])]
    pub score: Option<PathBuf>,
    /// With --score: the gaps (odd frame counts between the keyframes), comma-separated; 1 if
    /// not given.
    #[arg(long, value_name = "N,N,…", value_delimiter = ',', conflicts_with_all = ["a", "b", "output"])]
    pub gaps: Vec<usize>,
    /// Number of in-between frames strictly between A and B.
    #[arg(long, default_value_t = 8)]
    pub steps: usize,
    /// Their timing: linear (one speed), ease-in (slow out of A), ease-out (slow into B) or
    /// ease-in-out (slow out of A and into B: slow-in/slow-out).
    #[arg(long, default_value = "linear", value_name = "EASING")]
    pub easing: Easing,
    /// The path between the keyframes' fits, along the training frames' poses between them:
    /// rigid (as-rigid-as-possible between its corners) or latent (the decoder's, along the
    /// latents).
    #[arg(long, default_value = "rigid", value_name = "PATH")]
    pub path: PathArg,
    /// Place the in-betweens by hand instead: each one's position between A (0) and B (1), in
    /// increasing order, comma-separated (e.g. 0.1,0.3,0.6: a spacing chart).
    #[arg(long, value_name = "T,T,…", value_delimiter = ',', conflicts_with_all = ["steps", "easing"])]
    pub spacing: Vec<f32>,
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
    pub fit: FitArgs,
    #[command(flatten)]
    pub outfit: OutfitArgs,
    /// Also redraw the in-betweens with the model's appearance stage (generated/).
    #[arg(long)]
    pub appearance: bool,
    /// Fit each keyframe from the prior's placement too, and keep the fit that renders closer to
    /// it (a keyframe in a pose the model was never shown).
    #[arg(long, conflicts_with = "score")]
    pub prior: bool,
}

/// `--path`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum PathArg {
    /// As-rigid-as-possible between the corners of the path.
    Rigid,
    /// Along the latents.
    Latent,
}

impl From<PathArg> for InbetweenPath {
    fn from(p: PathArg) -> Self {
        match p {
            PathArg::Rigid => InbetweenPath::Rigid,
            PathArg::Latent => InbetweenPath::Latent,
        }
    }
}

/// Runs `puppet inbetween`.
pub fn run(args: InbetweenArgs, s: &Session) -> anyhow::Result<()> {
    let t = if args.spacing.is_empty() {
        eased_t(args.steps, args.easing, args.max_steps).context("--steps")?
    } else {
        spacing_t(&args.spacing, args.max_steps).context("--spacing")?
    };
    let device = puppet::backend::device();
    let dir = &args.model.model;
    let model = Model::load(dir, &device)?;
    let options = args.fit.options(Some(dir), &model, &device, &s.ui)?;
    if let Some(seq) = &args.score {
        let mut gaps = if args.gaps.is_empty() { vec![1] } else { args.gaps };
        gaps.sort_unstable();
        gaps.dedup();
        return score(&model, dir, seq, &gaps, &options, s);
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
    let stage = args.appearance.then(|| AppearanceStage::load(dir, &model, &device)).transpose()?;
    s.outputs.lock_folder(out)?;
    let files = files(&args, out);
    let sheet_path = out.join("sheet.png");
    s.outputs.claim(&sheet_path)?;
    let generated_files = AnimationFiles {
        frames: Some((out.join("generated"), "step".into())),
        background: args.animation.background,
        ..AnimationFiles::default()
    };
    s.ui.stage("inbetween", 0);
    let trained = training_frames(dir, &model, "the in-betweens take the straight path", &s.ui)?.unwrap_or_default();
    let waypoints = Waypoints::of_frames(&model, &trained.iter().collect::<Vec<_>>(), &device)?;
    let mut interp = Interpolator::new(&model, &a, &b, &options, &device)?.through(&waypoints);
    if args.prior {
        let keys = interp.keys().map(<[_]>::to_vec).to_vec();
        let kept = keep_closer(&puppet::prior::shipped(&device)?, &model, &[&a, &b], keys, &options, &device, &s.ui)?;
        let from_prior = kept.starts.iter().filter(|&&start| start == Start::Prior).count();
        s.ui.say(format!("{from_prior} of 2 keyframes kept the fit from the prior's placement"))?;
        let mut poses = kept.poses.into_iter();
        interp = interp.with_keys([poses.next().unwrap_or_default(), poses.next().unwrap_or_default()]);
    }
    let mut ib = along(&interp, &model, &t, args.path.into(), &device)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let key_l2 = |pose: Option<&Vec<[f32; 2]>>, frame| -> puppet::Result<f64> {
        pose.map_or(Ok(f64::NAN), |p| Ok(l2(&render_crisp(&model.puppet, p, w, h)?, frame)))
    };
    let (key_a, key_b) = (key_l2(ib.path.first(), &a)?, key_l2(ib.path.last(), &b)?);
    if let Some(worn) = &worn {
        ib = ib.dressed(&model, worn);
    }
    let drawn = worn.as_ref().unwrap_or(&model);
    write_inbetweens(drawn, &ib, &training, &files, &s.outputs, &s.ui)?;
    if let Some(stage) = &stage {
        let mut writer = AnimationWriter::new(&generated_files, ib.path.len(), w, h, &s.outputs)?;
        for (_, generated) in stage.render_and_redraw(&drawn.puppet, &ib.path, &device)? {
            writer.push(&generated)?;
        }
        writer.finish()?;
    }
    s.save_png(&sheet_path, &comparison_sheet(drawn, &ib, &training)?)?;
    s.ui.finish();
    for path in args.animation.animations() {
        s.ui.say(format!("wrote {}", path.display()))?;
    }
    s.ui.say(format!(
        "{} in-betweens ({} frames with the two ends, {}) from {} to {} → {} (inbetween/, vertex/, arap/{}{}, sheet.png, sprites.png + sprites.json)",
        t.len() - 2,
        t.len(),
        if args.spacing.is_empty() { args.easing.to_string() } else { "spaced by hand".to_string() },
        a_path.display(),
        b_path.display(),
        out.display(),
        if training.is_empty() { "" } else { ", nearest/" },
        if stage.is_some() { ", generated/" } else { "" }
    ))?;
    s.ui.say(format!(
        "the first and last frames are the keyframes' fits: L2 {key_a:.0} to {} and {key_b:.0} to {}",
        a_path.display(),
        b_path.display()
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
        path: AnimationFiles {
            frames: Some((out.join("inbetween"), "step".into())),
            sprites: Some((out.join("sprites.png"), args.columns)),
            ..args.animation.files(true)
        },
        vertex: frames("vertex"),
        rigid: frames("arap"),
        nearest: frames("nearest"),
        poses: Some(out.join("inbetween")),
    }
}

/// `--score`: the in-between table of `eval::inbetween_eval` on the odd frames of `seq`, a line
/// per gap.
fn score(model: &Model, dir: &Path, seq: &Path, gaps: &[usize], options: &FitOptions, s: &Session) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    s.ui.stage("score", 0);
    let table = score_sequence(dir, model, seq, gaps, options, &device, &s.ui)?;
    s.ui.finish();
    for at_gap in table {
        let gap = at_gap.gap;
        if at_gap.scores.is_empty() {
            s.ui.print(format!("gap {gap}: no odd frame lies between two even frames {} apart", gap + 1))?;
            continue;
        }
        let mean = |f: fn(&InbetweenScore) -> f64| at_gap.mean(f);
        s.ui.print(format!(
            "gap {gap}: {} in-betweens of {}: mean L2 — path rigid (default) {:.1}, path latent {:.1}, latent through the keyframes' fits straight {:.1}, plain latent {:.1}, vertex {:.1}, as-rigid-as-possible {:.1}, nearest even frame {:.1}, first keyframe held {:.1}, fit of the true frame {:.1}",
            at_gap.scores.len(),
            seq.display(),
            mean(|s| s.along_rigid),
            mean(|s| s.along_latent),
            mean(|s| s.keyed),
            mean(|s| s.latent),
            mean(|s| s.vertex),
            mean(|s| s.rigid),
            mean(|s| s.nearest),
            mean(|s| s.hold),
            mean(|s| s.fit)
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_frames_or_a_score_sequence() {
        let ab = |extra: &[&'static str]| [&["inbetween", "--model", "m", "a.png", "b.png", "-o", "o"][..], extra].concat();
        parses(&ab(&[
            "--steps",
            "4",
            "--gif",
            "x.gif",
            "--apng",
            "x.png",
            "--background",
            "transparent",
        ]));
        parses(&ab(&["--easing", "ease-in-out"]));
        parses(&ab(&["--spacing", "0.1,0.5,0.9"]));
        parses(&ab(&["--appearance"]));
        parses(&ab(&["--path", "latent"]));
        parses(&["inbetween", "--model", "m", "--score", "seq"]);
        parses(&["inbetween", "--model", "m", "--score", "seq", "--gaps", "1,3,5", "--one-pass"]);
        for bad in [
            ab(&["--easing", "bounce"]),
            ab(&["--path", "curved"]),
            ab(&["--spacing", "0.5", "--steps", "3"]),
            ab(&["--gaps", "3"]),
            ab(&["--background", "white"]),
            ab(&["--delay", "0"]),
            vec!["inbetween", "--model", "m", "a.png"],
            vec!["inbetween", "--model", "m", "--score", "seq", "--gif", "x.gif"],
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
