//! Motions played on the character in the editor (issue 57): a BVH file sent by a page, read,
//! its joints matched to the layers and played as turns of the limbs — pulled onto the poses
//! the model learned unless the page asks for the plain turns — by [`mod@crate::edit::retarget`],
//! and the poses sent back for the page to play in a loop.

use std::path::Path;

use super::error::ApiError;
use super::state::App;
use crate::edit::retarget::bvh::Bvh;
use crate::edit::retarget::{retarget, Head, Mapping, Motion, MotionOptions, RetargetOptions, View};
use crate::progress::Recorder;

/// The largest BVH file a page may send, bytes (a minute of a 60-joint capture at 120 frames a
/// second is about 10 MB).
pub const MAX_MOTION_BYTES: usize = 16 << 20;

/// The most frames the editor plays (30 s at 30 frames a second): each is a pose sent to the
/// page; `puppet retarget` plays longer ones.
pub const MAX_MOTION_FRAMES: usize = 900;

/// The most vertices sent over all frames (frames × the outfit's vertices): about 40 MB of JSON,
/// 800 frames of the Kenney robot's 1,245 vertices.
pub const MAX_MOTION_VERTICES: usize = 1_000_000;

/// The fastest a motion is played, frames a second: a faster file is resampled to it (the
/// page's player draws at most 60 frames a second).
pub const MAX_PLAY_FPS: f32 = 60.0;

/// How a page asks for a motion to be played.
#[derive(Clone, Copy, Debug, Default)]
pub struct PlayOptions {
    /// The plane the skeleton is seen in.
    pub view: View,
    /// The plain turns of the rest pose, not pulled onto the learned poses.
    pub rigid: bool,
    /// Without the root's travel sideways.
    pub in_place: bool,
    /// Frames a second to resample to (default: the file's own, at most [`MAX_PLAY_FPS`]).
    pub fps: Option<f32>,
    /// The outfit the poses are of.
    pub outfit: usize,
}

/// A motion as the page plays it.
#[derive(Clone, Debug)]
pub struct Played {
    /// Each frame's pose (frame pixels, the outfit's numbering).
    pub poses: Vec<Vec<[f32; 2]>>,
    /// Seconds per frame.
    pub frame_time: f32,
    /// The joints of the skeleton.
    pub joints: usize,
    /// Which joint drives which layer.
    pub pairs: Vec<(String, String)>,
    /// What the matching warned of (layers no joint drives).
    pub warnings: Vec<String>,
}

/// The motion of the BVH file `bytes` (`name` naming it in messages) played on `app`'s
/// character as `options` ask, kept as the motion a page downloads ([`App::motion`]). Blocks for
/// the pull (about 60 frames a second on two cores).
///
/// # Errors
/// [`ApiError`] 400 for bytes that are not a BVH file (naming the line), an fps that is not a
/// positive number or a motion past [`MAX_MOTION_FRAMES`] or [`MAX_MOTION_VERTICES`]; 404 for an outfit that does not
/// exist; 422 when no joint of the skeleton matches a layer (naming both); as [`retarget`].
pub fn play(app: &App, name: &str, bytes: &[u8], options: &PlayOptions) -> Result<Played, ApiError> {
    let model = &app.outfit(options.outfit)?.model;
    let path = Path::new(name);
    let head = Head::of(&bytes[..bytes.len().min(64)]);
    if head != Head::Bvh {
        let what = match head {
            Head::Png => "a PNG image",
            _ if bytes.is_empty() => "empty",
            _ => "not a BVH file",
        };
        return Err(ApiError::bad_request(format!(
            "{name}: {what}, where a motion was expected (a BVH file, which begins with HIERARCHY)"
        )));
    }
    let bvh = Bvh::parse(bytes, path).map_err(|e| ApiError::bad_request(e.to_string()))?;
    let motion = Motion::from_bvh(
        &bvh,
        path,
        &MotionOptions {
            view: options.view,
            ..MotionOptions::default()
        },
    );
    let fps = match options.fps {
        Some(fps) if !(fps.is_finite() && fps > 0.0 && fps <= MAX_PLAY_FPS) => {
            return Err(ApiError::bad_request(format!(
                "fps is {fps}; give a number above 0, at most {MAX_PLAY_FPS}"
            )))
        }
        Some(fps) => Some(fps),
        None => (1.0 / motion.frame_time > MAX_PLAY_FPS).then_some(MAX_PLAY_FPS),
    };
    let motion = match fps {
        Some(fps) => motion.resampled(1.0 / fps)?,
        None => motion,
    };
    let most = MAX_MOTION_FRAMES.min(MAX_MOTION_VERTICES / model.puppet.vertex_count().max(1));
    if motion.len() > most {
        return Err(ApiError::bad_request(format!(
            "{name} has {} frames at {:.0} frames a second; the editor plays up to {most} of this character (ask for fewer frames a second, or use puppet retarget)",
            motion.len(),
            1.0 / motion.frame_time
        )));
    }
    let recorder = Recorder::default();
    let mapping = Mapping::new(&motion, &model.puppet, None, &recorder).map_err(|e| ApiError::unprocessable(e.to_string()))?;
    let retarget_options = RetargetOptions {
        rigid: options.rigid,
        in_place: options.in_place,
        ..RetargetOptions::default()
    };
    let played = retarget(model, &motion, &mapping, &retarget_options, app.device(), &recorder)?;
    let pairs = mapping
        .pairs(&motion, &model.puppet)
        .into_iter()
        .map(|(from, to)| (from.to_string(), to.to_string()))
        .collect();
    app.keep_motion(options.outfit, played.poses.clone());
    Ok(Played {
        poses: played.poses,
        frame_time: motion.frame_time,
        joints: bvh.joints.len(),
        pairs,
        warnings: recorder.warnings(),
    })
}
