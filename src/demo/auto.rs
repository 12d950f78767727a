//! `puppet auto`: from drawn poses to a puppet in one command (issue 16 item 4). The poses' parts
//! are found (`parts`: the built-in correspondence network, then the part finder) and written as
//! artwork — label map, reference frame, `character.toml` with joints and layer order — with the
//! poses as its `frames/`; the demo pipeline then builds, trains, fits, in-betweens and drags it
//! and writes its page.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::page::FoundParts;
use super::{check_outputs, DemoOptions, DemoSummary};
use crate::atomic_file::{record, written_by_puppet, Outputs, MANIFEST};
use crate::error::{Error, Result};
use crate::parts::artwork::write_artwork;
use crate::parts::learn::TrainedNet;
use crate::parts::matching::network_correspondences;
use crate::parts::pose::{check_one_character, load_poses, Layout};
use crate::parts::{find_parts, set_aside_strangers, PartsOptions};
use crate::progress::Progress;

/// The forward–backward check on the network's correspondences, pixels (`puppet parts`'
/// default).
const CHECK: f32 = 2.0;

/// What `puppet auto` runs on and where it writes.
#[derive(Clone, Debug)]
pub struct AutoOptions {
    /// A sprite sheet, or a folder of pose images.
    pub input: PathBuf,
    /// How to cut a sheet (by its alpha when `None`).
    pub layout: Option<Layout>,
    /// The output folder: `artwork/` (the found parts and the poses as `frames/`), the model and
    /// the demo's page.
    pub output: PathBuf,
    /// A correspondence network trained by `puppet train-parts` (default: the built-in one).
    pub net: Option<PathBuf>,
    /// How parts are found.
    pub parts: PartsOptions,
    /// Training steps.
    pub steps: u64,
    /// Replace files puppet did not write.
    pub force: bool,
}

/// What `puppet auto` did.
#[derive(Clone, Debug)]
pub struct AutoSummary {
    /// The parts it found.
    pub found: FoundParts,
    /// The demo run on them.
    pub demo: DemoSummary,
}

/// Runs `puppet auto`.
///
/// # Errors
/// Whatever reading the poses, finding parts, writing the artwork and the demo report; refusals
/// to overwrite come before anything is written.
pub fn run(options: &AutoOptions, progress: &dyn Progress) -> Result<AutoSummary> {
    let artwork = options.output.join("artwork");
    let demo = DemoOptions {
        output: options.output.clone(),
        steps: options.steps,
        character: artwork.clone(),
        force: options.force,
        appearance_epochs: None,
        found_parts: None,
    };
    check_outputs(&demo)?;
    let (poses, sheet_size) = load_poses(&options.input, options.layout)?;
    check_one_character(&poses, &options.input)?;
    let outputs = Outputs::new(options.force);
    let frames_dir = artwork.join("frames");
    let frame_files: Vec<PathBuf> = (0..poses.len())
        .map(|k| frames_dir.join(frame_name(sheet_size.is_none().then_some(poses[k].name.as_str()), k)))
        .collect();
    for path in &frame_files {
        outputs.claim(path)?;
    }
    let stale = stale_frames(&frames_dir, &frame_files, options.force)?;
    let started = Instant::now();
    let device = crate::backend::device();
    let trained = match &options.net {
        Some(dir) => TrainedNet::load(dir, &device)?,
        None => TrainedNet::shipped(&device)?,
    };
    let flows = network_correspondences(&trained.net, trained.size, &poses, &device, progress)?;
    // A back view or a turn is no articulation of the rest: its frame is neither split into
    // parts nor trained on (an earlier run's copy of it goes as a stale frame does).
    let (poses, mut flows, keep) = set_aside_strangers(poses, flows, CHECK, progress);
    let mut stale = stale;
    stale.extend(
        (0..frame_files.len())
            .filter(|k| !keep.contains(k))
            .map(|k| frame_files[k].clone())
            .filter(|path| path.is_file()),
    );
    let frame_files: Vec<PathBuf> = keep.iter().map(|&k| frame_files[k].clone()).collect();
    flows.keep_consistent(poses[0].width(), CHECK);
    let parts = find_parts(poses, &flows, &options.parts)?;
    let seconds = started.elapsed().as_secs_f64();
    outputs.claim_folder(&options.output)?;
    outputs.claim_folder(&artwork)?;
    let name = options
        .input
        .file_stem()
        .map_or_else(|| "character".into(), |n| n.to_string_lossy().into_owned());
    let written = write_artwork(&parts, &artwork, &name, sheet_size, &outputs)?;
    std::fs::create_dir_all(&frames_dir).map_err(|e| Error::io(&frames_dir, e))?;
    // An earlier run's frames that this run does not write would be trained on as drawn frames.
    for path in &stale {
        std::fs::remove_file(path).map_err(|e| Error::io(path, e))?;
    }
    for (pose, path) in parts.poses.iter().zip(&frame_files) {
        outputs.write(path, &pose.image.png_bytes(path)?)?;
    }
    for dir in [&options.output, &artwork, &frames_dir] {
        record(&std::path::absolute(dir).map_err(|e| Error::io(dir, e))?)?;
    }
    let found = FoundParts {
        name: name.clone(),
        poses: parts.poses.len(),
        parts: parts.segmentation.parts,
        seconds,
        preview: relative(&written.preview, &options.output),
    };
    let demo = super::run(
        &DemoOptions {
            found_parts: Some(found.clone()),
            ..demo
        },
        progress,
    )?;
    Ok(AutoSummary { found, demo })
}

/// The files in `frames_dir` other than this run's `frames`: frames an earlier `puppet auto`
/// wrote there, to be removed.
///
/// # Errors
/// [`Error::WouldOverwrite`] for a file there puppet did not write (unless `force`): the demo
/// would train on it.
fn stale_frames(frames_dir: &Path, frames: &[PathBuf], force: bool) -> Result<Vec<PathBuf>> {
    if !frames_dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut stale = Vec::new();
    for entry in std::fs::read_dir(frames_dir).map_err(|e| Error::io(frames_dir, e))? {
        let path = entry.map_err(|e| Error::io(frames_dir, e))?.path();
        let ours = frames.iter().any(|f| f.file_name() == path.file_name());
        let manifest = path.file_name().is_some_and(|n| n == MANIFEST);
        if ours || manifest || !path.is_file() {
            continue;
        }
        if !(force || written_by_puppet(&path)?) {
            return Err(Error::WouldOverwrite {
                path,
                reason: "is in the frames folder of an earlier run, which the puppet would be trained on, and puppet did not write it"
                    .into(),
            });
        }
        stale.push(path);
    }
    Ok(stale)
}

/// The file name of pose `k` among the frames: the stem of its own file name when it came from
/// a folder (so `walk0` stays a walk frame), else numbered.
fn frame_name(file: Option<&str>, k: usize) -> String {
    let name = file
        .and_then(|f| Path::new(f).file_stem())
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let safe = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || "_-".contains(c));
    if safe {
        format!("{name}.png")
    } else {
        format!("pose_{k:03}.png")
    }
}

/// `path` relative to `base` when inside it (for links on the page).
fn relative(path: &Path, base: &Path) -> String {
    path.strip_prefix(base).unwrap_or(path).to_string_lossy().replace('\\', "/")
}
