//! `puppet eval-rig <set-dir>`: accessory rigs scored on a set of layered characters under a
//! suite of body edits, beside two baselines (see [`puppet::eval::rig`]).

use std::path::PathBuf;

use puppet::eval::rig::{
    default_edits, edit_sheet, evaluate_character, evaluate_motion, motion_sheet, set_members, EditsFile, RigReport, RigTruth, TRUTH_FILE,
};
use puppet::progress::Progress;
use puppet::puppet::{artwork, build};
use puppet::rig::{build_rigged, RigOptions};
use puppet::synth::Truth;

use super::Session;

/// Score accessory rigs on a set of characters: each subfolder is a character in the PNG-layer
/// form (character.toml), with an optional rig_truth.json ({"attach_to": {"layer": "parent"}}).
/// Each is built, rigged and put through a suite of body edits (the head widened 10 % and 20 %,
/// tilted ±12°, the body squashed to 0.8, the body widened 15 %, five ARAP drags); the rig is
/// scored against accessories left unchanged and accessories stuck to the body under them.
/// A subfolder may also be a synthetic sequence of `puppet synth --accessories` (template/ and
/// truth.json): its rig is then also scored along the sequence's true body motion, against the
/// accessories' true places (vertex error and coverage IoU).
/// Characters that cannot be built are named and the rest scored; the command then exits 1.
#[derive(Debug, clap::Args)]
pub struct EvalRigArgs {
    /// The set: a folder of character folders.
    pub set: PathBuf,
    /// Edits to use instead of the suite: a TOML file of [[edit]] tables (name, kind = widen |
    /// tilt | squash | drag, and their settings).
    #[arg(long, value_name = "FILE")]
    pub edits: Option<PathBuf>,
    /// Also write the report as JSON here.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Also write, per character, a picture of the first edits (rig | sticker | unchanged; the
    /// hidden outline each uncovers dotted in red), and
    /// for a synthetic sequence NAME_motion.png: six of its frames (rig | truth | sticker |
    /// unchanged).
    #[arg(long, value_name = "DIR")]
    pub pictures: Option<PathBuf>,
}

/// Runs `puppet eval-rig`.
pub fn run(args: EvalRigArgs, s: &Session) -> anyhow::Result<()> {
    if let Some(out) = &args.output {
        s.outputs.claim(out)?;
    }
    let edits = match &args.edits {
        Some(path) => EditsFile::load(path)?,
        None => default_edits(),
    };
    let members = set_members(&args.set)?;
    let mut characters = Vec::new();
    let mut problems = Vec::new();
    for member in &members {
        let (name, dir) = (&member.name, &member.artwork);
        let scored = (|| -> anyhow::Result<_> {
            let art = artwork::load(dir, &artwork::ImportOptions::default())?;
            let puppet = build_rigged(&art, &build::BuildOptions::default(), &RigOptions::default(), &s.ui)?;
            let truth_path = dir.join(TRUTH_FILE);
            let truth = if truth_path.is_file() {
                Some(RigTruth::load(&truth_path)?)
            } else {
                None
            };
            // After the build, whose own stages (meshing, rigging) would take the edits' steps.
            s.ui.stage(name, edits.len() as u64);
            let mut report = evaluate_character(name, &puppet, truth.as_ref(), &edits, &s.ui)?;
            if let Some(sequence) = &member.sequence {
                let truth = Truth::load(&sequence.join(puppet::synth::truth::TRUTH_FILE))?;
                report.motion = Some(evaluate_motion(&puppet, &truth, &s.ui)?);
                if let Some(pictures) = &args.pictures {
                    s.save_png(&pictures.join(format!("{name}_motion.png")), &motion_sheet(&puppet, &truth, 6)?)?;
                }
            }
            if let Some(pictures) = &args.pictures {
                s.save_png(&pictures.join(format!("{name}.png")), &edit_sheet(&puppet, &edits, 6)?)?;
            }
            Ok(report)
        })();
        match scored {
            Ok(report) => characters.push(report),
            Err(e) => problems.push(format!("{}: {e:#}", dir.display())),
        }
    }
    s.ui.finish();
    let report = RigReport { characters };
    s.ui.print(report.table().trim_end())?;
    if let Some(out) = &args.output {
        s.outputs.write(out, &serde_json::to_vec_pretty(&report)?)?;
        s.ui.say(format!("report → {}", out.display()))?;
    }
    anyhow::ensure!(
        problems.is_empty(),
        "{} characters could not be scored:\n  {}",
        problems.len(),
        problems.join("\n  ")
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_the_set_and_options() {
        parses(&["eval-rig", "data/rigs", "--edits", "e.toml", "-o", "r.json", "--pictures", "pics"]);
    }
}
