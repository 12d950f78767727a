//! `puppet suggest --model M [-n 3] -o DIR`: the poses worth drawing next (issue 57;
//! `edit::suggest`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;

use puppet::edit::suggest::{suggest, trace_picture, Candidate, Criterion, Ranking, SuggestOptions};
use puppet::fit::frame::training_frames;
use puppet::model::Model;
use puppet::picture::{contact_sheet, Picture};
use puppet::puppet::pose_file::{load_poses, PoseFile};
use puppet::synth::truth::{true_positions, Truth};

use super::args::ModelArgs;
use super::Session;

/// Suggest the poses whose drawings would teach the model most: poses near those drawn (limbs
/// turned a little past the drawn ranges, in-betweens of drawn frames, steps along the ways the
/// drawn frames differ), ranked by how badly the network reads its own renders of the poses
/// around each, beyond what the drawn frames teach already (or, with --by misread, of the pose
/// alone; with --by typical, by how many poses around it the drawn frames do not teach yet,
/// however well read; with --by distance, by how far each is from every drawn pose), n different ones kept,
/// none next to a drawn pose.
///
/// Writes into OUTPUT, best first: next_N.png (the rest art moved into the pose under its faint
/// mesh: trace over it), next_N.json (the pose), sheet.png (all of them) and suggestions.json
/// (every pick's scores and origin). Draw one, put it beside the training frames (a copy of
/// the folder) and continue the model: `puppet train --from MODEL --frames DIR -o NEW`.
#[derive(Debug, clap::Args)]
pub struct SuggestArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output folder (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Suggestions wanted.
    #[arg(short = 'n', long, default_value_t = 3, value_name = "N")]
    pub count: usize,
    /// Rank these poses instead of the ones suggest makes: a pose file or a folder of them
    /// (frames the artist could draw), or a `puppet synth` sequence (its true poses).
    #[arg(long, value_name = "PATH")]
    pub pool: Option<PathBuf>,
    /// The drawn frames (default: the model's training frames, as its split.json names them).
    #[arg(long, value_name = "DIR")]
    pub frames: Option<PathBuf>,
    /// What ranks a pose.
    #[arg(long, default_value = "coverage", value_name = "CRITERION")]
    pub by: ByArg,
    /// Candidates made by turning limbs of drawn poses.
    #[arg(long, default_value_t = SuggestOptions::default().turned, value_name = "N")]
    pub turned: usize,
    /// Degrees the drawn turn ranges are widened by on each side.
    #[arg(long, default_value_t = SuggestOptions::default().margin_degrees, value_name = "DEGREES")]
    pub margin: f32,
    /// The least root-mean-square limb-turn difference between two suggestions, degrees.
    #[arg(long, default_value_t = SuggestOptions::default().separation_degrees, value_name = "DEGREES")]
    pub separation: f32,
    /// Seeds the turned candidates.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// `--by`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ByArg {
    /// How badly the network reads its own render of the pose.
    Misread,
    /// How far the pose's limb turns are from the nearest drawn pose's (farthest first).
    Distance,
    /// How badly the network reads the candidates around the pose, nearer ones counting more,
    /// beyond what the drawn poses teach already.
    Coverage,
    /// How many poses around the pose, nearer ones counting more, the drawn poses do not teach
    /// yet, however well the network reads them: the most typical pose still to draw.
    Typical,
}

/// Runs `puppet suggest`.
pub fn run(args: SuggestArgs, s: &Session) -> anyhow::Result<()> {
    let started = Instant::now();
    let device = puppet::backend::device();
    let model_dir = &args.model.model;
    let model = Model::load(model_dir, &device)?;
    let options = SuggestOptions {
        count: args.count,
        turned: args.turned,
        margin_degrees: args.margin,
        separation_degrees: args.separation,
        criterion: match args.by {
            ByArg::Misread => Criterion::Misread,
            ByArg::Distance => Criterion::Distance,
            ByArg::Coverage => Criterion::Coverage,
            ByArg::Typical => Criterion::Typical,
        },
        seed: args.seed,
    };
    options.validate()?;
    let frames: Vec<Picture> = match &args.frames {
        Some(dir) => puppet::puppet::sequence::Frames::load(dir, &puppet::fit::frame::frame_check(&model))?.frames,
        None => training_frames(model_dir, &model, "suggest needs them", &s.ui)?.ok_or_else(|| {
            anyhow::anyhow!(
                "{}: the model's training frames cannot be read (see the warning above); give them with --frames",
                model_dir.display()
            )
        })?,
    };
    let pool = args
        .pool
        .as_deref()
        .map(|path| pool_poses(path, &model.puppet, s).with_context(|| format!("--pool {}", path.display())))
        .transpose()?;
    let ranking = suggest(&model, &frames.iter().collect::<Vec<_>>(), pool, &options, &device)?;
    let seconds = started.elapsed().as_secs_f64();
    if ranking.picked.is_empty() {
        anyhow::bail!("{} (try a smaller --separation)", ranking.why_none(options.separation_degrees));
    }
    let Ranking {
        candidates,
        picked,
        margin_degrees,
    } = ranking;

    // Everything is known to work: only now is the output folder made.
    let out = &args.output;
    s.outputs.lock_folder(out)?;
    let puppet = &model.puppet;
    let mut traces = Vec::new();
    let mut listed = Vec::new();
    for (rank, &i) in picked.iter().enumerate() {
        let c = &candidates[i];
        let stem = format!("next_{}", rank + 1);
        let trace = trace_picture(puppet, &c.pose)?;
        s.save_png(&out.join(format!("{stem}.png")), &trace)?;
        s.outputs
            .write(&out.join(format!("{stem}.json")), &PoseFile { vertices: c.pose.clone() }.to_json())?;
        traces.push(trace);
        listed.push(listing(&stem, c));
    }
    s.save_png(
        &out.join("sheet.png"),
        &contact_sheet(&traces.iter().collect::<Vec<_>>(), traces.len()),
    )?;
    let record = serde_json::json!({
        "model": model_dir,
        "criterion": options.criterion,
        "candidates": candidates.len(),
        "margin_degrees": margin_degrees,
        "drawn_frames": frames.len(),
        "suggestions": listed,
    });
    s.outputs
        .write(&out.join("suggestions.json"), &serde_json::to_vec_pretty(&record)?)?;
    s.ui.finish();
    for (rank, &i) in picked.iter().enumerate() {
        let c = &candidates[i];
        s.ui.print(format!(
            "next_{}: misread {:.2} px, coverage {:.1} px, {:.1}° from the nearest drawn pose ({})",
            rank + 1,
            c.misread,
            c.coverage,
            c.distance,
            c.origin
        ))?;
    }
    if let Some(m) = margin_degrees.filter(|&m| m != options.margin_degrees) {
        s.ui.say(format!(
            "the drawn frames read alike, so their turn ranges were widened by {m}° (--margin {}) to find poses apart from them",
            options.margin_degrees
        ))?;
    }
    s.ui.say(format!(
        "{} of {} candidates suggested in {seconds:.2} s → {} (next_N.png + .json, sheet.png, suggestions.json)",
        picked.len(),
        candidates.len(),
        out.display()
    ))
}

/// The poses of `--pool PATH`: pose files, or a `puppet synth` sequence's true poses (its
/// frames as the generator drew them, an artist who draws any pose exactly).
fn pool_poses(path: &Path, puppet: &puppet::Puppet, s: &Session) -> anyhow::Result<Vec<Vec<[f32; 2]>>> {
    Ok(match Truth::for_sequence(path)? {
        Some(truth) => (0..truth.frames.len())
            .map(|f| true_positions(&truth, f, puppet))
            .collect::<puppet::Result<_>>()?,
        None => load_poses(path, puppet, &s.ui)?,
    })
}

/// One suggestion in suggestions.json.
fn listing(stem: &str, c: &Candidate) -> serde_json::Value {
    serde_json::json!({
        "pose": format!("{stem}.json"),
        "picture": format!("{stem}.png"),
        "misread_px": c.misread,
        "coverage_px": c.coverage,
        "typical": c.typical,
        "distance_degrees": c.distance,
        "origin": c.origin,
    })
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_counts_pools_and_criteria() {
        parses(&["suggest", "--model", "m", "-o", "next"]);
        parses(&[
            "suggest", "--model", "m", "-o", "next", "-n", "5", "--by", "distance", "--pool", "poses",
        ]);
        parses(&[
            "suggest", "--model", "m", "-o", "next", "--frames", "f", "--turned", "10", "--seed", "3",
        ]);
        parses(&["suggest", "--model", "m", "-o", "next", "--by", "typical"]);
        for bad in [
            vec!["suggest", "--model", "m"],
            vec!["suggest", "--model", "m", "-o", "x", "--by", "luck"],
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
