//! `puppet rig <puppet or artwork> -o preview.png`: the accessory rig drawn (accessory-rigs.md);
//! `puppet rig apply <puppet> --pose vertices.json -o out.png`: a body pose carried to the
//! accessories, beside the same pose without the rig.

use std::path::PathBuf;

use anyhow::Context as _;
use puppet::picture::contact_sheet;
use puppet::puppet::pose_file::PoseFile;
use puppet::puppet::{artwork, build, format, Puppet};
use puppet::render::render_crisp;
use puppet::rig::deform::{deform, DeformOptions, PointMotion};
use puppet::rig::preview::rig_preview;
use puppet::rig::{build_rigged, RigOptions};

use super::Session;

/// Draw a puppet's accessory rig: the layer DAG, every pin coloured by its constraint
/// (occlusion red, point blue, coincident green, overlap orange), and one weight map per
/// accessory. Given artwork, the puppet is built and rigged first (with character.toml's [rig]
/// overrides).
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct RigArgs {
    #[command(subcommand)]
    pub action: Option<RigAction>,
    /// A puppet folder with a rig, or character artwork.
    #[arg(required = true)]
    pub puppet: Option<PathBuf>,
    /// The preview PNG.
    #[arg(short, long, required = true)]
    pub output: Option<PathBuf>,
}

/// What `puppet rig` does besides drawing the rig.
#[derive(Debug, clap::Subcommand)]
pub enum RigAction {
    /// Carry a body pose to the accessories and draw it beside the pose without the rig.
    Apply(ApplyArgs),
}

/// `puppet rig apply`.
#[derive(Debug, clap::Args)]
pub struct ApplyArgs {
    /// A puppet folder with a rig.
    pub puppet: PathBuf,
    /// The pose: every vertex's position (a *_vertices.json of fit, pose or inbetween); its body
    /// vertices drive the accessories.
    #[arg(long, value_name = "FILE")]
    pub pose: PathBuf,
    /// The picture: without the rig | with it.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Layers held by single points also turn with their parent (glasses tilt with a head); a rig
    /// with affine skinning turns them so already.
    #[arg(long)]
    pub turn_points: bool,
}

/// A puppet with its rig: a puppet folder as saved, or artwork built and rigged.
fn rigged(path: &std::path::Path, s: &Session) -> anyhow::Result<Puppet> {
    if path.join(format::PUPPET_FILE).is_file() {
        return Ok(format::load(path)?);
    }
    let art = artwork::load_reporting(path, &artwork::ImportOptions::default(), &s.ui)?;
    Ok(build_rigged(&art, &build::BuildOptions::default(), &RigOptions::default(), &s.ui)?)
}

/// Runs `puppet rig`.
pub fn run(args: RigArgs, s: &Session) -> anyhow::Result<()> {
    if let Some(RigAction::Apply(apply)) = args.action {
        return run_apply(apply, s);
    }
    let (Some(path), Some(output)) = (args.puppet, args.output) else {
        anyhow::bail!("give a puppet (or artwork) and -o preview.png");
    };
    s.outputs.claim(&output)?;
    let puppet = rigged(&path, s)?;
    s.ui.finish();
    let rig = puppet.rig.as_ref().with_context(|| {
        format!(
            "{}: the puppet has no accessory rig (no accessory layers, or built before rigs)",
            path.display()
        )
    })?;
    let scale = (512 / puppet.width.max(puppet.height)).clamp(1, 4);
    s.save_png(&output, &rig_preview(&puppet, rig, scale)?)?;
    let pins: usize = rig.accessories.iter().map(|a| a.pins.len()).sum();
    s.ui.say(format!(
        "{} accessories, {} edges, {pins} pins → {}",
        rig.accessories.len(),
        rig.edges.len(),
        output.display()
    ))
}

fn run_apply(args: ApplyArgs, s: &Session) -> anyhow::Result<()> {
    s.outputs.claim(&args.output)?;
    let puppet = format::load(&args.puppet)?;
    let rig = puppet
        .rig
        .as_ref()
        .with_context(|| format!("{}: the puppet has no accessory rig", args.puppet.display()))?;
    let pose = PoseFile::load(&args.pose, &puppet)?.vertices;
    let options = DeformOptions {
        point_motion: if args.turn_points {
            PointMotion::Turn
        } else {
            PointMotion::Translate
        },
        ..DeformOptions::default()
    };
    let rigged = deform(&puppet, rig, &pose, &options);
    let (w, h) = (puppet.width, puppet.height);
    let without = render_crisp(&puppet, &pose, w, h)?;
    let with = render_crisp(&puppet, &rigged, w, h)?;
    let scale = (384 / w.max(h)).clamp(1, 4);
    let sheet = contact_sheet(&[&without.upscaled_on_white(scale), &with.upscaled_on_white(scale)], 2);
    s.save_png(&args.output, &sheet)?;
    s.ui.say(format!("without the rig | with it → {}", args.output.display()))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_the_preview_and_apply() {
        parses(&["rig", "art", "-o", "p.png"]);
        parses(&["rig", "apply", "puppet", "--pose", "v.json", "-o", "a.png", "--turn-points"]);
        for bad in [vec!["rig", "art"], vec!["rig", "apply", "puppet", "-o", "a.png"]] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
