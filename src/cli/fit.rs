//! `puppet fit --model M <frames...> -o dir`: fit the puppet to frames with a trained model
//! (`--puppet P`: a character nobody trained, placed by the prior).

use std::path::PathBuf;

use puppet::appearance::AppearanceStage;
use puppet::atomic_file::unique_stems;
use puppet::fit::frame;
use puppet::picture::{contact_sheet, Picture};
use puppet::prior::Start;
use puppet::progress::Progress;
use puppet::puppet::pose_file::PoseFile;
use puppet::puppet::sequence::Frames;
use puppet::render::animation::{AnimationFiles, AnimationWriter};
use puppet::render::preview::wireframe_preview;
use puppet::render::render_pose;

use super::args::{AnimationArgs, FitArgs as FitOptionArgs, FitSource, FitSourceArgs, Fits, OutfitArgs};
use super::Session;

/// The most frames sheet.png shows (evenly sampled when more are fitted).
const SHEET_ROWS: usize = 16;

/// Fit the puppet to frames: for each, the fitted mesh over the frame (NAME_overlay.png), the
/// rendered reconstruction (NAME_render.png) and the fitted vertices (NAME_vertices.json, for
/// `puppet render --pose`), plus sheet.png with frame | render | overlay side by side and the
/// renders in order as sprites.png + sprites.json (a sheet and atlas for engines; --gif and
/// --apng play them). NAME is
/// the frame's file name, prefixed by its folders where two frames share a name. With --puppet
/// instead of --model, a character nobody trained is fitted: each frame placed by the prior,
/// then the stages that need no network of it. Frames that cannot be read are named and
/// skipped; the command then exits with status 1.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    #[command(flatten)]
    pub source: FitSourceArgs,
    /// Frames: PNG files, or folders of them (or holding frames/).
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub fit: FitOptionArgs,
    #[command(flatten)]
    pub outfit: OutfitArgs,
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Also write the appearance stage's redraw of each fit (NAME_generated.png; a fourth column
    /// in sheet.png).
    #[arg(long)]
    pub appearance: bool,
    /// Cells per row of sprites.png.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub columns: usize,
}

/// Runs `puppet fit`.
pub fn run(args: FitArgs, s: &Session) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let source = args.source.load(&device, &s.ui)?;
    let FitSource { model, dir, .. } = &source;
    let options = args.fit.options(dir.as_deref(), model, &device, &s.ui)?;
    let worn = args.outfit.model(model, &s.ui)?;
    let drawn = worn.as_ref().unwrap_or(model);
    let stage = match (&dir, args.appearance) {
        (Some(dir), true) => Some(AppearanceStage::load(dir, model, &device)?),
        (None, true) => anyhow::bail!("--appearance needs a trained model (--model): a puppet nobody trained has no appearance stage"),
        _ => None,
    };
    let check = frame::frame_check(model);
    let (mut files, mut pictures, mut problems) = (Vec::new(), Vec::new(), Vec::new());
    for path in &args.frames {
        if path.is_dir() {
            let (seq, bad) = Frames::load_each(path, &check)?;
            files.extend(seq.files);
            pictures.extend(seq.frames);
            problems.extend(bad.into_iter().map(|(_, e)| e));
        } else {
            match frame::load_frame(path, model) {
                Ok(p) => {
                    files.push(path.clone());
                    pictures.push(p);
                }
                Err(e) => problems.push(e),
            }
        }
    }
    if pictures.is_empty() {
        // Nothing to fit: the reasons are the whole answer.
        puppet::Error::collect(std::mem::take(&mut problems))?;
    }
    let stems = unique_stems(&files);
    let out = &args.output;
    s.outputs.lock_folder(out)?;
    let paths = |stem: &str| ["render.png", "overlay.png", "vertices.json"].map(|end| out.join(format!("{stem}_{end}")));
    let generated_path = |stem: &str| out.join(format!("{stem}_generated.png"));
    for stem in &stems {
        for path in paths(stem) {
            s.outputs.claim(&path)?;
        }
        if stage.is_some() {
            s.outputs.claim(&generated_path(stem))?;
        }
    }
    let sheet_path = out.join("sheet.png");
    s.outputs.claim(&sheet_path)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let sprites = AnimationFiles {
        sprites: Some((out.join("sprites.png"), args.columns)),
        ..args.animation.files(false)
    };
    let mut animation = AnimationWriter::new(&sprites, pictures.len(), w, h, &s.outputs)?;

    s.ui.stage("fitting", pictures.len() as u64);
    let refs: Vec<&Picture> = pictures.iter().collect();
    let Fits { poses: fits, starts } = source.fit(&refs, &options, &device, &s.ui)?;
    if let Some(starts) = starts {
        let from_prior: Vec<&str> = stems
            .iter()
            .zip(&starts)
            .filter(|(_, &s)| s == Start::Prior)
            .map(|(n, _)| n.as_str())
            .collect();
        s.ui.finish();
        s.ui.say(format!(
            "{} of {} frames kept the fit from the prior's placement (it rendered closer than the fit from the network's){}",
            from_prior.len(),
            stems.len(),
            if from_prior.is_empty() {
                String::new()
            } else {
                format!(": {}", from_prior.join(", "))
            }
        ))?;
    }
    // The ranges read with the options (for the term or the hidden limbs' twins); otherwise read
    // here only to name poses the model has not seen.
    let read;
    let ranges = match (&options.ranges, &dir) {
        (Some(ranges), _) => Some(ranges),
        (None, Some(dir)) => {
            read = args
                .fit
                .training_ranges(dir, model, &device, "no fit is checked against the training poses", &s.ui)?;
            read.as_ref()
        }
        (None, None) => None,
    };
    if let Some(ranges) = ranges {
        for (stem, pose) in stems.iter().zip(&fits) {
            if let Some((layer, degrees)) = ranges.worst(pose) {
                s.ui.warn(&format!(
                    "{stem}: {} turned {degrees:.0}° past the turns of the training frames (+{}°): a pose the model has not seen",
                    model.puppet.layers[layer].name, args.fit.plausible_margin
                ));
            }
        }
    }
    s.ui.stage("writing", pictures.len() as u64);
    let scale = (512 / w.max(h)).clamp(1, 4);
    let shown: Vec<usize> = (0..SHEET_ROWS.min(pictures.len()))
        .map(|k| k * pictures.len() / SHEET_ROWS.min(pictures.len()).max(1))
        .collect();
    let mut rows: Vec<Picture> = Vec::new();
    for (k, ((stem, picture), pose)) in stems.iter().zip(&pictures).zip(fits).enumerate() {
        let [render_path, overlay_path, vertices_path] = paths(stem);
        let pose = drawn.pose_from(model, &pose);
        let render = render_pose(&drawn.puppet, &pose, w, h, 0.0, args.animation.background)?;
        animation.push(&render)?;
        let overlay = wireframe_preview(&drawn.puppet, &pose, picture, scale);
        s.save_png(&render_path, &render)?;
        s.save_png(&overlay_path, &overlay)?;
        s.outputs.write(&vertices_path, &PoseFile { vertices: pose.clone() }.to_json())?;
        let generated = match &stage {
            Some(stage) => {
                let (_, generated) = stage
                    .render_and_redraw(&drawn.puppet, std::slice::from_ref(&pose), &device)?
                    .remove(0);
                s.save_png(&generated_path(stem), &generated)?;
                Some(generated)
            }
            None => None,
        };
        if shown.contains(&k) {
            rows.extend([picture.upscaled_on_white(scale), render.upscaled_on_white(scale), overlay]);
            rows.extend(generated.map(|g| g.upscaled_on_white(scale)));
        }
        s.ui.advance(1);
    }
    if !rows.is_empty() {
        s.save_png(
            &sheet_path,
            &contact_sheet(&rows.iter().collect::<Vec<_>>(), 3 + usize::from(stage.is_some())),
        )?;
    }
    animation.finish()?;
    s.ui.finish();
    for path in args.animation.animations() {
        s.ui.say(format!("wrote {}", path.display()))?;
    }
    s.ui.say(format!(
        "fitted {} frames → {} (side by side: {}{}; sprites.png + sprites.json)",
        pictures.len(),
        out.display(),
        sheet_path.display(),
        if pictures.len() > SHEET_ROWS {
            format!(", {SHEET_ROWS} of them")
        } else {
            String::new()
        }
    ))?;
    puppet::Error::collect(problems)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_frames_and_fit_options() {
        parses(&["fit", "--model", "m", "a.png", "dir", "-o", "out", "--one-pass"]);
        parses(&[
            "fit",
            "--model",
            "m",
            "a.png",
            "-o",
            "out",
            "--latent-steps",
            "10",
            "--vertex-steps",
            "0",
            "--no-limb-search",
        ]);
        assert!(
            clap::Parser::try_parse_from(["puppet", "fit", "--model", "m", "-o", "out"])
                .map(|_: crate::cli::Cli| ())
                .is_err(),
            "frames are required"
        );
    }
}
