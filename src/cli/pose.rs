//! `puppet pose --model M <image> --pin x,y:tx,ty ... -o out.png`: drag points of a frame to new
//! places by optimising the latent (neural-puppet.md §4.2, eq. 7–9), with the direct vertex-space
//! ARAP drag beside it (Figure 6 right).

use std::path::{Path, PathBuf};

use anyhow::Context as _;

use puppet::appearance::AppearanceStage;
use puppet::edit::arap_drag::arap_drag;
use puppet::edit::pin::Pin;
use puppet::edit::pin_overlay::pin_overlay;
use puppet::edit::pose::{PoseEditor, PoseOptions, DEFAULT_ETA};
use puppet::error::Context;
use puppet::fit::frame::load_frame;
use puppet::model::Model;
use puppet::picture::{contact_sheet, Picture};
use puppet::progress::Progress;
use puppet::puppet::pose_file::PoseFile;
use puppet::render::animation::{AnimationFiles, AnimationWriter};
use puppet::render::{render_crisp, render_pose};

use super::args::{parse_pin, AnimationArgs, LatentFitArgs, ModelArgs, OutfitArgs};
use super::Session;

/// Drag points of a frame to new places: the frame is fitted, each pin's point is bound to the
/// fitted mesh, and the latent is optimised so the points reach their targets (eq. 7–9).
///
/// Writes OUTPUT (the posed frame), OUTPUT_arap.png (the same pins solved directly by ARAP in
/// vertex space), OUTPUT_sheet.png (input | fit | ours | ARAP, pins drawn) and OUTPUT.json (the
/// posed vertices); with --gif / --apng / --sprites, the drag as an editor runs it.
#[derive(Debug, clap::Args)]
pub struct PoseArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The frame to pose (RGBA PNG of the puppet's frame size).
    pub image: PathBuf,
    /// A pin: the point X,Y (frame pixels, on the character) goes to TX,TY. Repeat for more.
    #[arg(long = "pin", value_parser = parse_pin, required = true, value_name = "X,Y:TX,TY")]
    pub pins: Vec<Pin>,
    /// The posed frame (a .png path; the other outputs are named after it).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Gradient steps on the latent (paper: 2 to 5).
    #[arg(long, default_value_t = 5)]
    pub steps: usize,
    /// The first step size η (later steps adapt it).
    #[arg(long, default_value_t = DEFAULT_ETA)]
    pub eta: f32,
    /// α1, the ARAP regulariser's weight (paper: 25).
    #[arg(long, default_value_t = 25.0)]
    pub alpha_reg: f32,
    /// α2, the joint term's weight (paper: 50).
    #[arg(long, default_value_t = 50.0)]
    pub alpha_joints: f32,
    /// The drag's animation (--gif, --apng): updates along straight lines to the targets.
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Also write the drag's updates as a sprite sheet with its atlas (FILE.png + FILE.json).
    #[arg(long, value_name = "FILE")]
    pub sprites: Option<PathBuf>,
    /// Also redraw the dragged pose with the model's appearance stage (OUT_generated.png, a
    /// fifth cell in the sheet).
    #[arg(long)]
    pub appearance: bool,
    /// Updates in the drag's animation.
    #[arg(long, alias = "gif-frames", default_value_t = 12, value_name = "N")]
    pub drag_frames: usize,
    #[command(flatten)]
    pub fit: LatentFitArgs,
    #[command(flatten)]
    pub outfit: OutfitArgs,
}

/// `output` with `suffix` in place of its extension (`out.png` → `out_arap.png`).
fn beside(output: &Path, suffix: &str) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pose".into());
    output.with_file_name(format!("{stem}{suffix}"))
}

/// Runs `puppet pose`.
pub fn run(args: PoseArgs, s: &Session) -> anyhow::Result<()> {
    let options = PoseOptions {
        steps: args.steps,
        eta: args.eta,
        alpha_reg: args.alpha_reg,
        alpha_joints: args.alpha_joints,
    };
    options.validate().context("--steps, --eta, --alpha-reg, --alpha-joints")?;
    anyhow::ensure!(
        args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")),
        "-o {}: the posed frame is a PNG (give a path ending in .png)",
        args.output.display()
    );
    let animated = args.animation.gif.is_some() || args.animation.apng.is_some() || args.sprites.is_some();
    anyhow::ensure!(
        !animated || args.drag_frames >= 2,
        "--drag-frames {}: need at least 2",
        args.drag_frames
    );
    let (arap_path, sheet_path, json_path) = (
        beside(&args.output, "_arap.png"),
        beside(&args.output, "_sheet.png"),
        beside(&args.output, ".json"),
    );
    let generated_path = beside(&args.output, "_generated.png");
    for path in [&args.output, &arap_path, &sheet_path, &json_path] {
        s.outputs.claim(path)?;
    }
    if args.appearance {
        s.outputs.claim(&generated_path)?;
    }
    let device = puppet::backend::device();
    let dir = &args.model.model;
    let model = Model::load(dir, &device)?;
    let worn = args.outfit.model(&model, &s.ui)?;
    let drawn = worn.as_ref().unwrap_or(&model);
    let stage = args.appearance.then(|| AppearanceStage::load(dir, &model, &device)).transpose()?;
    let frame = load_frame(&args.image, &model)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let mut editor = PoseEditor::new(&model, &frame, &args.fit.options(dir)?, &device)?;
    let sources: Vec<[f32; 2]> = args.pins.iter().map(|p| p.from).collect();
    let targets: Vec<[f32; 2]> = args.pins.iter().map(|p| p.to).collect();
    editor.set_pins(&sources).at_path(&args.image)?;
    let drag = animated
        .then(|| {
            let files = AnimationFiles {
                sprites: args.sprites.clone().map(|path| (path, args.drag_frames)),
                ..args.animation.files(false)
            };
            AnimationWriter::new(&files, args.drag_frames, w, h, &s.outputs)
        })
        .transpose()?;
    s.ui.stage("pose", 0);
    let started = std::time::Instant::now();
    let dragged = editor.drag(&targets, &options)?;
    let took = started.elapsed();
    let pins: Vec<_> = editor.bindings().iter().copied().zip(targets.iter().copied()).collect();
    let arap = drawn.pose_from(&model, &arap_drag(&model.puppet, editor.fitted(), &pins)?);
    let posed = drawn.pose_from(&model, &dragged.vertices);
    let background = args.animation.background;
    let ours = render_pose(&drawn.puppet, &posed, w, h, 0.0, background)?;
    let fit = render_crisp(&drawn.puppet, &drawn.pose_from(&model, editor.fitted()), w, h)?;
    let arap_pic = render_pose(&drawn.puppet, &arap, w, h, 0.0, background)?;
    s.save_png(&args.output, &ours)?;
    s.save_png(&arap_path, &arap_pic)?;
    s.outputs.write(&json_path, &PoseFile { vertices: posed.clone() }.to_json())?;
    let mut cells: Vec<Picture> = [&frame, &fit, &ours, &arap_pic]
        .iter()
        .map(|p| pin_overlay(p, &args.pins))
        .collect();
    if let Some(stage) = &stage {
        let (_, generated) = stage
            .render_and_redraw(&drawn.puppet, std::slice::from_ref(&posed), &device)?
            .remove(0);
        s.save_png(&generated_path, &generated)?;
        cells.push(pin_overlay(&generated, &args.pins));
    }
    s.save_png(&sheet_path, &contact_sheet(&cells.iter().collect::<Vec<_>>(), cells.len()))?;
    if let Some(mut writer) = drag {
        s.ui.stage("drag", args.drag_frames as u64);
        editor.write_drag(drawn, &args.pins, args.drag_frames, &options, &mut writer, &s.ui)?;
        for path in writer.finish()? {
            s.ui.say(format!("wrote {}", path.display()))?;
        }
    }
    s.ui.finish();
    let errors: Vec<String> = dragged.pin_error.iter().map(|e| format!("{e:.1}")).collect();
    s.ui.say(format!(
        "{} pin(s), {} steps in {:.1} ms: pin error [{}] px, L_deform {:.3e} → {:.3e} → {} (+ _arap.png, _sheet.png, .json)",
        args.pins.len(),
        options.steps,
        took.as_secs_f64() * 1e3,
        errors.join(", "),
        dragged.loss.first().copied().unwrap_or(0.0),
        dragged.loss.last().copied().unwrap_or(0.0),
        args.output.display()
    ))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_pins_and_drag_options() {
        parses(&[
            "pose",
            "--model",
            "m",
            "f.png",
            "--pin",
            "1,2:3,4",
            "--pin",
            "5,6:7,8",
            "-o",
            "o.png",
            "--steps",
            "3",
            "--gif",
            "d.gif",
            "--apng",
            "d.png",
            "--sprites",
            "s.png",
            "--background",
            "#102030",
        ]);
        for bad in [
            vec!["pose", "--model", "m", "f.png", "-o", "o.png"],
            vec!["pose", "--model", "m", "f.png", "--pin", "1,2", "-o", "o.png"],
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
