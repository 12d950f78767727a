//! `puppet correspond --model M <a.png> <b.png> -o out.json`: map points of frame a into frame b
//! through the fitted template (neural-puppet.md §4.3); with `--sequence`, score PCK on a
//! synthetic sequence's held-out pairs (Table 2 protocol) and write the keypoints for the
//! optical-flow peer (bench/flow_dis.py).

use std::path::{Path, PathBuf};

use puppet::edit::correspond::{correspond, grid_points, load_points};
use puppet::edit::pin::Pin;
use puppet::edit::pin_overlay::pin_overlay;
use puppet::eval::pck_pairs::{score_sequence, HeldOut};
use puppet::fit::frame::load_frame;
use puppet::model::Model;
use puppet::picture::contact_sheet;
use puppet::progress::Progress;

use super::args::{positive_f32, FitArgs, FitSourceArgs};
use super::Session;

/// Map points of frame A to frame B through the fitted puppet (or score correspondences).
///
/// Two-frame mode writes OUTPUT (JSON: each point, its match or null when it is not on the
/// character, and the layer it lies on) and OUTPUT's stem + "_pairs.png" (A and B side by side
/// with each match drawn as a line in B from where the point was in A). Default points: a grid
/// over A's opaque pixels every --spacing pixels. With --puppet instead of --model, the frames
/// are of a character nobody trained, fitted from the prior's placement.
///
/// With --sequence DIR (a `puppet synth` folder): every ordered pair of the model's held-out
/// frames (split.json) is scored with PCK@{0.1, 0.05, 0.025}; OUTPUT gets the keypoints, truths
/// and our matches, the input of bench/flow_dis.py.
#[derive(Debug, clap::Args)]
pub struct CorrespondArgs {
    #[command(flatten)]
    pub source: FitSourceArgs,
    /// Frames A and B (two-frame mode).
    #[arg(num_args = 0..=2)]
    pub frames: Vec<PathBuf>,
    /// JSON list of [x, y] points in A (frame pixels).
    #[arg(long, value_name = "FILE")]
    pub points: Option<PathBuf>,
    /// Grid spacing of the default points, pixels.
    #[arg(long, default_value_t = 8.0, value_name = "PX", value_parser = positive_f32)]
    pub spacing: f32,
    /// A synthetic sequence with truth.json: score PCK on the held-out pairs instead.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["frames", "points"])]
    pub sequence: Option<PathBuf>,
    /// With --sequence: score pairs of the odd-numbered frames (held out by a model trained on
    /// the even frames, configs/edit-walk-23.toml) instead of split.json's test frames.
    #[arg(long, conflicts_with_all = ["frames", "points"])]
    pub odd: bool,
    /// Output JSON.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    #[command(flatten)]
    pub fit: FitArgs,
}

#[derive(serde::Serialize)]
struct Match {
    from: [f32; 2],
    to: Option<[f32; 2]>,
    layer: Option<String>,
}

/// `output` with its extension replaced by `_pairs.png`: never the JSON's own name.
fn picture_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map_or_else(|| "correspondences".into(), |s| s.to_string_lossy().into_owned());
    output.with_file_name(format!("{stem}_pairs.png"))
}

/// Runs `puppet correspond`.
pub fn run(args: CorrespondArgs, s: &Session) -> anyhow::Result<()> {
    s.outputs.claim(&args.output)?;
    if let Some(seq) = &args.sequence {
        return run_sequence(&args, seq, s);
    }
    anyhow::ensure!(args.frames.len() == 2, "give two frames A and B (or --sequence DIR)");
    let png = picture_path(&args.output);
    s.outputs.claim(&png)?;
    let device = puppet::backend::device();
    let source = args.source.load(&device, &s.ui)?;
    let model = &source.model;
    let a = load_frame(&args.frames[0], model)?;
    let b = load_frame(&args.frames[1], model)?;
    let points = match &args.points {
        Some(path) => load_points(path)?,
        None => grid_points(&a, args.spacing),
    };
    s.ui.stage("fit", 2);
    let options = args.fit.options(source.dir.as_deref(), model, &device, &s.ui)?;
    let fits = source.fit(&[&a, &b], &options, &device, &s.ui)?.poses;
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
    s.outputs.write(&args.output, &serde_json::to_vec_pretty(&rows)?)?;
    let lines: Vec<Pin> = matches.iter().flatten().map(|c| Pin { from: c.from, to: c.to }).collect();
    s.save_png(&png, &contact_sheet(&[&a, &pin_overlay(&b, &lines)], 2))?;
    s.ui.finish();
    let mapped = matches.iter().flatten().count();
    s.ui.say(format!(
        "{mapped} of {} points mapped ({} not on the character in {}) → {} and {}",
        points.len(),
        points.len() - mapped,
        args.frames[0].display(),
        args.output.display(),
        png.display()
    ))
}

fn run_sequence(args: &CorrespondArgs, seq: &Path, s: &Session) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let dir = args
        .source
        .model
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("--sequence scores a trained model's held-out pairs: give --model"))?;
    let model = Model::load(dir, &device)?;
    let held_out = if args.odd { HeldOut::Odd } else { HeldOut::Split };
    let options = args.fit.options(Some(dir), &model, &device, &s.ui)?;
    let (scored, pairs) = score_sequence(dir, &model, seq, held_out, &options, &device, &s.ui)?;
    s.outputs.write(&args.output, &serde_json::to_vec(&scored)?)?;
    s.ui.finish();
    let table: Vec<String> = scored
        .alphas
        .iter()
        .zip(&scored.ours)
        .map(|(a, p)| format!("PCK@{a} {:.2}%", 100.0 * p))
        .collect();
    s.ui.print(format!(
        "{} held-out pairs, {} keypoints: {} → {}",
        pairs.len(),
        scored.pairs.iter().map(|p| p.points_a.len()).sum::<usize>(),
        table.join(", "),
        args.output.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::picture_path;
    use crate::cli::tests::parses;

    #[test]
    fn parses_both_modes_and_never_names_the_picture_as_the_json() {
        parses(&["correspond", "--model", "m", "a.png", "b.png", "-o", "c.json", "--spacing", "4"]);
        parses(&["correspond", "--model", "m", "--sequence", "seq", "--odd", "-o", "c.json"]);
        parses(&["correspond", "--puppet", "p", "a.png", "b.png", "-o", "c.json"]);
        assert!(
            clap::Parser::try_parse_from(["puppet", "correspond", "--model", "m", "a.png", "b.png"])
                .map(|_: crate::cli::Cli| ())
                .is_err(),
            "the output is required"
        );
        assert!(
            clap::Parser::try_parse_from(["puppet", "correspond", "--model", "m", "a.png", "b.png", "-o", "c.json", "--odd"])
                .map(|_: crate::cli::Cli| ())
                .is_err(),
            "--odd belongs to --sequence"
        );
        assert_eq!(picture_path(std::path::Path::new("x.png")), std::path::Path::new("x_pairs.png"));
    }
}
