//! `puppet inbetween --model M <a.png> <b.png> --steps N -o DIR [--gif out.gif]`: in-betweens by
//! latent interpolation (neural-puppet.md §4.1), with the vertex-space interpolation and the
//! nearest training frame beside each step (Figure 5).

use std::path::PathBuf;

use anyhow::Context;
use puppet::edit::inbetween::{inbetween, nearest_frame};
use puppet::edit::load_frame::load_frame;
use puppet::model::Model;
use puppet::picture::Picture;
use puppet::progress::Progress;
use puppet::puppet::pose_file::PoseFile;
use puppet::render::animation::{sprite_sheet, write_gif, write_png_sequence};
use puppet::render::render_crisp;
use puppet::train::refine::RefineOptions;

use super::fit::RefineArgs;
use super::Ui;

/// Make in-between frames of two frames by interpolating their latent codes.
///
/// Writes into OUTPUT: latent/step_NNN.png (the decoded latent interpolation, end frames
/// included), vertex/step_NNN.png (linear interpolation of the two fitted meshes, for
/// comparison), latent/step_NNN.json (each pose's vertices), nearest/step_NNN.png (the training
/// frame nearest each latent step, with --training), sheet.png (rows: latent, vertex, nearest)
/// and sprites.png (the latent steps as a sprite sheet).
#[derive(Debug, clap::Args)]
pub struct InbetweenArgs {
    /// The model folder (written by `puppet train`).
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
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
    #[arg(long, value_name = "SEQUENCE", conflicts_with_all = ["a", "b", "gif", "training"])]
    pub score: Option<PathBuf>,
    /// Number of in-between frames strictly between A and B (1 to 10000).
    #[arg(long, default_value_t = 8)]
    pub steps: usize,
    /// Output folder (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Also write the latent in-betweens as an animated GIF (there and back).
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// GIF frame time in milliseconds.
    #[arg(long, default_value_t = 80, value_name = "MS")]
    pub delay: u32,
    /// Folder of training frames: the nearest one (Euclidean image distance) is written beside
    /// each step.
    #[arg(long, value_name = "DIR")]
    pub training: Option<PathBuf>,
    /// Cells per row of sprites.png.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub columns: usize,
    #[command(flatten)]
    pub refine: RefineArgs,
}

/// Runs `puppet inbetween`.
pub fn run(args: InbetweenArgs, ui: &Ui) -> anyhow::Result<()> {
    puppet::edit::inbetween::steps_t(args.steps)?;
    let device = puppet::backend::device();
    let model = Model::load(&args.model, &device)?;
    if let Some(seq) = &args.score {
        return score(&model, seq, &args.refine.options(&args.model)?, ui);
    }
    let (Some(a_path), Some(b_path)) = (&args.a, &args.b) else {
        anyhow::bail!("give two frames A and B (or --score SEQUENCE)");
    };
    let a = load_frame(a_path, &model)?;
    let b = load_frame(b_path, &model)?;
    let training = match &args.training {
        Some(dir) => load_training(dir, &model)?,
        None => Vec::new(),
    };
    ui.stage("inbetween", 0);
    let out = inbetween(&model, &a, &b, args.steps, &args.refine.options(&args.model)?, &device)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    ui.stage("render", out.t.len() as u64);
    let mut latent = Vec::with_capacity(out.t.len());
    let mut vertex = Vec::with_capacity(out.t.len());
    for (lv, vv) in out.latent.iter().zip(&out.vertex) {
        latent.push(render_crisp(&model.puppet, lv, w, h)?);
        vertex.push(render_crisp(&model.puppet, vv, w, h)?);
        ui.advance(1);
    }
    let nearest: Vec<Picture> = latent
        .iter()
        .filter_map(|p| nearest_frame(p, &training).map(|(k, _)| training[k].clone()))
        .collect();
    let dir = &args.output;
    let latent_paths = write_png_sequence(&dir.join("latent"), "step", &latent)?;
    for (path, pose) in latent_paths.iter().zip(&out.latent) {
        PoseFile { vertices: pose.clone() }.save(&path.with_extension("json"))?;
    }
    write_png_sequence(&dir.join("vertex"), "step", &vertex)?;
    let mut rows: Vec<&Picture> = latent.iter().chain(&vertex).collect();
    if !nearest.is_empty() {
        write_png_sequence(&dir.join("nearest"), "step", &nearest)?;
        rows.extend(&nearest);
    }
    puppet::synth::output::contact_sheet(&rows, latent.len()).save_png(&dir.join("sheet.png"))?;
    sprite_sheet(&latent, args.columns)?.save_png(&dir.join("sprites.png"))?;
    if let Some(gif) = &args.gif {
        // There and back, so the loop has no jump.
        let frames: Vec<Picture> = latent
            .iter()
            .chain(latent.iter().rev().skip(1).take(latent.len().saturating_sub(2)))
            .cloned()
            .collect();
        write_gif(gif, &frames, args.delay, [1.0; 3])?;
        ui.say(format!("wrote {}", gif.display()));
    }
    ui.say(format!(
        "{} steps from {} to {} → {} (latent/, vertex/{}, sheet.png, sprites.png)",
        out.t.len(),
        a_path.display(),
        b_path.display(),
        dir.display(),
        if nearest.is_empty() { "" } else { ", nearest/" }
    ));
    Ok(())
}

/// `--score`: the in-between table of `edit::inbetween_eval` on the odd frames of `seq`.
fn score(model: &Model, seq: &std::path::Path, refine: &RefineOptions, ui: &Ui) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let frames = puppet::train::Frames::load(seq)?;
    for (file, f) in frames.files.iter().zip(&frames.frames) {
        model.check_frame(f).map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    }
    let n = frames.frames.len();
    let even: Vec<usize> = (0..n).step_by(2).collect();
    let odd: Vec<usize> = (1..n).step_by(2).collect();
    ui.stage("score", 0);
    let scores = puppet::edit::inbetween_eval::inbetween_scores(model, &frames.frames, &even, &odd, refine, &device)?;
    ui.finish();
    let mean = |f: fn(&puppet::edit::inbetween_eval::InbetweenScore) -> f64| scores.iter().map(f).sum::<f64>() / scores.len() as f64;
    ui.say(format!(
        "{} held-out frames of {}: mean L2 — latent {:.1}, vertex {:.1}, nearest even frame {:.1}, previous frame {:.1}, fit of the true frame {:.1}",
        scores.len(),
        seq.display(),
        mean(|s| s.latent),
        mean(|s| s.vertex),
        mean(|s| s.nearest),
        mean(|s| s.hold),
        mean(|s| s.fit)
    ));
    Ok(())
}

/// Every PNG in `dir` (natural order), checked against the model.
fn load_training(dir: &std::path::Path, model: &Model) -> anyhow::Result<Vec<Picture>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading --training {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    files.sort();
    anyhow::ensure!(!files.is_empty(), "--training {}: no PNG frames", dir.display());
    Ok(files.iter().map(|f| load_frame(f, model)).collect::<Result<_, _>>()?)
}
