//! `puppet retarget --model M <motion> -o DIR`: another figure's motion — a BVH file, or another
//! character's pose files — played by this character (issue 57; `edit::retarget`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;

use puppet::edit::inbetween::{write_inbetweens, InbetweenFiles, Inbetweens};
use puppet::edit::pose::PoseOptions;
use puppet::edit::retarget::{
    load_motion, motion_kind, retarget, BvhRest, Mapping, MotionKind, MotionOptions, RetargetMap, RetargetOptions, View,
};
use puppet::model::{Model, ModelFolder};
use puppet::puppet::format;
use puppet::render::animation::AnimationFiles;

use super::args::{positive_f32, AnimationArgs, ModelArgs};
use super::Session;

/// Play another figure's motion on this character: a BVH file (a humanoid skeleton, its joints
/// matched to the layers by a built-in name table), or pose files of another character (`fit`,
/// `inbetween` and `pose` write them; with --from, its layers matched to these by name and
/// place in the layer tree).
///
/// Each frame turns this character's limbs about their joints as the matched parts turn in the
/// picture, from the motion's rest; then, unless --rigid, the pose is pulled onto the poses
/// the model learned, so it bends and squashes as the drawings do. Writes into OUTPUT:
/// frame_NNN.png and frame_NNN.json (each frame and its pose: `export spine` takes the folder as
/// an animation), sprites.png with its atlas sprites.json, rigid/frame_NNN.png (the plain turns,
/// for comparison; not with --rigid), and with --gif / --apng the motion played in a loop.
#[derive(Debug, clap::Args)]
pub struct RetargetArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The motion: a BVH file, or a pose file or a folder of them (in natural order) of the
    /// character given with --from.
    #[arg(value_name = "MOTION")]
    pub motion: PathBuf,
    /// Output folder (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// The character the pose files pose: its model folder or its puppet folder.
    #[arg(long, value_name = "DIR")]
    pub from: Option<PathBuf>,
    /// A TOML file whose [retarget] table names a layer of this character for a joint or layer
    /// of the motion where names and the layer tree do not match them (`LeftArm = "arm_back"`).
    #[arg(long, value_name = "FILE")]
    pub map: Option<PathBuf>,
    /// Keep the plain turns of the rest pose: no pull onto the learned poses.
    #[arg(long)]
    pub rigid: bool,
    /// Frames per second written: the motion is resampled to this rate (default: the motion's
    /// own, a BVH file's frame time, 12 for pose files), and the animations play at it.
    #[arg(long, value_name = "N", value_parser = positive_f32)]
    pub fps: Option<f32>,
    /// The plane a BVH skeleton is seen in: front (x right, y up) or side (its forward
    /// direction, z, to the right: a walk side on).
    #[arg(long, default_value = "front", value_name = "VIEW")]
    pub view: ViewArg,
    /// What a BVH skeleton's turns are measured from, the pose this character's rest pose
    /// stands for: its first frame, or its offsets with every channel zero (often a T-pose).
    #[arg(long, default_value = "first-frame", value_name = "REST")]
    pub bvh_rest: RestArg,
    /// Leave out the motion's travel sideways (a walk on the spot); the bob up and down stays.
    #[arg(long)]
    pub in_place: bool,
    /// Drag steps per frame pulling the pose onto the learned poses.
    #[arg(long, default_value_t = RetargetOptions::default().pull.steps, value_name = "N")]
    pub pull_steps: usize,
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Cells per row of sprites.png.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub columns: usize,
}

/// `--view`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ViewArg {
    /// From the front.
    Front,
    /// From the skeleton's right.
    Side,
}

/// `--bvh-rest`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum RestArg {
    /// The first frame.
    FirstFrame,
    /// The offsets, every channel zero.
    Offsets,
}

/// The puppet of the model or puppet folder `dir`.
fn source_puppet(dir: &Path) -> anyhow::Result<puppet::Puppet> {
    let puppet = match ModelFolder::open(dir) {
        Ok(folder) => format::load(&folder.puppet())?,
        Err(_) => format::load(dir)?,
    };
    Ok(puppet)
}

/// Runs `puppet retarget`.
pub fn run(args: RetargetArgs, s: &Session) -> anyhow::Result<()> {
    let started = Instant::now();
    let device = puppet::backend::device();
    let model = Model::load(&args.model.model, &device)?;
    let options = RetargetOptions {
        rigid: args.rigid,
        in_place: args.in_place,
        pull: PoseOptions {
            steps: args.pull_steps,
            ..RetargetOptions::default().pull
        },
    };
    options.pull.validate().context("--pull-steps")?;
    let from = match (motion_kind(&args.motion)?, &args.from) {
        (MotionKind::Poses, None) => anyhow::bail!(
            "{}: pose files: give the character they pose with --from (its model or puppet folder)",
            args.motion.display()
        ),
        (MotionKind::Poses, Some(dir)) => Some(source_puppet(dir).with_context(|| format!("--from {}", dir.display()))?),
        (MotionKind::Bvh, _) => None,
    };
    let motion_options = MotionOptions {
        view: match args.view {
            ViewArg::Front => View::Front,
            ViewArg::Side => View::Side,
        },
        rest: match args.bvh_rest {
            RestArg::FirstFrame => BvhRest::FirstFrame,
            RestArg::Offsets => BvhRest::Offsets,
        },
    };
    let mut motion = load_motion(&args.motion, from.as_ref(), &motion_options, &s.ui)?;
    if let Some(fps) = args.fps {
        motion = motion.resampled(1.0 / fps).context("--fps")?;
    }
    let map = args.map.as_deref().map(RetargetMap::load).transpose()?;
    let mapping = Mapping::new(&motion, &model.puppet, map.as_ref(), &s.ui)?;
    let pairs: Vec<String> = mapping
        .pairs(&motion, &model.puppet)
        .iter()
        .map(|(from, to)| format!("{from} → {to}"))
        .collect();
    let computed = Instant::now();
    let result = retarget(&model, &motion, &mapping, &options, &device, &s.ui)?;
    let pose_seconds = computed.elapsed().as_secs_f64();
    s.ui.finish();

    // Everything is known to work: only now is the output folder made.
    let out = &args.output;
    s.outputs.lock_folder(out)?;
    let frames = |dir: PathBuf| AnimationFiles {
        frames: Some((dir, "frame".into())),
        background: args.animation.background,
        ..AnimationFiles::default()
    };
    let delay_ms = (1000.0 * motion.frame_time).round().clamp(1.0, 65_535.0) as u32;
    let files = InbetweenFiles {
        path: AnimationFiles {
            frames: Some((out.clone(), "frame".into())),
            sprites: Some((out.join("sprites.png"), args.columns)),
            ..args.animation.files_timed(false, delay_ms)
        },
        rigid: if args.rigid {
            AnimationFiles::default()
        } else {
            frames(out.join("rigid"))
        },
        poses: Some(out.clone()),
        ..InbetweenFiles::default()
    };
    let frame_times: Vec<f32> = (0..motion.len()).map(|k| k as f32 * motion.frame_time).collect();
    let played = Inbetweens {
        t: frame_times,
        path: result.poses,
        vertex: Vec::new(),
        rigid: result.rigid,
    };
    write_inbetweens(&model, &played, &[], &files, &s.outputs, &s.ui)?;
    s.ui.finish();
    for path in args.animation.animations() {
        s.ui.say(format!("wrote {}", path.display()))?;
    }
    let n = motion.len();
    s.ui.say(format!(
        "{n} frames of {} at {:.1} frames/s ({}) → {} (frame_NNN.png + .json, sprites.png + sprites.json{}); poses made in {:.2} s ({:.0} frames/s), {:.1} s in all",
        args.motion.display(),
        1.0 / motion.frame_time,
        pairs.join(", "),
        out.display(),
        if args.rigid { "" } else { ", rigid/" },
        pose_seconds,
        n as f64 / pose_seconds.max(1e-9),
        started.elapsed().as_secs_f64()
    ))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_a_motion_and_its_options() {
        let base = ["retarget", "--model", "m", "walk.bvh", "-o", "out"];
        parses(&base);
        parses(
            &[
                &base[..],
                &["--rigid", "--fps", "24", "--view", "side", "--bvh-rest", "offsets", "--in-place"],
            ]
            .concat(),
        );
        parses(
            &[
                &base[..],
                &["--map", "map.toml", "--from", "other", "--gif", "a.gif", "--pull-steps", "5"],
            ]
            .concat(),
        );
        for bad in [
            vec!["retarget", "--model", "m", "walk.bvh"],
            [&base[..], &["--fps", "0"]].concat(),
            [&base[..], &["--view", "top"]].concat(),
        ] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
