//! `puppet pose --model M <image> --pin x,y:tx,ty ... -o out.png`: drag points of a frame to new
//! places by optimising the latent (neural-puppet.md §4.2, eq. 7–9), with the direct vertex-space
//! ARAP drag beside it (Figure 6 right).

use std::path::{Path, PathBuf};

use puppet::edit::arap_drag::arap_drag;
use puppet::edit::load_frame::load_frame;
use puppet::edit::pin_overlay::pin_overlay;
use puppet::edit::pose::{Pin, PoseEditor, PoseOptions, DEFAULT_ETA};
use puppet::model::Model;
use puppet::picture::Picture;
use puppet::progress::Progress;
use puppet::puppet::pose_file::PoseFile;
use puppet::render::animation::write_gif;
use puppet::render::render_crisp;

use super::fit::RefineArgs;
use super::Ui;

/// Pose a frame by dragging points: each --pin moves the character's point x,y to tx,ty.
///
/// Writes OUTPUT (the posed character), OUTPUT's stem + "_arap.png" (the same pins solved
/// as-rigid-as-possible in vertex space, for comparison), + "_sheet.png" (input | fit | ours |
/// ARAP, pins drawn) and + ".json" (the posed vertices, for `puppet render --pose`).
#[derive(Debug, clap::Args)]
pub struct PoseArgs {
    /// The model folder (written by `puppet train`).
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
    /// The frame to pose (RGBA PNG of the puppet's frame size).
    pub image: PathBuf,
    /// A pin "x,y:tx,ty" in frame pixels: the point x,y on the character goes to tx,ty.
    /// Repeat for several pins.
    #[arg(long = "pin", value_parser = parse_pin, required = true, value_name = "X,Y:TX,TY")]
    pub pins: Vec<Pin>,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Gradient steps on the latent (paper: 2 to 5).
    #[arg(long, default_value_t = 5)]
    pub steps: usize,
    /// Step size η of eq. 9.
    #[arg(long, default_value_t = DEFAULT_ETA)]
    pub eta: f32,
    /// Weight α1 of the ARAP term (paper: 25).
    #[arg(long, default_value_t = 25.0)]
    pub alpha_reg: f32,
    /// Weight α2 of the joint term (paper: 50).
    #[arg(long, default_value_t = 50.0)]
    pub alpha_joints: f32,
    /// Also write the drag as an animated GIF: the targets move from the grabbed points to their
    /// destinations over this many updates, each continuing from the last (as an editor would).
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// Number of drag updates in the GIF.
    #[arg(long, default_value_t = 12, value_name = "N")]
    pub gif_frames: usize,
    #[command(flatten)]
    pub refine: RefineArgs,
}

/// Parses "x,y:tx,ty".
pub fn parse_pin(s: &str) -> Result<Pin, String> {
    let bad = || format!("{s:?} is not a pin X,Y:TX,TY (e.g. 40,60:52,48)");
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let point = |t: &str| -> Result<[f32; 2], String> {
        let (x, y) = t.split_once(',').ok_or_else(bad)?;
        let (x, y) = (
            x.trim().parse::<f32>().map_err(|_| bad())?,
            y.trim().parse::<f32>().map_err(|_| bad())?,
        );
        if x.is_finite() && y.is_finite() {
            Ok([x, y])
        } else {
            Err(bad())
        }
    };
    Ok(Pin {
        from: point(a)?,
        to: point(b)?,
    })
}

/// `out.png` → `out<suffix>`.
fn beside(output: &Path, suffix: &str) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pose".into());
    output.with_file_name(format!("{stem}{suffix}"))
}

/// Runs `puppet pose`.
pub fn run(args: PoseArgs, ui: &Ui) -> anyhow::Result<()> {
    let options = PoseOptions {
        steps: args.steps,
        eta: args.eta,
        alpha_reg: args.alpha_reg,
        alpha_joints: args.alpha_joints,
    };
    options.validate()?;
    anyhow::ensure!(
        args.gif.is_none() || args.gif_frames >= 2,
        "--gif-frames {}: need at least 2",
        args.gif_frames
    );
    let device = puppet::backend::device();
    let model = Model::load(&args.model, &device)?;
    let frame = load_frame(&args.image, &model)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let mut editor = PoseEditor::new(&model, &frame, &args.refine.options(&args.model)?, &device)?;
    let sources: Vec<[f32; 2]> = args.pins.iter().map(|p| p.from).collect();
    let targets: Vec<[f32; 2]> = args.pins.iter().map(|p| p.to).collect();
    editor
        .set_pins(&sources)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.image.display()))?;
    ui.stage("pose", 0);
    let started = std::time::Instant::now();
    let dragged = editor.drag(&targets, &options)?;
    let took = started.elapsed();
    let pins: Vec<_> = editor.bindings().iter().copied().zip(targets.iter().copied()).collect();
    let arap = arap_drag(&model.puppet, editor.fitted(), &pins)?;
    let ours = render_crisp(&model.puppet, &dragged.vertices, w, h)?;
    let fit = render_crisp(&model.puppet, editor.fitted(), w, h)?;
    let arap_pic = render_crisp(&model.puppet, &arap, w, h)?;
    ours.save_png(&args.output)?;
    arap_pic.save_png(&beside(&args.output, "_arap.png"))?;
    PoseFile {
        vertices: dragged.vertices.clone(),
    }
    .save(&beside(&args.output, ".json"))?;
    let drawn: Vec<Picture> = [&frame, &fit, &ours, &arap_pic]
        .iter()
        .map(|p| pin_overlay(p, &args.pins))
        .collect();
    let refs: Vec<&Picture> = drawn.iter().collect();
    puppet::synth::output::contact_sheet(&refs, 4).save_png(&beside(&args.output, "_sheet.png"))?;
    if let Some(gif) = &args.gif {
        let n = args.gif_frames;
        ui.stage("drag", n as u64);
        editor.reset();
        let mut frames = Vec::with_capacity(n);
        for k in 1..=n {
            let s = k as f32 / n as f32;
            let t: Vec<[f32; 2]> = args
                .pins
                .iter()
                .map(|p| [p.from[0] + s * (p.to[0] - p.from[0]), p.from[1] + s * (p.to[1] - p.from[1])])
                .collect();
            let step = editor.drag(&t, &options)?;
            let pic = render_crisp(&model.puppet, &step.vertices, w, h)?;
            let shown: Vec<Pin> = args.pins.iter().zip(&t).map(|(p, &to)| Pin { from: p.from, to }).collect();
            frames.push(pin_overlay(&pic, &shown));
            ui.advance(1);
        }
        write_gif(gif, &frames, 80, [1.0; 3])?;
        ui.say(format!("wrote {}", gif.display()));
    }
    let errors: Vec<String> = dragged.pin_error.iter().map(|e| format!("{e:.1}")).collect();
    ui.say(format!(
        "{} pin(s), {} steps in {:.1} ms: pin error [{}] px, L_deform {:.3e} → {:.3e} → {} (+ _arap.png, _sheet.png, .json)",
        args.pins.len(),
        options.steps,
        took.as_secs_f64() * 1e3,
        errors.join(", "),
        dragged.loss.first().copied().unwrap_or(0.0),
        dragged.loss.last().copied().unwrap_or(0.0),
        args.output.display()
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_pin;

    #[test]
    fn pins_parse_and_bad_ones_are_explained() {
        let p = parse_pin("40,60:52.5,48").unwrap();
        assert_eq!((p.from, p.to), ([40.0, 60.0], [52.5, 48.0]));
        for bad in ["40,60", "40:60", "a,b:c,d", "1,2:3", "nan,1:2,3"] {
            assert!(parse_pin(bad).unwrap_err().contains("is not a pin"), "{bad}");
        }
    }
}
