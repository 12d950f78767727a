//! `puppet fit --model M <frames...> -o dir`: fit the puppet to frames with a trained model.

use std::path::PathBuf;

use anyhow::Context;
use puppet::model::Model;
use puppet::picture::Picture;
use puppet::progress::Progress;
use puppet::puppet::pose_file::PoseFile;
use puppet::render::preview::wireframe_preview;
use puppet::render::render_crisp;
use puppet::train::refine::{self, refined_fit, RefineOptions};
use puppet::train::Frames;

use super::Ui;

/// Fit the puppet to frames: for each, the fitted mesh over the frame (NAME_overlay.png), the
/// rendered reconstruction (NAME_render.png) and the fitted vertices (NAME_vertices.json, for
/// `puppet render --pose`), plus sheet.png with frame | render | overlay side by side.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    /// The model folder written by `puppet train`.
    #[arg(long)]
    pub model: PathBuf,
    /// Frames: PNG files, or folders of them.
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub refine: FitRefineArgs,
}

/// Latent refinement options shared by every command that fits frames.
#[derive(Debug, clap::Args)]
pub struct RefineArgs {
    /// After the encoder, this many Adam steps on each frame's latent lowering the training
    /// objective for that frame (analysis by synthesis; the weights do not change). 0 = the
    /// encoder's one-pass fit, as the paper evaluates; ~0.1 s per step for 16 frames at 128².
    #[arg(long, default_value_t = refine::DEFAULT_STEPS)]
    pub refine: usize,
}

impl RefineArgs {
    /// Latent refinement with the objective the model in `model_dir` was trained with; no
    /// vertex steps (edits move latents).
    pub fn options(&self, model_dir: &std::path::Path) -> puppet::Result<RefineOptions> {
        RefineOptions::for_model(model_dir, self.refine, 0)
    }
}

/// Refinement options of the commands whose result is a fit (`fit`, `eval`, `correspond`).
#[derive(Debug, clap::Args)]
pub struct FitRefineArgs {
    #[command(flatten)]
    pub latent: RefineArgs,
    /// Then this many Adam steps on the vertices themselves per round, σ falling from the
    /// training's first to its last: off the decoder's manifold, held by the ARAP and joint
    /// terms — a closer fit of poses the training frames never showed. 0 = stay on the manifold
    /// (no limb search either); ~0.03 s per step for 16 frames at 128².
    #[arg(long, default_value_t = refine::DEFAULT_VERTEX_STEPS)]
    pub refine_vertices: usize,
    /// Rounds of vertex refinement, each a search over limb turns about their joints (for limbs
    /// drawn far from where the network put them) and then `--refine-vertices` steps.
    #[arg(long, default_value_t = RefineOptions::default().vertex_rounds)]
    pub vertex_rounds: usize,
    /// Skip the limb search: vertex steps only.
    #[arg(long)]
    pub no_limb_search: bool,
}

impl FitRefineArgs {
    /// Latent then vertex refinement with the objective the model in `model_dir` was trained with.
    pub fn options(&self, model_dir: &std::path::Path) -> puppet::Result<RefineOptions> {
        let options = RefineOptions::for_model(model_dir, self.latent.refine, self.refine_vertices)?;
        Ok(RefineOptions {
            vertex_rounds: self.vertex_rounds,
            limb_search: options.limb_search.filter(|_| !self.no_limb_search),
            ..options
        })
    }
}

/// Runs `puppet fit`.
pub fn run(args: FitArgs, ui: &Ui) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let model = Model::load(&args.model, &device)?;
    let mut files = Vec::new();
    let mut pictures = Vec::new();
    for path in &args.frames {
        if path.is_dir() {
            let seq = Frames::load(path)?;
            files.extend(seq.files);
            pictures.extend(seq.frames);
        } else {
            pictures.push(Picture::load(path)?);
            files.push(path.clone());
        }
    }
    for (file, picture) in files.iter().zip(&pictures) {
        model.check_frame(picture).with_context(|| format!("{}", file.display()))?;
    }
    ui.stage("fitting", pictures.len() as u64);
    let (w, h) = (model.puppet.width, model.puppet.height);
    let scale = (512 / w.max(h)).clamp(1, 4);
    let mut rows = Vec::new();
    for (chunk_files, chunk) in files.chunks(16).zip(pictures.chunks(16)) {
        let refs: Vec<&Picture> = chunk.iter().collect();
        let fits = refined_fit(&model, &refs, &args.refine.options(&args.model)?, &device)?;
        for ((file, picture), fit) in chunk_files.iter().zip(chunk).zip(fits) {
            let stem = file.file_stem().map_or("frame".into(), |s| s.to_string_lossy().into_owned());
            let render = render_crisp(&model.puppet, &fit, w, h)?;
            let overlay = wireframe_preview(&model.puppet, &fit, picture, scale);
            render.save_png(&args.output.join(format!("{stem}_render.png")))?;
            overlay.save_png(&args.output.join(format!("{stem}_overlay.png")))?;
            PoseFile { vertices: fit }.save(&args.output.join(format!("{stem}_vertices.json")))?;
            rows.push([upscale(picture, scale), upscale(&render, scale), overlay]);
            ui.advance(1);
        }
    }
    ui.finish();
    let sheet_path = args.output.join("sheet.png");
    sheet(&rows).save_png(&sheet_path)?;
    ui.say(format!(
        "fitted {} frames → {} (side by side: {})",
        rows.len(),
        args.output.display(),
        sheet_path.display()
    ));
    Ok(())
}

/// Nearest-neighbour upscale over white (matching the overlay's look).
fn upscale(p: &Picture, s: u32) -> Picture {
    let mut out = Picture::filled(p.width * s, p.height * s, [1.0; 4]);
    for y in 0..out.height {
        for x in 0..out.width {
            let [r, g, b, a] = p.get(x / s, y / s);
            out.pixels[(y * out.width + x) as usize] = [r * a + 1.0 - a, g * a + 1.0 - a, b * a + 1.0 - a, 1.0];
        }
    }
    out
}

/// Rows of equally sized pictures, 4 px apart, on light grey.
fn sheet(rows: &[[Picture; 3]]) -> Picture {
    let (cw, ch) = rows.first().map_or((1, 1), |r| (r[0].width, r[0].height));
    let gap = 4;
    let mut out = Picture::filled(3 * cw + 4 * gap, rows.len() as u32 * (ch + gap) + gap, [0.9, 0.9, 0.9, 1.0]);
    for (ri, row) in rows.iter().enumerate() {
        for (ci, pic) in row.iter().enumerate() {
            let (ox, oy) = (gap + ci as u32 * (cw + gap), gap + ri as u32 * (ch + gap));
            for y in 0..pic.height.min(ch) {
                for x in 0..pic.width.min(cw) {
                    out.pixels[((oy + y) * out.width + ox + x) as usize] = pic.get(x, y);
                }
            }
        }
    }
    out
}
