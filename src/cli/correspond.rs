//! `puppet correspond --model M <a.png> <b.png> [--points pts.json]`: map points of frame a into
//! frame b through the fitted template (neural-puppet.md §4.3); with `--sequence`, score PCK on
//! a synthetic sequence's held-out pairs (Table 2 protocol) and write the keypoints for the
//! optical-flow peer (bench/flow_dis.py).

use std::path::PathBuf;

use anyhow::Context;
use puppet::edit::correspond::correspond;
use puppet::edit::load_frame::load_frame;
use puppet::edit::pck_pairs::{ordered_pairs, pck_pairs};
use puppet::edit::pin_overlay::pin_overlay;
use puppet::edit::pose::Pin;
use puppet::model::Model;
use puppet::picture::Picture;
use puppet::progress::Progress;
use puppet::train::refine::refined_fit;
use puppet::train::sequence::Frames;
use puppet::train::trainer::SplitRecord;

use super::fit::FitRefineArgs;
use super::Ui;

/// Map points of frame A to frame B through the fitted puppet (or score correspondences).
///
/// Two-frame mode writes OUTPUT (JSON: each point, its match or null when it is not on the
/// character, and the layer it lies on) and OUTPUT's stem + ".png" (A and B side by side with
/// each match drawn as a line in B from where the point was in A). Default points: a grid over
/// A's opaque pixels every --spacing pixels.
///
/// With --sequence DIR (a `puppet synth` folder): every ordered pair of the model's held-out
/// frames (split.json) is scored with PCK@{0.1, 0.05, 0.025}; OUTPUT gets the keypoints, truths
/// and our matches, the input of bench/flow_dis.py.
#[derive(Debug, clap::Args)]
pub struct CorrespondArgs {
    /// The model folder (written by `puppet train`).
    #[arg(long, value_name = "DIR")]
    pub model: PathBuf,
    /// Frames A and B (two-frame mode).
    #[arg(num_args = 0..=2)]
    pub frames: Vec<PathBuf>,
    /// JSON list of [x, y] points in A (frame pixels).
    #[arg(long, value_name = "FILE")]
    pub points: Option<PathBuf>,
    /// Grid spacing of the default points, pixels.
    #[arg(long, default_value_t = 8.0, value_name = "PX")]
    pub spacing: f32,
    /// A synthetic sequence with truth.json: score PCK on the held-out pairs instead.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["frames", "points"])]
    pub sequence: Option<PathBuf>,
    /// With --sequence: score pairs of the odd-numbered frames (held out by a model trained on
    /// the even frames, configs/edit-walk-23.toml) instead of split.json's test frames.
    #[arg(long, requires = "sequence")]
    pub odd: bool,
    /// Output JSON.
    #[arg(short, long, default_value = "correspondences.json")]
    pub output: PathBuf,
    #[command(flatten)]
    pub refine: FitRefineArgs,
}

/// One point's match, as written.
#[derive(serde::Serialize)]
struct Match {
    from: [f32; 2],
    to: Option<[f32; 2]>,
    layer: Option<String>,
}

/// Runs `puppet correspond`.
pub fn run(args: CorrespondArgs, ui: &Ui) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    if let Some(seq) = &args.sequence {
        return run_sequence(&args, seq, ui);
    }
    anyhow::ensure!(args.frames.len() == 2, "give two frames A and B (or --sequence DIR)");
    anyhow::ensure!(
        args.spacing.is_finite() && args.spacing >= 1.0,
        "--spacing {}: must be at least 1",
        args.spacing
    );
    let model = Model::load(&args.model, &device)?;
    let a = load_frame(&args.frames[0], &model)?;
    let b = load_frame(&args.frames[1], &model)?;
    let points: Vec<[f32; 2]> = match &args.points {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            let pts: Vec<[f32; 2]> =
                serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: not a JSON list of [x, y] points: {e}", path.display()))?;
            anyhow::ensure!(
                pts.iter().flatten().all(|c| c.is_finite()),
                "{}: a point is not finite",
                path.display()
            );
            pts
        }
        None => grid_points(&a, args.spacing),
    };
    let fits = refined_fit(&model, &[&a, &b], &args.refine.options(&args.model)?, &device)?;
    let matches = correspond(&model.puppet, &fits[0], &fits[1], &points)?;
    let rows: Vec<Match> = points
        .iter()
        .zip(&matches)
        .map(|(&p, m)| Match {
            from: p,
            to: m.map(|c| c.to),
            layer: m.map(|c| model.puppet.layers[c.binding.layer].name.clone()),
        })
        .collect();
    let json = serde_json::to_vec_pretty(&rows)?;
    puppet::atomic_file::write_atomic(&args.output, &json)?;
    let lines: Vec<Pin> = matches.iter().flatten().map(|c| Pin { from: c.from, to: c.to }).collect();
    let sheet = puppet::synth::output::contact_sheet(&[&a, &pin_overlay(&b, &lines)], 2);
    let png = args.output.with_extension("png");
    sheet.save_png(&png)?;
    let mapped = matches.iter().flatten().count();
    ui.say(format!(
        "{mapped} of {} points mapped ({} not on the character in {}) → {} and {}",
        points.len(),
        points.len() - mapped,
        args.frames[0].display(),
        args.output.display(),
        png.display()
    ));
    Ok(())
}

/// Points every `spacing` pixels where `frame` is mostly opaque.
fn grid_points(frame: &Picture, spacing: f32) -> Vec<[f32; 2]> {
    let mut out = Vec::new();
    let mut y = spacing / 2.0;
    while y < frame.height as f32 {
        let mut x = spacing / 2.0;
        while x < frame.width as f32 {
            if frame.get(x as u32, y as u32)[3] > 0.5 {
                out.push([x, y]);
            }
            x += spacing;
        }
        y += spacing;
    }
    out
}

fn run_sequence(args: &CorrespondArgs, seq: &std::path::Path, ui: &Ui) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let model = Model::load(&args.model, &device)?;
    let frames = Frames::load(seq)?;
    let truth = frames
        .truth
        .as_ref()
        .with_context(|| format!("{}: no truth.json (PCK needs a synthetic sequence)", seq.display()))?;
    let test: Vec<usize> = if args.odd {
        (1..frames.frames.len()).step_by(2).collect()
    } else {
        let split = SplitRecord::load(&args.model)?
            .with_context(|| format!("{}: no split.json (was it trained by `puppet train`?)", args.model.display()))?;
        split.test_indices(&frames.names()).with_context(|| {
            format!(
                "{}: the model's held-out frames are not all in {}",
                args.model.display(),
                seq.display()
            )
        })?
    };
    anyhow::ensure!(
        test.len() >= 2,
        "{}: fewer than two held-out frames, no pair to score",
        args.model.display()
    );
    for (file, f) in frames.files.iter().zip(&frames.frames) {
        model.check_frame(f).map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    }
    ui.stage("fit", test.len() as u64);
    let refine = args.refine.options(&args.model)?;
    let mut fits = vec![Vec::new(); frames.frames.len()];
    // Batches of 16, as training and `eval` run: one rasterizer and objective per batch.
    for chunk in test.chunks(16) {
        let pictures: Vec<_> = chunk.iter().map(|&t| &frames.frames[t]).collect();
        for (&t, fit) in chunk.iter().zip(refined_fit(&model, &pictures, &refine, &device)?) {
            fits[t] = fit;
        }
        ui.advance(chunk.len() as u64);
    }
    let pairs = ordered_pairs(&test);
    let sequence_dir = frames.dir.parent().unwrap_or(seq).to_path_buf();
    let scored = pck_pairs(truth, &sequence_dir, &frames.files, &fits, &model.puppet, &pairs)?;
    puppet::atomic_file::write_atomic(&args.output, &serde_json::to_vec(&scored)?)?;
    let table: Vec<String> = scored
        .alphas
        .iter()
        .zip(&scored.ours)
        .map(|(a, p)| format!("PCK@{a} {:.2}%", 100.0 * p))
        .collect();
    ui.say(format!(
        "{} held-out pairs, {} keypoints: {} → {}",
        pairs.len(),
        scored.pairs.iter().map(|p| p.points_a.len()).sum::<usize>(),
        table.join(", "),
        args.output.display()
    ));
    Ok(())
}
