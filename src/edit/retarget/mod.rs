//! Retargeting (issue 57): another figure's motion played by this puppet. The motion is a BVH
//! skeleton's ([`bvh`]) or another puppet's poses (pose files of `fit`, `inbetween`, `pose`);
//! either way it becomes, per frame, each source part's turn in the image plane from the
//! source's rest ([`Motion`]), and the root's move.
//!
//! 1. **Matching** ([`Mapping`]): each layer of this puppet takes the motion of one source part —
//!    the one of the same name, or of the same humanoid part and side ([`names`]; sides by where
//!    the parts are drawn, so that the arm shown on the viewer's left moves as the source's arm
//!    shown there), or, between two puppets, the one at the same place in the layer tree; a
//!    `[retarget]` table in a TOML file names the pairs where these do not agree
//!    ([`RetargetMap`]). A layer no source part drives turns with its parent.
//! 2. **Turning** ([`Retargeter::rigid`]): the rest pose's limbs ([`crate::puppet::limbs`]) are
//!    turned root first, each about its joint by its source part's turn relative to its
//!    parent's, the figure is turned with the root part and moved as the root moved (scaled from
//!    the source's size to this puppet's), and accessories are placed by the rig.
//! 3. **The manifold** ([`Retargeter::pull`]): by default each turned pose is pulled onto this
//!    character's learned manifold, so that it bends and squashes as its artist draws it: the
//!    encoder's latent of the turned pose's render, then the latent steps of a drag
//!    ([`PoseEditor`], eq. 7–9) with every body vertex pinned to its turned place; then the
//!    layers are turned back to the motion's angles, keeping the learned shapes, and the
//!    accessories placed again.

pub mod bvh;
pub mod names;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use burn::tensor::Device;
use rayon::prelude::*;

use crate::edit::pose::{body_pins, PoseEditor, PoseOptions};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::picture::Picture;
use crate::posing::sample::figure_size;
use crate::progress::Progress;
use crate::puppet::limbs::{wrap, LimbTurns};
use crate::puppet::pose_file::load_poses;
use crate::puppet::{LayerKind, Puppet};
use crate::render::render_crisp;
use crate::rig::deform::RigMap;
use crate::user_file;
use bvh::Bvh;
use names::{part_of, Naming, Part, Side};

/// The most frames a retargeted motion may have after resampling (40 minutes at 30 frames a
/// second): a guard against a frame rate typed wrong.
pub const MAX_FRAMES: usize = 72_000;

/// Seconds per frame of pose files, which carry no time of their own: 12 frames a second, as
/// `export spine` plays them.
pub const POSE_FRAME_TIME: f32 = 1.0 / 12.0;

/// Which plane a 3D skeleton is seen in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    /// From the front: the skeleton's x to the right, y up (the BVH convention faces the
    /// skeleton towards +z, the viewer).
    #[default]
    Front,
    /// From the skeleton's right: its z (forwards) to the right, y up — a walk seen side on, as
    /// platform games draw it.
    Side,
}

/// What a BVH skeleton's turns are measured from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhRest {
    /// Its first frame, taken to be the puppet's rest pose.
    #[default]
    FirstFrame,
    /// Its offsets with every channel zero (often a T-pose).
    Offsets,
}

/// How a motion file is read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotionOptions {
    /// The plane a skeleton is seen in.
    pub view: View,
    /// What a skeleton's turns are measured from.
    pub rest: BvhRest,
}

/// The kinds of motion file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionKind {
    /// A BVH file.
    Bvh,
    /// A pose file or a folder of them, of another puppet.
    Poses,
}

/// One part of a motion's source: a skeleton's joint or a puppet's layer.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionPart {
    /// Its name in the source.
    pub name: String,
    /// The part it hangs from; `None` at the root.
    pub parent: Option<usize>,
    /// Where it is drawn at rest: its x in the image plane, in units of the source's size.
    pub rest_x: f32,
    /// Whether its turn can be measured (a bone seen end on at rest cannot).
    pub measurable: bool,
}

/// A motion: each source part's turn in each frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// The file or folder it was read from (named in errors).
    pub path: PathBuf,
    /// Whose names the parts have.
    pub naming: Naming,
    /// The source's parts, parents first.
    pub parts: Vec<MotionPart>,
    /// Per frame, each part's turn from its rest in the image plane (radians; y down, so a
    /// positive turn is clockwise on screen, as [`crate::puppet::limbs::Limb::turn`] turns).
    pub turns: Vec<Vec<f32>>,
    /// Per frame, the root's move from its rest in the image plane, in units of the source's
    /// size (the larger side of its rest bounding box).
    pub shifts: Vec<[f32; 2]>,
    /// Seconds per frame.
    pub frame_time: f32,
}

/// What the first bytes of a file show it to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Head {
    /// A BVH file: `HIERARCHY` first (after white space, in any case).
    Bvh,
    /// A JSON object: `{` first.
    Json,
    /// A PNG image.
    Png,
    /// Anything else, nothing included.
    Other,
}

impl Head {
    /// What `head`, the first bytes of a file (64 are enough), shows it to be.
    pub fn of(head: &[u8]) -> Self {
        if head.starts_with(b"\x89PNG") {
            return Head::Png;
        }
        let text = String::from_utf8_lossy(head);
        let start = text.trim_start();
        if start.get(..9).is_some_and(|w| w.eq_ignore_ascii_case("HIERARCHY")) {
            Head::Bvh
        } else if start.starts_with('{') {
            Head::Json
        } else {
            Head::Other
        }
    }
}

/// What kind of motion `path` holds, told by its content.
///
/// # Errors
/// [`Error::Io`] if missing or unreadable; [`Error::Format`] naming `path` for anything that is
/// not a motion: an image, a puppet or model folder, a `puppet.json`, JSON of another kind, or
/// text that is not a BVH file.
pub fn motion_kind(path: &Path) -> Result<MotionKind> {
    let not_a_motion = |what: &str| {
        Error::format(
            path,
            format!("{what}, not a motion (expected a BVH file, a pose file or a folder of pose files)"),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        if path.join(crate::puppet::format::PUPPET_FILE).is_file() {
            return Err(not_a_motion("a puppet folder"));
        }
        if path.join(crate::model::ModelFolder::NET).is_file() {
            return Err(not_a_motion("a trained model folder"));
        }
        return Ok(MotionKind::Poses);
    }
    let mut head = [0u8; 64];
    let n = {
        use std::io::Read;
        let mut file = user_file::open(path, u64::MAX)?;
        file.read(&mut head).map_err(|e| Error::io(path, e))?
    };
    match Head::of(&head[..n]) {
        Head::Png => Err(not_a_motion("a PNG image")),
        Head::Bvh => Ok(MotionKind::Bvh),
        Head::Json => {
            let bytes = user_file::read_bytes(path, user_file::DATA)?;
            let value: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| Error::format(path, format!("not JSON: {e}")))?;
            if value.get("vertices").is_some() {
                Ok(MotionKind::Poses)
            } else if value.get("layers").is_some() {
                Err(not_a_motion("a puppet.json"))
            } else {
                Err(not_a_motion("JSON without \"vertices\""))
            }
        }
        // Named a BVH file: its reader says what is wrong with it.
        Head::Other if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bvh")) => Ok(MotionKind::Bvh),
        Head::Other => Err(not_a_motion("neither a BVH file (HIERARCHY …) nor JSON")),
    }
}

/// Reads the motion at `path`: a BVH file, or pose files of `source` (a pose file, or a folder
/// of them in natural order).
///
/// # Errors
/// As [`motion_kind`], [`Bvh::load`] and [`load_poses`]; [`Error::Format`] naming `path` for
/// pose files without the puppet they pose.
pub fn load_motion(path: &Path, source: Option<&Puppet>, options: &MotionOptions, progress: &dyn Progress) -> Result<Motion> {
    match motion_kind(path)? {
        MotionKind::Bvh => Ok(Motion::from_bvh(&Bvh::load(path)?, path, options)),
        MotionKind::Poses => {
            let Some(source) = source else {
                return Err(Error::format(
                    path,
                    "pose files: the puppet they pose is needed to read them (the other model or its puppet folder)",
                ));
            };
            let poses = load_poses(path, source, progress)?;
            Ok(Motion::from_poses(source, &poses, path, POSE_FRAME_TIME))
        }
    }
}

impl Motion {
    /// The motion of a BVH skeleton read from `path`, seen in `options.view`: each joint's bone
    /// (from the joint to the mean of its children and end sites) projected on the image plane,
    /// its angle there measured from `options.rest`. A bone seen nearly end on in a frame (its
    /// image under a tenth of its length) keeps its last angle; one seen end on at rest cannot be
    /// measured.
    pub fn from_bvh(bvh: &Bvh, path: &Path, options: &MotionOptions) -> Self {
        let project = |p: [f64; 3]| -> [f64; 2] {
            match options.view {
                View::Front => [p[0], -p[1]],
                View::Side => [p[2], -p[1]],
            }
        };
        // A projected bone shorter than this share of its length has no reliable angle.
        const END_ON: f64 = 0.1;
        let angle = |d: Option<[f64; 3]>| -> Option<f64> {
            let d = d?;
            let q = project(d);
            let (length, shown) = (d.iter().map(|c| c * c).sum::<f64>().sqrt(), q[0].hypot(q[1]));
            (shown > END_ON * length).then(|| q[1].atan2(q[0]))
        };
        let rest_frame = match options.rest {
            BvhRest::FirstFrame => Some(0),
            BvhRest::Offsets => None,
        };
        let rest_angles: Vec<Option<f64>> = bvh.bone_directions(rest_frame).into_iter().map(angle).collect();
        let rest_places = bvh.placed(rest_frame);
        let mut points: Vec<[f64; 2]> = rest_places.iter().map(|p| project(p.position)).collect();
        for (j, joint) in bvh.joints.iter().enumerate() {
            for end in &joint.ends {
                // End sites at rest, for the size (their direction is the joint's own).
                let moved = bvh::apply(&rest_places[j].rotation, *end);
                points.push(project([0, 1, 2].map(|k| rest_places[j].position[k] + moved[k])));
            }
        }
        let size = f64::from(figure_size(&points.iter().map(|p| p.map(|c| c as f32)).collect::<Vec<_>>())).max(f64::MIN_POSITIVE);
        let root_rest = points[0];
        let parts = bvh
            .joints
            .iter()
            .enumerate()
            .map(|(j, joint)| MotionPart {
                name: joint.name.clone(),
                parent: joint.parent,
                rest_x: ((points[j][0] - root_rest[0]) / size) as f32,
                measurable: rest_angles[j].is_some(),
            })
            .collect();
        let mut last = vec![0.0f32; bvh.joints.len()];
        let mut turns = Vec::with_capacity(bvh.frames.len());
        let mut shifts = Vec::with_capacity(bvh.frames.len());
        for f in 0..bvh.frames.len() {
            for (j, d) in bvh.bone_directions(Some(f)).into_iter().enumerate() {
                if let (Some(now), Some(rest)) = (angle(d), rest_angles[j]) {
                    last[j] = wrap((now - rest) as f32);
                }
            }
            turns.push(last.clone());
            let root = project(bvh.placed(Some(f))[0].position);
            shifts.push([((root[0] - root_rest[0]) / size) as f32, ((root[1] - root_rest[1]) / size) as f32]);
        }
        Motion {
            path: path.to_path_buf(),
            naming: Naming::Skeleton,
            parts,
            turns,
            shifts,
            frame_time: bvh.frame_time as f32,
        }
    }

    /// The motion of `poses` of the puppet `source` (global numbering, frame pixels), read from
    /// `path`: each body layer's turn from its rest (the rotation of the least-squares
    /// similarity, [`LimbTurns::layer_turns`]) and the root layer's centroid's move.
    pub fn from_poses(source: &Puppet, poses: &[Vec<[f32; 2]>], path: &Path, frame_time: f32) -> Self {
        let turns_of = LimbTurns::new(source);
        let rest = source.rest_vertices();
        let size = figure_size(&rest).max(f32::MIN_POSITIVE);
        let offsets = source.vertex_offsets();
        let root = offsets[source.root]..offsets[source.root + 1];
        let mut parent = vec![None; source.layers.len()];
        for limb in turns_of.limbs() {
            parent[limb.layer] = Some(limb.parent);
        }
        let root_rest = centroid(&rest[root.clone()]);
        let parts = source
            .layers
            .iter()
            .enumerate()
            .map(|(l, layer)| MotionPart {
                name: layer.name.clone(),
                parent: parent[l],
                rest_x: (centroid(&rest[offsets[l]..offsets[l + 1]])[0] - root_rest[0]) / size,
                measurable: layer.kind == LayerKind::Body && offsets[l + 1] - offsets[l] >= 2,
            })
            .collect();
        Motion {
            path: path.to_path_buf(),
            naming: Naming::Layer,
            parts,
            turns: poses.iter().map(|p| turns_of.layer_turns(p)).collect(),
            shifts: poses
                .iter()
                .map(|p| {
                    let c = centroid(&p[root.clone()]);
                    [(c[0] - root_rest[0]) / size, (c[1] - root_rest[1]) / size]
                })
                .collect(),
            frame_time,
        }
    }

    /// How many frames there are.
    pub fn len(&self) -> usize {
        self.turns.len()
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.turns.is_empty()
    }

    /// The motion at `frame_time` seconds per frame, over the same duration: turns and moves
    /// interpolated linearly between the nearest frames (turns the short way round).
    ///
    /// # Errors
    /// [`Error::Setting`] for a frame time that is not positive; [`Error::Limit`] past
    /// [`MAX_FRAMES`].
    pub fn resampled(&self, frame_time: f32) -> Result<Motion> {
        if !(frame_time.is_finite() && frame_time > 0.0) {
            return Err(Error::setting("the frame time", frame_time, "a positive number of seconds"));
        }
        if self.is_empty() {
            return Ok(Motion {
                frame_time,
                ..self.clone()
            });
        }
        let duration = self.frame_time as f64 * self.len().saturating_sub(1) as f64;
        let count = (duration / frame_time as f64 + 1e-6).floor() + 1.0;
        if count > MAX_FRAMES as f64 {
            return Err(Error::limit("the retargeted frames", count as u64, MAX_FRAMES as u64, "frames"));
        }
        let mut out = Motion {
            turns: Vec::new(),
            shifts: Vec::new(),
            frame_time,
            ..self.clone()
        };
        for k in 0..count as usize {
            let at = (k as f64 * frame_time as f64 / self.frame_time as f64).min(self.len().saturating_sub(1) as f64);
            let (i, s) = (at.floor() as usize, (at - at.floor()) as f32);
            let j = (i + 1).min(self.len() - 1);
            let (a, b) = (&self.turns[i], &self.turns[j]);
            out.turns.push(a.iter().zip(b).map(|(&x, &y)| wrap(x + s * wrap(y - x))).collect());
            let (p, q) = (self.shifts[i], self.shifts[j]);
            out.shifts.push([p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])]);
        }
        Ok(out)
    }
}

/// A `[retarget]` table: source part names to this puppet's layer names, where names and the
/// layer tree do not match them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RetargetMap {
    /// The file it was read from (named in errors).
    pub path: PathBuf,
    /// The pairs (source part, layer).
    pub pairs: Vec<(String, String)>,
}

impl RetargetMap {
    /// Reads the `[retarget]` table of the TOML file `path`.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable, [`Error::Limit`] past [`user_file::CONFIG`], as
    /// [`RetargetMap::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses the text of the TOML file `path` (which only names it in errors).
    ///
    /// # Errors
    /// [`Error::Format`] naming `path` for bad TOML, no `[retarget]` table, or a value that is not
    /// a layer name (a string).
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let value: toml::Table = toml::from_str(text).map_err(|e| Error::format(path, e.to_string()))?;
        let Some(table) = value.get("retarget").and_then(toml::Value::as_table) else {
            return Err(Error::format(
                path,
                "no [retarget] table (expected `[retarget]` and lines `SourceName = \"layer\"`)",
            ));
        };
        let pairs = table
            .iter()
            .map(|(k, v)| match v.as_str() {
                Some(layer) => Ok((k.clone(), layer.to_string())),
                None => Err(Error::format(path, format!("retarget.{k}: {v} is not a layer name (a string)"))),
            })
            .collect::<Result<_>>()?;
        Ok(RetargetMap {
            path: path.to_path_buf(),
            pairs,
        })
    }
}

/// Which source part drives each layer of a puppet.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mapping {
    /// Per layer of the puppet, the index of the source part it takes the turns of.
    pub source_of: Vec<Option<usize>>,
}

impl Mapping {
    /// Matches `motion`'s parts to `puppet`'s body layers (module doc), with `map`'s pairs
    /// first; reports through `progress` the source parts and layers left unmatched.
    ///
    /// # Errors
    /// [`Error::Format`] naming `map`'s file for a pair naming a part the motion does not have
    /// or a layer the puppet does not have (or an accessory, which follows its rig), or two
    /// parts for one layer; [`Error::Format`] naming the motion's file when no part matches any
    /// layer (with both lists), or, for another puppet's poses, when layers on both sides are
    /// left unmatched (with both lists: a `[retarget]` table is needed).
    pub fn new(motion: &Motion, puppet: &Puppet, map: Option<&RetargetMap>, progress: &dyn Progress) -> Result<Self> {
        let body = |l: usize| puppet.layers[l].kind == LayerKind::Body;
        let n = puppet.layers.len();
        let mut source_of: Vec<Option<usize>> = vec![None; n];
        let mut taken = vec![false; motion.parts.len()];
        let mut fixed = vec![false; n];
        if let Some(map) = map {
            for (from, to) in &map.pairs {
                let Some(p) = motion.parts.iter().position(|p| &p.name == from) else {
                    return Err(Error::format(
                        &map.path,
                        format!(
                            "retarget.{from}: {} has no part {from:?} (it has {})",
                            motion.path.display(),
                            names_of(&motion.parts, |_| true)
                        ),
                    ));
                };
                let Some(l) = puppet.layer_index(to).filter(|&l| body(l)) else {
                    return Err(Error::format(
                        &map.path,
                        format!(
                            "retarget.{from}: the puppet has no body layer {to:?} (it has {}; accessories follow their rig)",
                            layer_names(puppet, body)
                        ),
                    ));
                };
                if fixed[l] {
                    return Err(Error::format(
                        &map.path,
                        format!("retarget.{from}: layer {to:?} is given two source parts"),
                    ));
                }
                (source_of[l], fixed[l], taken[p]) = (Some(p), true, true);
            }
        }
        let usable = |p: usize, taken: &[bool]| !taken[p] && motion.parts[p].measurable;
        // By name, then by humanoid part and side.
        if motion.naming == Naming::Layer {
            for (l, layer) in puppet.layers.iter().enumerate() {
                if !body(l) || source_of[l].is_some() {
                    continue;
                }
                let name = &layer.name;
                if let Some(p) = (0..motion.parts.len()).find(|&p| usable(p, &taken) && motion.parts[p].name.eq_ignore_ascii_case(name)) {
                    (source_of[l], taken[p]) = (Some(p), true);
                }
            }
        }
        let target_keys = layer_keys(puppet);
        let source_keys = part_keys(motion);
        for l in 0..n {
            let Some(key) = target_keys[l].filter(|_| body(l) && source_of[l].is_none()) else {
                continue;
            };
            // Several joints of one part (Spine, Spine1, Spine2): the one farthest from the root.
            let best = (0..motion.parts.len())
                .filter(|&p| usable(p, &taken) && source_keys[p] == Some(key))
                .max_by_key(|&p| depth(&motion.parts, p));
            if let Some(p) = best {
                (source_of[l], taken[p]) = (Some(p), true);
            }
        }
        // Between two layer trees, by place in the tree: the roots, then, under a matched pair,
        // the one unmatched child on each side.
        if motion.naming == Naming::Layer {
            let source_root = motion.parts.iter().position(|p| p.parent.is_none());
            if let (None, Some(p)) = (source_of[puppet.root], source_root) {
                if usable(p, &taken) {
                    (source_of[puppet.root], taken[p]) = (Some(p), true);
                }
            }
            let limbs = crate::puppet::limbs::limbs(puppet);
            let mut changed = true;
            while changed {
                changed = false;
                for l in 0..n {
                    let Some(p) = source_of[l] else { continue };
                    let ours: Vec<usize> = limbs
                        .iter()
                        .filter(|c| c.parent == l && body(c.layer) && source_of[c.layer].is_none())
                        .map(|c| c.layer)
                        .collect();
                    let theirs: Vec<usize> = (0..motion.parts.len())
                        .filter(|&c| motion.parts[c].parent == Some(p) && usable(c, &taken))
                        .collect();
                    if let ([a], [b]) = (ours.as_slice(), theirs.as_slice()) {
                        (source_of[*a], taken[*b]) = (Some(*b), true);
                        changed = true;
                    }
                }
            }
        }
        let matched = |l: usize| source_of[l].is_some();
        let moving: Vec<usize> = crate::puppet::limbs::limbs(puppet)
            .iter()
            .map(|c| c.layer)
            .chain([puppet.root])
            .filter(|&l| body(l))
            .collect();
        let unmatched_layers = layer_names(puppet, |l| moving.contains(&l) && !matched(l));
        let unmatched_parts = names_of(&motion.parts, |p| motion.parts[p].measurable && !taken[p]);
        if !(0..n).any(matched) {
            return Err(Error::format(
                &motion.path,
                format!(
                    "no part of the motion matches a layer of the puppet: the motion has {}; the puppet has {} (name the pairs in a [retarget] table)",
                    names_of(&motion.parts, |_| true),
                    layer_names(puppet, body)
                ),
            ));
        }
        let layers_left = moving.iter().any(|&l| !matched(l));
        let parts_left = (0..motion.parts.len()).any(|p| motion.parts[p].measurable && !taken[p]);
        if motion.naming == Naming::Layer && layers_left && parts_left {
            return Err(Error::format(
                &motion.path,
                format!(
                    "another layer tree: the motion's layers {unmatched_parts} match none of the puppet's layers {unmatched_layers} by name or place (name the pairs in a [retarget] table)"
                ),
            ));
        }
        if layers_left {
            progress.warn(&format!(
                "no part of the motion drives {unmatched_layers}: they turn with the layer they hang from"
            ));
        }
        if parts_left && motion.naming == Naming::Layer {
            progress.warn(&format!("the motion's {unmatched_parts} drive no layer of the puppet"));
        }
        Ok(Mapping { source_of })
    }

    /// The pairs, `(source part, layer)`, in the puppet's layer order.
    pub fn pairs<'a>(&self, motion: &'a Motion, puppet: &'a Puppet) -> Vec<(&'a str, &'a str)> {
        self.source_of
            .iter()
            .enumerate()
            .filter_map(|(l, p)| p.map(|p| (motion.parts[p].name.as_str(), puppet.layers[l].name.as_str())))
            .collect()
    }
}

/// The names of `parts` that `keep` keeps, quoted and comma-separated.
fn names_of(parts: &[MotionPart], keep: impl Fn(usize) -> bool) -> String {
    quoted((0..parts.len()).filter(|&p| keep(p)).map(|p| parts[p].name.as_str()))
}

/// The names of `puppet`'s layers that `keep` keeps, quoted and comma-separated.
fn layer_names(puppet: &Puppet, keep: impl Fn(usize) -> bool) -> String {
    quoted(
        (0..puppet.layers.len())
            .filter(|&l| keep(l))
            .map(|l| puppet.layers[l].name.as_str()),
    )
}

fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let list: Vec<String> = names.map(|n| format!("{n:?}")).collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join(", ")
    }
}

/// How many parents a part has.
fn depth(parts: &[MotionPart], mut p: usize) -> usize {
    let mut d = 0;
    while let Some(q) = parts[p].parent {
        (p, d) = (q, d + 1);
        if d > parts.len() {
            break; // not a tree: no deeper answer
        }
    }
    d
}

/// A humanoid part and the side of the picture it is drawn on.
type Key = (Part, Side);

/// Each name's part, its side turned into the side of the picture it is drawn on: of a pair of
/// parts named left and right, the one drawn further left is on the left (a skeleton facing the
/// viewer shows its left arm on the viewer's right); where the two are drawn at the same x (a
/// side view), the names decide.
fn screen_keys(keys: Vec<Option<Key>>, rest_x: &[f32]) -> Vec<Option<Key>> {
    // Mean x of each named (part, side).
    let mut sums: BTreeMap<Key, (f32, usize)> = BTreeMap::new();
    for (k, x) in keys.iter().zip(rest_x) {
        if let Some(k) = k {
            let e = sums.entry(*k).or_default();
            (e.0, e.1) = (e.0 + x, e.1 + 1);
        }
    }
    let mean = |k: Key| sums.get(&k).map(|(s, n)| s / *n as f32);
    keys.into_iter()
        .map(|key| {
            let (part, side) = key?;
            let other = match side {
                Side::Left => Side::Right,
                Side::Right => Side::Left,
                Side::Middle => return Some((part, side)),
            };
            match (mean((part, side)), mean((part, other))) {
                // Sizes are in units of the figure: a hundredth of it apart is apart.
                (Some(x), Some(y)) if (x - y).abs() > 0.01 => Some((part, if x < y { Side::Left } else { Side::Right })),
                _ => Some((part, side)),
            }
        })
        .collect()
}

/// The keys of a puppet's layers (body layers only), sides as drawn.
fn layer_keys(puppet: &Puppet) -> Vec<Option<Key>> {
    let rest = puppet.rest_vertices();
    let offsets = puppet.vertex_offsets();
    let size = figure_size(&rest).max(f32::MIN_POSITIVE);
    let xs: Vec<f32> = (0..puppet.layers.len())
        .map(|l| centroid(&rest[offsets[l]..offsets[l + 1]])[0] / size)
        .collect();
    let keys = puppet
        .layers
        .iter()
        .map(|l| (l.kind == LayerKind::Body).then(|| part_of(&l.name, Naming::Layer)).flatten())
        .collect();
    screen_keys(keys, &xs)
}

/// The keys of a motion's parts, sides as drawn.
fn part_keys(motion: &Motion) -> Vec<Option<Key>> {
    let keys = motion.parts.iter().map(|p| part_of(&p.name, motion.naming)).collect();
    let xs: Vec<f32> = motion.parts.iter().map(|p| p.rest_x).collect();
    screen_keys(keys, &xs)
}

/// The mean of `points` (the origin for none).
fn centroid(points: &[[f32; 2]]) -> [f32; 2] {
    let n = points.len().max(1) as f32;
    points.iter().fold([0.0, 0.0], |c, p| [c[0] + p[0] / n, c[1] + p[1] / n])
}

/// How a motion is played.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RetargetOptions {
    /// Keep the plain turns: no pull onto the learned manifold.
    pub rigid: bool,
    /// Leave out the root's move sideways (a walk on the spot); the move up and down stays.
    pub in_place: bool,
    /// The drag's settings for the pull onto the manifold (its steps per frame).
    pub pull: PoseOptions,
}

impl Default for RetargetOptions {
    /// The pull with three drag steps per frame: most of what a drag gains comes in its first
    /// steps (neural-puppet.md §4.2 takes 2 to 5).
    fn default() -> Self {
        RetargetOptions {
            rigid: false,
            in_place: false,
            pull: PoseOptions {
                steps: 3,
                ..PoseOptions::default()
            },
        }
    }
}

/// The poses of a retargeted motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Retargeted {
    /// Each frame's pose (frame pixels, global numbering): pulled onto the manifold, or the
    /// plain turns with [`RetargetOptions::rigid`].
    pub poses: Vec<Vec<[f32; 2]>>,
    /// Each frame's plain turns.
    pub rigid: Vec<Vec<[f32; 2]>>,
}

/// Plays motions on one puppet: its limbs, rest pose and rig, prepared once.
pub struct Retargeter<'p> {
    puppet: &'p Puppet,
    turns: LimbTurns,
    rig: Option<&'p RigMap>,
    rest: Vec<[f32; 2]>,
    size: f32,
}

impl<'p> Retargeter<'p> {
    /// A retargeter for `puppet`, its accessories placed by `rig` (the model's, if it has one).
    pub fn new(puppet: &'p Puppet, rig: Option<&'p RigMap>) -> Self {
        let rest = puppet.rest_vertices();
        Retargeter {
            turns: LimbTurns::new(puppet),
            size: figure_size(&rest),
            rest,
            rig,
            puppet,
        }
    }

    /// Per frame of `motion`, each layer's turn from its rest (radians): its source part's,
    /// or, for a layer no part drives, its parent's (0 at the root).
    pub fn turns(&self, motion: &Motion, mapping: &Mapping) -> Vec<Vec<f32>> {
        (0..motion.len()).map(|f| self.layer_turns(motion, mapping, f)).collect()
    }

    /// [`Self::turns`] of frame `f`.
    fn layer_turns(&self, motion: &Motion, mapping: &Mapping, f: usize) -> Vec<f32> {
        let mut turns = vec![0.0f32; self.puppet.layers.len()];
        let driven = |l: usize| mapping.source_of.get(l).copied().flatten().map(|p| motion.turns[f][p]);
        turns[self.puppet.root] = driven(self.puppet.root).unwrap_or(0.0);
        for limb in self.turns.limbs() {
            turns[limb.layer] = driven(limb.layer).unwrap_or(turns[limb.parent]);
        }
        turns
    }

    /// The root layer's centroid in `pose`.
    fn root_centre(&self, pose: &[[f32; 2]]) -> [f32; 2] {
        let o = self.turns.offsets();
        centroid(&pose[o[self.puppet.root]..o[self.puppet.root + 1]])
    }

    /// Turns every limb of `pose` by what it lacks of `turns` (each layer's turn from its rest,
    /// [`Self::layer_turns`]), root first, then the whole pose about the root layer's centroid
    /// by what the root lacks, moves the root's centroid to `centre`, and places the
    /// accessories.
    fn turn_to(&self, pose: &mut [[f32; 2]], turns: &[f32], centre: [f32; 2]) {
        let now = self.turns.of(pose);
        for (limb, measured) in self.turns.limbs().iter().zip(now) {
            limb.turn(pose, wrap(turns[limb.layer] - turns[limb.parent] - measured));
        }
        let root_now = self.turns.layer_turns(pose)[self.puppet.root];
        let (s, c) = wrap(turns[self.puppet.root] - root_now).sin_cos();
        let pivot = self.root_centre(pose);
        for p in pose.iter_mut() {
            let (dx, dy) = (p[0] - pivot[0], p[1] - pivot[1]);
            *p = [centre[0] + c * dx - s * dy, centre[1] + s * dx + c * dy];
        }
        if let Some(rig) = self.rig {
            rig.apply(pose);
        }
    }

    /// Each frame of `motion` as the plain turns of the rest pose (module doc, step 2).
    pub fn rigid(&self, motion: &Motion, mapping: &Mapping, in_place: bool) -> Vec<Vec<[f32; 2]>> {
        let rest_centre = self.root_centre(&self.rest);
        self.turns(motion, mapping)
            .iter()
            .enumerate()
            .map(|(f, turns)| {
                let mut pose = self.rest.clone();
                let shift = motion.shifts[f];
                let centre = [
                    rest_centre[0] + if in_place { 0.0 } else { shift[0] * self.size },
                    rest_centre[1] + shift[1] * self.size,
                ];
                self.turn_to(&mut pose, turns, centre);
                pose
            })
            .collect()
    }

    /// The `rigid` poses pulled onto `model`'s manifold (module doc, step 3), then turned back
    /// to `turns` (per frame, each layer's turn from its rest: [`Self::turns`]); frames in two
    /// runs side by side, each run a drag continuing from frame to frame.
    ///
    /// # Errors
    /// As [`render_crisp`], [`Model::encode`] and [`PoseEditor::drag`] (options out of range).
    pub fn pull(
        &self,
        model: &Model,
        rigid: &[Vec<[f32; 2]>],
        turns: &[Vec<f32>],
        options: &PoseOptions,
        device: &Device,
        progress: &dyn Progress,
    ) -> Result<Vec<Vec<[f32; 2]>>> {
        if rigid.is_empty() {
            return Ok(Vec::new());
        }
        let (w, h) = (model.puppet.width, model.puppet.height);
        let pictures: Vec<Picture> = rigid
            .par_iter()
            .map(|p| render_crisp(&model.puppet, p, w, h))
            .collect::<Result<_>>()?;
        let z = model.encode(&pictures.iter().collect::<Vec<_>>(), device)?;
        let pins = body_pins(&model.puppet);
        let runs = 2.min(rigid.len());
        let n = rigid.len();
        let pulled: Vec<Vec<Vec<[f32; 2]>>> = (0..runs)
            .into_par_iter()
            .map(|k| {
                let frames = k * n / runs..(k + 1) * n / runs;
                let mut editor = PoseEditor::at(model, z.clone().narrow(0, frames.start, 1), device)?;
                editor.pin_vertices(&pins)?;
                frames
                    .map(|f| {
                        editor.set_latent(z.clone().narrow(0, f, 1))?;
                        let targets: Vec<[f32; 2]> = pins.iter().map(|&v| rigid[f][v]).collect();
                        let mut pose = editor.drag(&targets, options)?.vertices;
                        self.turn_to(&mut pose, &turns[f], self.root_centre(&rigid[f]));
                        progress.advance(1);
                        Ok(pose)
                    })
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<_>>()?;
        Ok(pulled.into_iter().flatten().collect())
    }
}

/// Plays `motion` on `model`'s character (module doc): the plain turns, and unless
/// `options.rigid`, those pulled onto the manifold.
///
/// # Errors
/// As [`Retargeter::pull`].
pub fn retarget(
    model: &Model,
    motion: &Motion,
    mapping: &Mapping,
    options: &RetargetOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Retargeted> {
    options.pull.validate()?;
    let retargeter = Retargeter::new(&model.puppet, model.expansion.rig_map());
    let rigid = retargeter.rigid(motion, mapping, options.in_place);
    progress.stage("retarget", motion.len() as u64);
    let poses = if options.rigid {
        progress.advance(motion.len() as u64);
        rigid.clone()
    } else {
        let turns = retargeter.turns(motion, mapping);
        retargeter.pull(model, &rigid, &turns, &options.pull, device, progress)?
    };
    Ok(Retargeted { poses, rigid })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Recorder;
    use crate::test_util::{rect_layer, stripes, untrained_model, weld};

    /// A torso with a two-part arm drawn to the viewer's right: `arm_l` from the shoulder at
    /// (32, 14), `forearm_l` from the elbow at (44, 14), 64 × 40.
    fn armed_puppet() -> Puppet {
        let f = (64, 40);
        let mut p = Puppet {
            width: f.0,
            height: f.1,
            layers: vec![
                rect_layer("torso", f, [16.0, 8.0, 32.0, 34.0], (4, 6), stripes([0.9, 0.6, 0.2], 16.0)),
                rect_layer("arm_l", f, [32.0, 12.0, 44.0, 16.0], (4, 2), stripes([0.2, 0.5, 0.9], 14.0)),
                rect_layer("forearm_l", f, [44.0, 12.0, 56.0, 16.0], (4, 2), stripes([0.8, 0.2, 0.5], 13.0)),
            ],
            root: 0,
            joints: Vec::new(),
            rig: None,
        };
        weld(&mut p, 0, 1, [32.0, 14.0]);
        weld(&mut p, 1, 2, [44.0, 14.0]);
        p
    }

    /// A skeleton whose left arm points along +x (the viewer's right from the front); in frame 1
    /// the forearm turns by `degrees` about z (towards +y, up) and the root rises by 1.
    fn arm_bvh(degrees: f32) -> Bvh {
        let text = format!(
            "HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n\
             JOINT LeftArm\n{{\nOFFSET 1 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n\
             JOINT LeftForeArm\n{{\nOFFSET 2 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n\
             End Site\n{{\nOFFSET 2 0 0\n}}\n}}\n}}\n}}\nMOTION\nFrames: 2\nFrame Time: 0.1\n\
             0 0 0 0 0 0 0 0 0 0 0 0\n0 1 0 0 0 0 0 0 0 {degrees} 0 0\n"
        );
        Bvh::parse(text.as_bytes(), Path::new("arm.bvh")).unwrap()
    }

    #[test]
    fn a_joint_turned_in_the_bvh_turns_its_limb_by_the_same_angle() {
        let puppet = armed_puppet();
        let motion = Motion::from_bvh(&arm_bvh(30.0), Path::new("arm.bvh"), &MotionOptions::default());
        let recorder = Recorder::default();
        let mapping = Mapping::new(&motion, &puppet, None, &recorder).unwrap();
        let pairs = mapping.pairs(&motion, &puppet);
        assert!(
            pairs.contains(&("LeftArm", "arm_l")) && pairs.contains(&("LeftForeArm", "forearm_l")),
            "{pairs:?}"
        );
        // A turn about z towards +y is counter-clockwise on screen: −30° in the picture, whose
        // y points down.
        let turns = LimbTurns::new(&puppet);
        let forearm = turns.limbs().iter().position(|l| l.layer == 2).unwrap();
        let arm = turns.limbs().iter().position(|l| l.layer == 1).unwrap();
        let check = |poses: &[Vec<[f32; 2]>], what: &str| {
            let of = turns.of(&poses[1]);
            assert!(
                (of[forearm].to_degrees() + 30.0).abs() < 0.1,
                "{what}: forearm {}°",
                of[forearm].to_degrees()
            );
            assert!(of[arm].to_degrees().abs() < 0.1, "{what}: arm {}°", of[arm].to_degrees());
            assert!(turns.of(&poses[0]).iter().all(|a| a.abs() < 1e-4), "{what}: frame 0 is the rest");
        };
        let rigid = Retargeter::new(&puppet, None).rigid(&motion, &mapping, false);
        check(&rigid, "rigid");
        // The root rose by a fifth of the skeleton's size (5 wide, root to fingertip): a fifth
        // of the figure's.
        let size = figure_size(&puppet.rest_vertices());
        let rise = rigid[0][0][1] - rigid[1][0][1];
        assert!((rise - size / 5.0).abs() < 1e-3, "rose {rise}, expected {}", size / 5.0);
        let (model, device) = untrained_model(puppet.clone(), 16);
        let pulled = retarget(&model, &motion, &mapping, &RetargetOptions::default(), &device, &recorder).unwrap();
        check(&pulled.poses, "pulled onto the manifold");
        assert_eq!(pulled.rigid, rigid);
    }

    #[test]
    fn another_puppets_poses_drive_the_layers_of_the_same_names_and_places() {
        let source = armed_puppet();
        let mut target = armed_puppet();
        target.layers[2].name = "lower".into(); // matched by its place under arm_l
        let mut pose = source.rest_vertices();
        let turns = LimbTurns::new(&source);
        turns.limbs()[1].turn(&mut pose, 0.4);
        let motion = Motion::from_poses(
            &source,
            &[source.rest_vertices(), pose.clone()],
            Path::new("poses"),
            POSE_FRAME_TIME,
        );
        let mapping = Mapping::new(&motion, &target, None, &Recorder::default()).unwrap();
        assert_eq!(mapping.source_of, vec![Some(0), Some(1), Some(2)]);
        let rigid = Retargeter::new(&target, None).rigid(&motion, &mapping, false);
        assert!(crate::test_util::largest_distance(&rigid[1], &pose) < 1e-3);
        // Two unmatched children on each side: another tree, and the error names them.
        let with_tail = |mut p: Puppet, name: &str| {
            let tail = rect_layer(name, (64, 40), [8.0, 30.0, 16.0, 34.0], (2, 1), stripes([0.1, 0.9, 0.1], 9.0));
            p.layers.push(tail);
            weld(&mut p, 0, 3, [16.0, 32.0]);
            p
        };
        let three = with_tail(source.clone(), "tail");
        let motion = Motion::from_poses(&three, &[three.rest_vertices()], Path::new("poses"), POSE_FRAME_TIME);
        let mut two = with_tail(armed_puppet(), "fin");
        two.layers[1].name = "upper".into();
        let err = Mapping::new(&motion, &two, None, &Recorder::default()).unwrap_err().to_string();
        assert!(err.starts_with("poses: another layer tree"), "{err}");
        assert!(
            err.contains("\"arm_l\"") && err.contains("\"tail\"") && err.contains("\"upper\"") && err.contains("\"fin\""),
            "{err}"
        );
        let map = RetargetMap::parse("[retarget]\narm_l = \"upper\"\ntail = \"fin\"\n", Path::new("map.toml")).unwrap();
        let mapping = Mapping::new(&motion, &two, Some(&map), &Recorder::default()).unwrap();
        assert_eq!(mapping.source_of, vec![Some(0), Some(1), Some(2), Some(3)]);
        let bad = RetargetMap::parse("[retarget]\nleg = \"upper\"\n", Path::new("map.toml")).unwrap();
        let err = Mapping::new(&motion, &two, Some(&bad), &Recorder::default())
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("map.toml: retarget.leg: poses has no part \"leg\""), "{err}");
        assert!(RetargetMap::parse("arm = 1", Path::new("m.toml"))
            .unwrap_err()
            .to_string()
            .contains("no [retarget] table"));
    }

    #[test]
    fn a_skeleton_that_matches_no_layer_names_both() {
        let text = "HIERARCHY\nROOT Bone1\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Bone2\n{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0 0 0 0\n";
        let motion = Motion::from_bvh(
            &Bvh::parse(text.as_bytes(), Path::new("odd.bvh")).unwrap(),
            Path::new("odd.bvh"),
            &MotionOptions::default(),
        );
        let err = Mapping::new(&motion, &armed_puppet(), None, &Recorder::default())
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("odd.bvh: no part of the motion matches"), "{err}");
        assert!(
            err.contains("\"Bone1\", \"Bone2\"") && err.contains("\"torso\", \"arm_l\", \"forearm_l\""),
            "{err}"
        );
    }

    #[test]
    fn resampling_keeps_the_duration_and_turns_the_short_way() {
        let mut motion = Motion::from_bvh(&arm_bvh(170.0), Path::new("arm.bvh"), &MotionOptions::default());
        motion.turns[1][2] = wrap(200f32.to_radians());
        let half = motion.resampled(0.05).unwrap();
        assert_eq!(half.len(), 3);
        // 0° to 200° (−160°) the short way: through −80°.
        assert!(
            (half.turns[1][2].to_degrees() + 80.0).abs() < 1e-3,
            "{}",
            half.turns[1][2].to_degrees()
        );
        assert!(motion.resampled(0.0).is_err());
        assert!(matches!(motion.resampled(1e-9), Err(Error::Limit { .. })));
    }
}
