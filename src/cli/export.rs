//! `puppet export spine --model M <poses>... -o DIR`: a trained puppet and poses of it, for a
//! game engine.

use std::path::PathBuf;

use anyhow::Context as _;
use puppet::export::spine::{self, OutfitSkin, PoseAnimation};
use puppet::model::folder::ModelFolder;
use puppet::model::Model;
use puppet::puppet::{artwork, build::BuildOptions, format, pose_file::load_poses};
use puppet::rig::outfit::dress;
use puppet::rig::RigOptions;

use super::args::{positive_f32, ModelArgs, OutfitArgs};
use super::Session;

/// Export a puppet and its animations to a game engine's format.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    #[command(subcommand)]
    pub format: ExportFormat,
}

/// The formats.
#[derive(Debug, clap::Subcommand)]
pub enum ExportFormat {
    Spine(SpineArgs),
}

/// Spine 4.2: NAME.json (one bone per layer at its joint, each layer a weighted mesh, one
/// animation per pose source whose keys reproduce the poses: rotations and translations of the
/// bones plus per-vertex deform offsets), NAME.atlas and NAME.png (the layers' textures), for
/// Spine's runtimes in Unity, Godot, Unreal, Phaser, PixiJS and others.
#[derive(Debug, clap::Args)]
pub struct SpineArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Pose sources, each one animation named after it: a folder of pose files (*.json, in
    /// natural order — `inbetween`'s latent/, `fit`'s output folder) or one pose file (`pose`'s
    /// OUTPUT.json).
    #[arg(required = true, value_name = "POSES")]
    pub sources: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// The skeleton's file names (NAME.json, NAME.atlas, NAME.png).
    #[arg(long, default_value = "puppet")]
    pub name: String,
    /// Poses per second in the animations.
    #[arg(long, default_value_t = 12.0, value_parser = positive_f32)]
    pub fps: f32,
    /// The character in another outfit (mix and match): the poses (of the model's own puppet)
    /// are exported with these accessories, placed by their rig.
    #[command(flatten)]
    pub outfit: OutfitArgs,
    /// Another outfit as a Spine skin (accessory layers drawn for the same rest body: PNG
    /// layers with character.toml, or .ora): its accessories get bones and slots of their own,
    /// and an engine switches outfits by setting the skin. Repeat for more.
    #[arg(long = "skin", value_name = "ARTWORK")]
    pub skins: Vec<PathBuf>,
}

/// Runs `puppet export`.
pub fn run(args: ExportArgs, s: &Session) -> anyhow::Result<()> {
    match args.format {
        ExportFormat::Spine(args) => run_spine(args, s),
    }
}

fn run_spine(args: SpineArgs, s: &Session) -> anyhow::Result<()> {
    anyhow::ensure!(
        !args.name.is_empty() && !args.name.contains(['/', '\\']) && !args.name.starts_with('.'),
        "--name {:?}: give a plain file name",
        args.name
    );
    let own = format::load(&ModelFolder::open(&args.model.model)?.puppet())?;
    let mut animations = Vec::new();
    for source in &args.sources {
        let name = source
            .file_stem()
            .map_or_else(|| "animation".into(), |n| n.to_string_lossy().into_owned());
        animations.push(PoseAnimation {
            name,
            poses: load_poses(source, &own, &s.ui)?,
        });
    }
    // Other outfits need the model (its rig map of the body); the model's own needs only the
    // puppet.
    let dressed = args.outfit.dress.is_some() || !args.outfit.undress.is_empty();
    let model = if dressed || !args.skins.is_empty() {
        Some(Model::load(&args.model.model, &puppet::backend::device())?)
    } else {
        None
    };
    let mut skins = Vec::new();
    if let Some(model) = &model {
        for dir in &args.skins {
            let art = artwork::load(dir, &artwork::ImportOptions::default()).with_context(|| format!("--skin {}", dir.display()))?;
            let puppet = dress(&model.puppet, &art, &BuildOptions::default(), &RigOptions::default(), &s.ui)?;
            let worn = model.wearing(puppet).with_context(|| format!("--skin {}", dir.display()))?;
            skins.push(OutfitSkin {
                name: art.name.clone(),
                poses: animations
                    .iter()
                    .map(|a| a.poses.iter().map(|p| worn.pose_from(model, p)).collect())
                    .collect(),
                puppet: worn.puppet,
            });
        }
    }
    let worn = match (&model, dressed) {
        (Some(model), true) => args.outfit.model(model, &s.ui)?,
        _ => None,
    };
    let puppet = match (&model, worn) {
        (Some(model), Some(worn)) => {
            for animation in &mut animations {
                for pose in &mut animation.poses {
                    *pose = worn.pose_from(model, pose);
                }
            }
            worn.puppet
        }
        _ => own,
    };
    let skeleton = spine::skeleton(&puppet, &animations, &skins, &args.name, 1.0 / f64::from(args.fps))?;
    s.outputs.lock_folder(&args.output)?;
    let written = spine::write(&skeleton, &args.output, &args.name, &s.outputs)?;
    let sizes: Vec<String> = written
        .iter()
        .map(|p| {
            let bytes = std::fs::metadata(p).map_or(0, |m| m.len());
            format!("{} ({:.1} KB)", p.display(), bytes as f64 / 1024.0)
        })
        .collect();
    let keys: Vec<String> = animations.iter().map(|a| format!("{} ({} keys)", a.name, a.poses.len())).collect();
    let skin_names: Vec<String> = skins.iter().map(|k| format!("{:?}", k.name)).collect();
    s.ui.say(format!(
        "Spine {}: {} bones, animations {}{} → {}",
        spine::SPINE_VERSION,
        skeleton.json["bones"].as_array().map_or(0, Vec::len),
        keys.join(", "),
        if skins.is_empty() {
            String::new()
        } else {
            format!(
                ", skins {} and {:?} (the model's own accessories)",
                skin_names.join(", "),
                spine::OWN_SKIN
            )
        },
        sizes.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_sources_and_options() {
        parses(&[
            "export",
            "spine",
            "--model",
            "m",
            "ib/latent",
            "pose.json",
            "-o",
            "out",
            "--fps",
            "24",
            "--name",
            "robot",
            "--dress",
            "outfit",
            "--skin",
            "a",
            "--skin",
            "b",
        ]);
        for bad in [
            vec!["export", "spine", "--model", "m", "-o", "out"],
            vec!["export", "spine", "--model", "m", "p", "-o", "out", "--fps", "0"],
            vec!["export", "gltf", "--model", "m", "p", "-o", "out"],
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
