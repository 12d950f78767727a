//! `puppet prior`: the character-agnostic prior. `data` writes the posing engine's poses of
//! characters with their truth, the data the prior learns from.

use std::path::PathBuf;

use anyhow::Context;
use puppet::atomic_file::{record, unique_stems};
use puppet::picture::ImageLimits;
use puppet::posing::write::{character_files, write_character};
use puppet::posing::{EngineSettings, PoseEngine};
use puppet::train::trainer::load_or_build_puppet;

use super::Session;

/// The most poses one run writes per character.
const MAX_POSES: usize = 10_000;

/// The character-agnostic prior.
#[derive(Debug, clap::Args)]
pub struct PriorArgs {
    #[command(subcommand)]
    command: PriorCommand,
}

/// `puppet prior` subcommands.
#[derive(Debug, clap::Subcommand)]
enum PriorCommand {
    Data(DataArgs),
}

/// Pose characters at random and write each pose with its truth (the prior's training data).
///
/// Each character (artwork, built with its accessory rig, or a puppet folder) gets a folder in
/// OUTPUT named after it: rest.png, puppet.json and textures/, layers.json (each layer's name,
/// first vertex and label colour), and per pose pose_NNN.png, pose_NNN_labels.png (the layer in
/// front at each pixel) and pose_NNN.json (every template vertex's place in the frame and
/// whether it shows), plus sheet.png with the shown vertices dotted. Limbs turn about their
/// joints, layers bend by ARAP drags, the figure squashes and stretches, accessories follow
/// their rigs. The same seed gives the same files.
#[derive(Debug, clap::Args)]
struct DataArgs {
    /// Characters: artwork (a folder with character.toml, a .ora or a .psd) or puppet folders.
    #[arg(required = true, value_name = "CHARACTER")]
    characters: Vec<PathBuf>,
    /// Output folder (created if missing; a folder puppet did not make is refused unless --force).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Poses per character, 1 to 10000.
    #[arg(long, default_value_t = 16, value_name = "N")]
    poses: usize,
    /// Random seed of the poses.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

impl DataArgs {
    /// Checks what parsing cannot.
    fn validate(&self) -> anyhow::Result<()> {
        if !(1..=MAX_POSES).contains(&self.poses) {
            anyhow::bail!("--poses {}: give from 1 to {MAX_POSES} poses per character", self.poses);
        }
        Ok(())
    }
}

/// Runs `puppet prior`.
pub fn run(args: PriorArgs, s: &Session) -> anyhow::Result<()> {
    match args.command {
        PriorCommand::Data(args) => data(args, s),
    }
}

/// Runs `puppet prior data`: every character is built and every output claimed before a file
/// is written, so a refused command writes nothing.
fn data(args: DataArgs, s: &Session) -> anyhow::Result<()> {
    args.validate()?;
    let mut engines = Vec::with_capacity(args.characters.len());
    for path in &args.characters {
        let puppet = load_or_build_puppet(path, &ImageLimits::default(), true, &s.ui)
            .with_context(|| format!("while building the character {}", path.display()))?;
        engines.push(PoseEngine::new(&puppet, EngineSettings::default()).with_context(|| format!("while posing {}", path.display()))?);
    }
    s.ui.finish();
    s.outputs.claim_folder(&args.output)?;
    let dirs: Vec<PathBuf> = unique_stems(&args.characters).iter().map(|name| args.output.join(name)).collect();
    for dir in &dirs {
        s.outputs.claim_folder(dir)?;
        for file in character_files(dir, args.poses) {
            s.outputs.claim(&file)?;
        }
    }
    for ((engine, dir), path) in engines.iter().zip(&dirs).zip(&args.characters) {
        write_character(engine, args.seed, args.poses, dir, &s.outputs).with_context(|| format!("while writing {}", dir.display()))?;
        record(&std::path::absolute(dir)?)?;
        s.ui.say(format!(
            "{}: {} poses of {} ({} layers, {} limbs, {} layers dragged)",
            dir.display(),
            args.poses,
            path.display(),
            engine.puppet().layers.len(),
            engine.limbs().len(),
            engine.drag_layers().count()
        ))?;
    }
    record(&std::path::absolute(&args.output)?)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::parses;
    use super::*;

    #[test]
    fn data_parses_its_characters_and_refuses_pose_counts_out_of_range() {
        let cli = parses(&["prior", "data", "a", "b.psd", "-o", "out", "--poses", "3", "--seed", "9"]);
        let super::super::Command::Prior(PriorArgs {
            command: PriorCommand::Data(args),
        }) = cli.command
        else {
            panic!("not prior data")
        };
        assert_eq!((args.characters.len(), args.poses, args.seed), (2, 3, 9));
        assert!(args.validate().is_ok());
        for bad in ["0", "10001"] {
            let cli = parses(&["prior", "data", "a", "-o", "out", "--poses", bad]);
            let super::super::Command::Prior(PriorArgs {
                command: PriorCommand::Data(args),
            }) = cli.command
            else {
                panic!("not prior data")
            };
            let err = args.validate().unwrap_err().to_string();
            assert!(err.contains(&format!("--poses {bad}")) && err.contains("1 to 10000"), "{err}");
        }
    }
}
