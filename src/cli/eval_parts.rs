//! `puppet eval-parts`: part IoU of predicted label maps against true ones (issue 16 item 5).

use std::path::PathBuf;

use puppet::eval::parts::{score_label_maps, score_synthetic_sheet, OracleCleanup, SheetScores, Source};
use puppet::parts::learn::TrainedNet;
use puppet::parts::pose::Layout;
use puppet::parts::{PartsOptions, ESTIMATED_RIGID_CHECK};
use puppet::progress::Progress;

use super::args::parse_size;
use super::parts::{RebuildArg, SelectArg};
use super::Session;

/// Score predicted parts against true parts: both are label maps drawn one flat colour per part
/// (any colours; parts are matched, not named), either two sheets laid out alike (the truth's
/// poses are cut by its alpha or by --grid, and the prediction is read at the same places) or
/// two folders of per-pose label maps in the same order. Prints part IoU three ways: the
/// paper's (per pose, Hungarian matching on 1 − IoU, averaged over matched parts), strict (one
/// matching per sheet, unmatched true parts 0) and merged (each predicted part joined to the
/// true part it overlaps most: for truth coarser than the prediction), and the part counts.
///
/// With --synthetic FIRST..END instead: generates the sprite sheet of each seed (6 to 10 random
/// poses), finds its parts from the generator's exact correspondences (or, with --net, from
/// the correspondence network's, and scores those against the exact ones), and prints part IoU
/// beside two references on the same sheets — one part per connected region, and the
/// superpixel-majority ceiling — with the skeleton's joints against the generator's.
#[derive(Debug, clap::Args)]
pub struct EvalPartsArgs {
    /// The true label maps: a sheet or a folder.
    #[arg(long, value_name = "LABELS", required_unless_present = "synthetic", requires = "predicted")]
    pub truth: Option<PathBuf>,
    /// The predicted label maps (e.g. `puppet parts`' pose_labels.png): a sheet or a folder.
    pub predicted: Option<PathBuf>,
    /// Score the part finder on the synthetic sheets of these seeds, FIRST..END (END excluded).
    #[arg(long, value_name = "FIRST..END", value_parser = parse_seeds, conflicts_with_all = ["truth", "predicted", "grid"])]
    pub synthetic: Option<(u64, u64)>,
    /// With --synthetic: correspondences from the network trained in DIR (`--net` alone: the
    /// built-in one) instead of the exact ones.
    #[arg(long, value_name = "DIR", num_args = 0..=1, conflicts_with_all = ["truth", "predicted"])]
    pub net: Option<Option<PathBuf>>,
    /// With --net: drop correspondences whose way back misses the start by more than this many
    /// pixels (0: keep all).
    #[arg(long, default_value_t = 2.0, value_name = "PX")]
    pub flow_check: f32,
    /// With --net: mend the network's matches by the generator's truth after the checks, to
    /// measure what each kind of error costs (an oracle, for analysis): `hidden` drops matches
    /// of points the other pose hides, `far` also those more than 6 px off, `wrong` also those
    /// more than 2 px off, `corrected` replaces those by the truth instead.
    #[arg(long, value_enum, value_name = "KIND", requires = "net")]
    pub oracle_cleanup: Option<CleanupArg>,
    /// With --synthetic: the part finder's largest RMS motion residual of a merged part, as a
    /// fraction of the pose size (as `puppet parts --merge-residual`).
    #[arg(long, default_value_t = PartsOptions::default().segment.merge_residual, value_name = "FRACTION", conflicts_with_all = ["truth", "predicted"])]
    pub merge_residual: f32,
    /// With --synthetic: drop correspondences more than this many pixels from their
    /// superpixel's similarity (as `puppet parts --rigid-check`; default 4 with --net, else 0).
    #[arg(long, value_name = "PX", conflicts_with_all = ["truth", "predicted"])]
    pub rigid_check: Option<f32>,
    /// With --synthetic: how parts are chosen.
    #[arg(long, value_enum, default_value_t = SelectArg::Synchronised, conflicts_with_all = ["truth", "predicted"])]
    pub select: SelectArg,
    /// With --synthetic: how the poses are rebuilt from the parts found (the rebuilt L2).
    #[arg(long, value_enum, default_value_t = RebuildArg::Arap, conflicts_with_all = ["truth", "predicted"])]
    pub rebuild: RebuildArg,
    /// With --synthetic --select cover: how the poses are rebuilt to score each selection.
    #[arg(long, value_enum, default_value_t = RebuildArg::Rigid, conflicts_with_all = ["truth", "predicted"])]
    pub cover_score: RebuildArg,
    /// With --synthetic: characters of wider variety (`puppet synth --varied`: half bodies,
    /// robots, front views, held objects, some dressed; an accessory counts as the body part it
    /// is fixed to) instead of the one humanoid.
    #[arg(long, requires = "synthetic")]
    pub varied: bool,
    /// Pose size of the synthetic sheets (square).
    #[arg(long, default_value_t = 128, value_name = "PX", value_parser = clap::value_parser!(u32).range(64..=1024))]
    pub size: u32,
    /// Cut the truth sheet into a COLUMNSxROWS grid of equal cells instead of by its alpha.
    #[arg(long, value_name = "CxR", value_parser = parse_size)]
    pub grid: Option<(u32, u32)>,
}

/// `--oracle-cleanup`'s values ([`OracleCleanup`]).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum CleanupArg {
    /// Drop matches of points hidden in the other pose.
    Hidden,
    /// Also drop matches more than 6 px from the truth.
    Far,
    /// Also drop matches more than 2 px from the truth.
    Wrong,
    /// Replace matches more than 2 px from the truth by the truth; drop the hidden ones.
    Corrected,
}

impl From<CleanupArg> for OracleCleanup {
    fn from(arg: CleanupArg) -> Self {
        match arg {
            CleanupArg::Hidden => OracleCleanup::Hidden,
            CleanupArg::Far => OracleCleanup::Far,
            CleanupArg::Wrong => OracleCleanup::Wrong,
            CleanupArg::Corrected => OracleCleanup::Corrected,
        }
    }
}

fn parse_seeds(s: &str) -> Result<(u64, u64), String> {
    let bad = || format!("{s:?} is not a seed range FIRST..END with FIRST < END (e.g. 9000..9024)");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b) = (
        a.trim().parse::<u64>().map_err(|_| bad())?,
        b.trim().parse::<u64>().map_err(|_| bad())?,
    );
    if a < b && b - a <= 10_000 {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

/// Runs `puppet eval-parts`.
pub fn run(args: EvalPartsArgs, s: &Session) -> anyhow::Result<()> {
    if let Some((first, end)) = args.synthetic {
        let device = puppet::backend::device();
        let trained = match &args.net {
            Some(Some(dir)) => Some(TrainedNet::load(dir, &device)?),
            Some(None) => Some(TrainedNet::shipped(&device)?),
            None => None,
        };
        let source = match &trained {
            Some(net) => Source::Network {
                net,
                check: args.flow_check,
                cleanup: args.oracle_cleanup.map(OracleCleanup::from),
            },
            None => Source::Truth,
        };
        let mut options = PartsOptions::default();
        options.segment.merge_residual = args.merge_residual;
        options.select = args.select.selection(args.cover_score);
        options.rebuild = args.rebuild.rebuild();
        options.rigid_check = args
            .rigid_check
            .unwrap_or(if trained.is_some() { ESTIMATED_RIGID_CHECK } else { 0.0 });
        return synthetic(first, end, args.size, args.varied, &options, source, s);
    }
    let (Some(truth_path), Some(predicted_path)) = (&args.truth, &args.predicted) else {
        anyhow::bail!("give --truth LABELS and the predicted label maps, or --synthetic FIRST..END");
    };
    let layout = args.grid.map(|(columns, rows)| Layout::Grid { columns, rows });
    let (names, scores) = score_label_maps(truth_path, predicted_path, layout)?;
    let mut table = format!("{:<24} {:>7}\n", "pose", "IoU");
    for (name, iou) in names.iter().zip(&scores.per_pose) {
        table += &format!("{:<24} {:>7.3}\n", name, iou);
    }
    table += &format!(
        "part IoU: paper {:.3}, strict {:.3}, merged {:.3}; parts {} predicted, {} true ({:+})",
        scores.paper,
        scores.strict,
        scores.merged,
        scores.predicted_parts,
        scores.true_parts,
        scores.predicted_parts as i64 - scores.true_parts as i64
    );
    s.ui.print(table)?;
    Ok(())
}

/// The synthetic evaluation: one row per seed, then the means.
fn synthetic(first: u64, end: u64, size: u32, varied: bool, options: &PartsOptions, source: Source, s: &Session) -> anyhow::Result<()> {
    s.ui.stage("sheets", end - first);
    let mut rows = Vec::new();
    for seed in first..end {
        // 6 to 10 poses, the range of the paper's sheets.
        let poses = 6 + (seed % 5) as usize;
        rows.push((poses, score_synthetic_sheet(seed, poses, size, varied, options, source)?));
        s.ui.advance(1);
    }
    s.ui.finish();
    let mut table = format!(
        "{:>6} {:>5} {:>11} {:>7} {:>7} {:>7} {:>13} {:>13} {:>8} {:>9} {:>7} {:>6}\n",
        "seed", "poses", "parts f/t", "paper", "strict", "merged", "regions p/s", "ceiling p/s", "hinged", "pivot px", "order", "s"
    );
    let estimated = matches!(source, Source::Network { .. });
    for (poses, r) in &rows {
        table += &format!(
            "{:>6} {:>5} {:>11} {:>7.3} {:>7.3} {:>7.3} {:>13} {:>13} {:>8} {:>9} {:>7} {:>6.2}\n",
            r.seed,
            poses,
            format!("{}/{}", r.found.predicted_parts, r.found.true_parts),
            r.found.paper,
            r.found.strict,
            r.found.merged,
            format!("{:.3}/{:.3}", r.components.paper, r.components.strict),
            format!("{:.3}/{:.3}", r.ceiling.paper, r.ceiling.strict),
            format!("{}/{}", r.joints_hinged, r.joints),
            r.pivot_error.map_or("-".into(), |e| format!("{e:.2}")),
            format!("{}/{}", r.joints_ordered, r.joints_matched),
            r.seconds
        );
    }
    let n = rows.len() as f64;
    let mean = |f: &dyn Fn(&SheetScores) -> f64| rows.iter().map(|(_, r)| f(r)).sum::<f64>() / n;
    let sum = |f: &dyn Fn(&SheetScores) -> usize| rows.iter().map(|(_, r)| f(r)).sum::<usize>();
    let mut pivots: Vec<f32> = rows.iter().filter_map(|(_, r)| r.pivot_error).collect();
    pivots.sort_by(f32::total_cmp);
    table += &format!(
        "mean over {} sheets at {size}²: part IoU paper {:.3}, strict {:.3}, merged {:.3}; one part per region {:.3}/{:.3}; \
         superpixel ceiling {:.3}/{:.3}; |part count error| {:.2}; joints hinged {}/{}, median pivot error {:.2} px, \
         joints stacked right {}/{}; poses rebuilt from the parts L2 {:.0} (the reference pose unchanged {:.0}); \
         {:.2} s per sheet{}",
        rows.len(),
        mean(&|r| r.found.paper),
        mean(&|r| r.found.strict),
        mean(&|r| r.found.merged),
        mean(&|r| r.components.paper),
        mean(&|r| r.components.strict),
        mean(&|r| r.ceiling.paper),
        mean(&|r| r.ceiling.strict),
        mean(&|r| (r.found.predicted_parts as f64 - r.found.true_parts as f64).abs()),
        sum(&|r| r.joints_hinged),
        sum(&|r| r.joints),
        pivots.get(pivots.len() / 2).copied().unwrap_or(f32::NAN),
        sum(&|r| r.joints_ordered),
        sum(&|r| r.joints_matched),
        mean(&|r| r.reconstruction_l2),
        mean(&|r| r.unchanged_l2),
        mean(&|r| r.seconds),
        if estimated {
            format!(
                "; correspondences: {:.1} % of the visible ones given, {:.1} % of those within 2 px of the truth",
                100.0 * mean(&|r| r.matching.coverage),
                100.0 * mean(&|r| r.matching.within_2px)
            )
        } else {
            String::new()
        }
    );
    s.ui.print(table)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_the_truth_and_prediction() {
        parses(&["eval-parts", "--truth", "sheet_labels.png", "out/pose_labels.png", "--grid", "4x2"]);
        parses(&["eval-parts", "--synthetic", "9000..9024", "--size", "256"]);
        parses(&["eval-parts", "--synthetic", "9000..9024", "--net"]);
        parses(&["eval-parts", "--synthetic", "9000..9024", "--varied"]);
        parses(&["eval-parts", "--synthetic", "9000..9024", "--net", "--select", "cover"]);
        parses(&["eval-parts", "--synthetic", "9000..9024", "--net", "runs/net", "--flow-check", "0"]);
        for bad in [
            &["eval-parts", "--truth", "a", "b", "--net", "n"][..],
            &["eval-parts", "--synthetic", "9..3"],
            &["eval-parts", "--synthetic", "1..5", "--truth", "x", "y"],
            &["eval-parts"],
        ] {
            assert!(
                <crate::cli::Cli as clap::Parser>::try_parse_from(std::iter::once("puppet").chain(bad.iter().copied())).is_err(),
                "{bad:?}"
            );
        }
    }
}
