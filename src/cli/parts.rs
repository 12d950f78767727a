//! `puppet parts`: articulated parts from a sprite sheet of poses (APES, issue 16), written as
//! artwork `puppet build` reads.

use std::path::PathBuf;

use anyhow::Context;
use puppet::atomic_file::record;
use puppet::parts::artwork::write_artwork;
use puppet::parts::cover::CoverOptions;
use puppet::parts::deform::{BendOptions, Rebuild};
use puppet::parts::flow::read_flows;
use puppet::parts::learn::TrainedNet;
use puppet::parts::matching::network_correspondences;
use puppet::parts::pose::{check_one_character, load_poses, Layout};
use puppet::parts::{find_parts, set_aside_strangers, PartsOptions, Selection, ESTIMATED_RIGID_CHECK};
use puppet::synth::sheet_flow::TruthSheet;

use super::args::parse_size;

use super::Session;

/// Find a character's articulated parts from a sprite sheet of its poses, and write them as a
/// label map + reference frame + character.toml (root, joints, back-to-front layers) that
/// `puppet build` accepts, with parts.png (the poses, their parts, and the poses rebuilt from
/// the parts) and the label map of every pose (pose_labels.png laid out like the sheet, for
/// `puppet eval-parts`).
///
/// Parts are superpixels of the reference pose merged while one similarity per pose explains
/// their motion in every pose; every pixel of every pose then takes the part whose motion
/// explains its correspondences best. Correspondences come from the correspondence network
/// (the one built in, trained on the generator's characters by `puppet train-parts`, or
/// --net DIR), from optical flow between every pair of poses (--flows: Middlebury .flo files,
/// e.g. from bench/parts_flow.py; --cut-only writes the poses to compute them on) or from a
/// synthetic sheet's truth (--truth).
#[derive(Debug, clap::Args)]
pub struct PartsArgs {
    /// The poses: a sprite sheet (PNG), a folder of pose PNGs, or with --truth a folder written
    /// by `puppet synth --sprite-sheet`.
    pub input: PathBuf,
    /// Output folder (created if missing; a folder puppet did not make is refused unless --force).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Use the exact correspondences of a synthetic sheet (its truth.json): the oracle that
    /// measures the part finder apart from correspondence errors.
    #[arg(long, conflicts_with_all = ["flows", "cut_only", "grid"])]
    pub truth: bool,
    /// Optical flow between every ordered pair of poses: DIR/flow_SSS_TTT.flo from pose SSS to
    /// pose TTT (numbered from 0 in reading order); a landing off the character moves to its
    /// nearest pixel.
    #[arg(long, value_name = "DIR", conflicts_with = "cut_only")]
    pub flows: Option<PathBuf>,
    /// The correspondence network trained in DIR by `puppet train-parts` (default: the one
    /// built in).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["flows", "cut_only", "truth"])]
    pub net: Option<PathBuf>,
    /// Drop correspondences (from flow or the network) whose way back misses the start by more
    /// than this many pixels (0: keep all).
    #[arg(long, default_value_t = 2.0, value_name = "PX")]
    pub flow_check: f32,
    /// Drop correspondences more than this many pixels from the similarity that best moves
    /// their superpixel (stray matches; default 4 for the network and flow, 0 with --truth).
    #[arg(long, value_name = "PX")]
    pub rigid_check: Option<f32>,
    /// Only cut the sheet: write OUTPUT/poses/pose_NNN.png (to compute flows on) and stop.
    #[arg(long)]
    pub cut_only: bool,
    /// Keep every pose: by default a pose whose correspondences mostly fail to come back from
    /// the others (a back view, a turn) is set aside with a warning naming it.
    #[arg(long)]
    pub keep_all: bool,
    /// Cut the sheet into a COLUMNSxROWS grid of equal cells instead of by its alpha.
    #[arg(long, value_name = "CxR", value_parser = parse_size)]
    pub grid: Option<(u32, u32)>,
    /// Merge until this many parts are left (default: merge while the motion residual allows).
    #[arg(long, value_name = "N")]
    pub parts: Option<usize>,
    /// Superpixels per pose.
    #[arg(long, default_value_t = PartsOptions::default().superpixels, value_name = "N")]
    pub superpixels: usize,
    /// Largest RMS motion residual of a merged part, as a fraction of the pose size.
    #[arg(long, default_value_t = PartsOptions::default().segment.merge_residual, value_name = "FRACTION")]
    pub merge_residual: f32,
    /// The reference pose, counted from 0 (default: the pose with the most foreground).
    #[arg(long, value_name = "K")]
    pub reference: Option<usize>,
    /// How parts are chosen.
    #[arg(long, value_enum, default_value_t = SelectArg::Synchronised)]
    pub select: SelectArg,
    /// How the poses are rebuilt from the parts found (parts.png's bottom row).
    #[arg(long, value_enum, default_value_t = RebuildArg::Arap)]
    pub rebuild: RebuildArg,
    /// With --select cover: how the poses are rebuilt to score each selection.
    #[arg(long, value_enum, default_value_t = RebuildArg::Rigid)]
    pub cover_score: RebuildArg,
    /// The character's name in character.toml (default: the input's file name).
    #[arg(long)]
    pub name: Option<String>,
}

impl PartsArgs {
    fn options(&self) -> PartsOptions {
        let mut options = PartsOptions {
            superpixels: self.superpixels,
            ..PartsOptions::default()
        };
        options.segment.parts = self.parts;
        options.segment.merge_residual = self.merge_residual;
        options.segment.reference = self.reference;
        options.rigid_check = self.rigid_check.unwrap_or(if self.truth { 0.0 } else { ESTIMATED_RIGID_CHECK });
        options.select = self.select.selection(self.cover_score);
        options.rebuild = self.rebuild.rebuild();
        options
    }
}

/// How `--select` chooses parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SelectArg {
    /// Superpixels of the reference pose merged while they move together in every pose.
    Synchronised,
    /// The paper's set cover: candidates from every pair of poses, the fewest covering every
    /// superpixel of every pose (LP relaxation, randomised rounding), the rounding whose parts
    /// rebuild the poses best.
    Cover,
}

impl SelectArg {
    /// The part finder's setting, a set cover scoring its selections as `score` says.
    pub fn selection(self, score: RebuildArg) -> Selection {
        match self {
            SelectArg::Synchronised => Selection::Synchronised,
            SelectArg::Cover => Selection::Cover(CoverOptions {
                score: score.rebuild(),
                ..CoverOptions::default()
            }),
        }
    }
}

/// How `--rebuild` rebuilds the poses from the parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RebuildArg {
    /// Each part's control mesh bent as rigidly as possible towards its correspondences (the
    /// paper's).
    Arap,
    /// Each part moved by its similarity.
    Rigid,
}

impl RebuildArg {
    /// The part finder's setting.
    pub fn rebuild(self) -> Rebuild {
        match self {
            RebuildArg::Arap => Rebuild::Arap(BendOptions::default()),
            RebuildArg::Rigid => Rebuild::Rigid,
        }
    }
}

/// The round trip within which a correspondence counts as consistent when poses are weighed
/// for setting aside (pixels; the default `--flow-check`).
const SET_ASIDE_CHECK: f32 = 2.0;

/// Runs `puppet parts`.
pub fn run(args: PartsArgs, s: &Session) -> anyhow::Result<()> {
    let options = args.options();
    let (poses, flows, sheet_size) = if args.truth {
        let sheet = TruthSheet::load(&args.input)?;
        check_one_character(&sheet.poses, &args.input)?;
        let flows = sheet.correspondences()?;
        (sheet.poses, flows, Some(sheet.sheet_size))
    } else {
        let layout = args.grid.map(|(columns, rows)| Layout::Grid { columns, rows });
        let (poses, sheet_size) = load_poses(&args.input, layout)?;
        check_one_character(&poses, &args.input)?;
        if args.cut_only {
            return cut_only(&poses, &args.output, s);
        }
        let flows = match &args.flows {
            Some(dir) => read_flows(dir, &poses)?,
            None => {
                let device = puppet::backend::device();
                let trained = match &args.net {
                    Some(dir) => TrainedNet::load(dir, &device)?,
                    None => TrainedNet::shipped(&device)?,
                };
                network_correspondences(&trained.net, trained.size, &poses, &device, &s.ui)?
            }
        };
        let (poses, mut flows) = if args.keep_all {
            (poses, flows)
        } else {
            let (poses, flows, _) = set_aside_strangers(poses, flows, SET_ASIDE_CHECK, &s.ui);
            (poses, flows)
        };
        if args.flow_check > 0.0 {
            let kept = flows.keep_consistent(poses[0].width(), args.flow_check);
            s.ui.say(format!("forward–backward check: {:.1} % of the correspondences kept", 100.0 * kept))?;
        }
        (poses, flows, sheet_size)
    };
    let name = args.name.clone().unwrap_or_else(|| {
        args.input
            .file_name()
            .map_or_else(|| "character".into(), |n| n.to_string_lossy().into_owned())
    });
    let started = std::time::Instant::now();
    let parts = find_parts(poses, &flows, &options).context("while finding parts")?;
    let seconds = started.elapsed().as_secs_f64();
    // Claimed only now: a run that fails before this point leaves no folder behind.
    s.outputs.claim_folder(&args.output)?;
    let written = write_artwork(&parts, &args.output, &name, sheet_size, &s.outputs)
        .with_context(|| format!("while writing {}", args.output.display()))?;
    record(&std::path::absolute(&args.output)?)?;
    s.ui.say(format!(
        "{} parts from {} poses in {seconds:.2} s (reference pose {}, {} hinges): {} (build it with `puppet build {}`), {}, {}",
        parts.segmentation.parts,
        parts.poses.len(),
        parts.segmentation.reference,
        parts.skeleton.hinges.len(),
        written.character.display(),
        args.output.display(),
        written.preview.display(),
        written.pose_labels.display()
    ))?;
    let (rebuilt, unchanged) = parts.rebuild_l2();
    s.ui.say(format!(
        "the poses rebuilt from the parts ({}): mean L2 {rebuilt:.0} against the poses (the reference pose unchanged: {unchanged:.0})",
        if parts.meshes.is_some() { "bent by ARAP" } else { "moved rigidly" }
    ))?;
    if let Some(c) = &parts.cover {
        s.ui.say(format!(
            "set cover: {} candidates from every pair of poses; {} of {} superpixels covered; LP bound {:.2}; {} distinct roundings scored, the best keeps {} candidates",
            c.candidates,
            c.superpixels - c.uncovered,
            c.superpixels,
            c.lp_bound,
            c.selections,
            c.selected
        ))?;
    }
    Ok(())
}

/// Writes the poses as `dir/poses/pose_NNN.png`.
fn cut_only(poses: &[puppet::parts::pose::SheetPose], dir: &std::path::Path, s: &Session) -> anyhow::Result<()> {
    let folder = dir.join("poses");
    let paths: Vec<_> = (0..poses.len()).map(|k| folder.join(format!("pose_{k:03}.png"))).collect();
    // Every file claimed before the first is written: a refusal changes nothing.
    for path in &paths {
        s.outputs.claim(path)?;
    }
    for (pose, path) in poses.iter().zip(&paths) {
        s.save_png(path, &pose.image)?;
    }
    s.ui.say(format!("{} poses → {}", poses.len(), folder.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_the_input_and_options() {
        parses(&[
            "parts",
            "sheet",
            "-o",
            "out",
            "--truth",
            "--parts",
            "10",
            "--superpixels",
            "150",
            "--merge-residual",
            "0.02",
            "--reference",
            "2",
        ]);
        parses(&["parts", "sheet.png", "-o", "out", "--grid", "4x3", "--flows", "f"]);
        parses(&["parts", "sheet.png", "-o", "out", "--cut-only"]);
        parses(&["parts", "sheet.png", "-o", "out", "--net", "runs/net", "--flow-check", "1"]);
        parses(&[
            "parts",
            "poses",
            "-o",
            "out",
            "--select",
            "cover",
            "--rebuild",
            "rigid",
            "--cover-score",
            "arap",
        ]);
        parses(&["parts", "poses", "-o", "out"]);
        parses(&["parts", "poses", "-o", "out", "--select", "cover"]);
        assert!(
            <crate::cli::Cli as clap::Parser>::try_parse_from(["puppet", "parts", "s", "-o", "o", "--net", "n", "--flows", "f"]).is_err()
        );
    }
}
