//! `puppet prior`: the character-agnostic prior. `data` writes the posing engine's poses of
//! characters with their truth, the data the prior learns from; `train` trains it; `eval`
//! scores it and the parts network on such poses.

use std::path::PathBuf;

use anyhow::Context;
use puppet::atomic_file::{record, unique_stems};
use puppet::eval::posed_pairs::{score_posed, ALPHAS};
use puppet::parts::learn::{LearnOptions, TrainedNet};
use puppet::picture::ImageLimits;
use puppet::posing::write::{character_files, write_character};
use puppet::posing::{EngineSettings, PoseEngine};
use puppet::prior::{train_prior, PriorConfig};
use puppet::synth::sheet_flow::SyntheticPairs;
use puppet::train::trainer::load_or_build_puppet;

use super::train_parts::say_summary;
use super::Session;

/// The generator's seed of the prior's first generator pair: far from every seed a test, a
/// tuning run, an evaluation or the parts network's training uses.
const GENERATOR_SEEDS: u64 = 3_000_000;

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
    Train(TrainArgs),
    Eval(EvalArgs),
}

/// Train the prior: a correspondence network on pairs of the config's characters posed by the
/// engine (and the generator's, at generator_share), scored on the held-out characters' pairs.
///
/// Writes the run folder (the config's output, or --output): config.toml, net.json,
/// weights.bpk, log.csv, curves.png and checkpoints/. A killed run continues with --resume.
/// The weights puppet ships (data/prior/) come from configs/prior.toml.
#[derive(Debug, clap::Args)]
struct TrainArgs {
    /// The training config (TOML; keys in docs/prior.md).
    config: PathBuf,
    /// The run folder, instead of the config's output.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Continue from the latest checkpoint.
    #[arg(long)]
    resume: bool,
    /// Stop (checkpointed, resumable) once this many steps are done in total.
    #[arg(long, value_name = "STEPS")]
    pause_at: Option<u64>,
}

/// Score correspondence networks on posed characters (folders of `puppet prior data`).
///
/// For the disjoint pairs of consecutive poses (0 → 1, 2 → 3, …), every template vertex shown
/// in both is carried from the first frame to the second by the network, and PCK at 0.1, 0.05
/// and 0.025 of the frame's larger side is taken against its true place: for the prior (built
/// in, or --net) and the parts network puppet ships. `bench/flow_dis.py posed` scores DIS flow
/// on the same pairs.
#[derive(Debug, clap::Args)]
struct EvalArgs {
    /// Character folders written by `puppet prior data`.
    #[arg(required = true, value_name = "FOLDER")]
    folders: Vec<PathBuf>,
    /// A prior's run folder, instead of the built-in prior.
    #[arg(long, value_name = "DIR")]
    net: Option<PathBuf>,
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
        PriorCommand::Train(args) => train(args, s),
        PriorCommand::Eval(args) => eval(args, s),
    }
}

/// Runs `puppet prior train`.
fn train(args: TrainArgs, s: &Session) -> anyhow::Result<()> {
    let mut config = PriorConfig::load(&args.config)?;
    if let Some(output) = args.output {
        config.output = output;
    }
    let generator = SyntheticPairs {
        first_seed: GENERATOR_SEEDS,
        size: u32::try_from(config.net.input_size)?,
        varied: true,
    };
    let options = LearnOptions {
        resume: args.resume,
        pause_at: args.pause_at,
    };
    let summary = train_prior(&config, &generator, &options, &s.ui)?;
    say_summary(&summary, &config.output, "held-out characters' pairs", s)
}

/// Runs `puppet prior eval`.
fn eval(args: EvalArgs, s: &Session) -> anyhow::Result<()> {
    let device = puppet::backend::device();
    let prior = puppet::prior::load_or_shipped(args.net.as_deref(), &device)?;
    let parts = TrainedNet::shipped(&device)?;
    let alphas = ALPHAS.map(|a| format!("PCK@{a:<6}")).join(" ");
    s.ui.print(format!(
        "{:<25} {:<7} {:>5} {:>8}  {alphas}",
        "character", "network", "pairs", "vertices"
    ))?;
    let mut totals = [[0.0; 3]; 2];
    for folder in &args.folders {
        let name = folder
            .file_name()
            .map_or_else(|| folder.display().to_string(), |n| n.to_string_lossy().into_owned());
        for ((label, net), total) in [("prior", &prior), ("parts", &parts)].into_iter().zip(&mut totals) {
            let score = score_posed(folder, net, &device)?;
            let pck = score.pck.map(|v| format!("{:>9.2}%", 100.0 * v)).join(" ");
            s.ui.print(format!("{name:<25} {label:<7} {:>5} {:>8} {pck}", score.pairs, score.vertices))?;
            for (t, v) in total.iter_mut().zip(score.pck) {
                *t += v / args.folders.len() as f64;
            }
        }
    }
    for (label, total) in ["prior", "parts"].iter().zip(totals) {
        let pck = total.map(|v| format!("{:>9.2}%", 100.0 * v)).join(" ");
        s.ui.print(format!("{:<25} {label:<7} {:>5} {:>8} {pck}", "mean over characters", "", ""))?;
    }
    Ok(())
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
