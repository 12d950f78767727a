//! `puppet eval-rig`: accessory rigs scored on a set of layered characters (DESIGN.md "Rig
//! metrics"), under a committed suite of body edits, beside two baselines.
//!
//! Each edit moves the body's vertices; the accessories then come from
//! - **rig**: the accessory rig ([`crate::rig::deform::deform`] with its default options: the
//!   linear map, then ARAP polish of a folded accessory);
//! - **unchanged**: left at rest;
//! - **sticker**: each accessory vertex bound to the body point under it at rest (the front-most
//!   body layer holding it, else the nearest layer's nearest point, keeping its offset from
//!   it), moving with that point.
//!
//! The metrics, per edit:
//! - **occlusion kept**: the body outline hidden under accessories' rest meshes (by at least
//!   half a pixel), sampled every pixel and carried by the edit, still covered by an accessory in
//!   front of it — the share of samples, the deepest exposure (pixels from an uncovered sample to
//!   the nearest cover), and leak blobs (runs of more than 4 consecutive uncovered samples along
//!   an outline). Coverage is tested on the accessories' triangles, not on pixels, so rounding
//!   does not expose a sample that did not move off its cover; and
//!   **own occlusion kept**, the same share over only the outline each accessory hides of the
//!   body layer it follows (its DAG parent, or the body layer its parent chain ends in), covered
//!   by those accessories: what the occlusion constraint promises. The first counts a torso
//!   outline that a sleeve hid and uncovers when the arm swings, as the drawn truth does too;
//!   the second does not;
//! - **stays attached**: each accessory's overlap area with its parent after / before (overlap
//!   retention, median over accessories), and the drift of 16 fixed anchors of the overlap
//!   bound to both layers (mean pixels between the two places an anchor goes);
//! - **no tearing**: accessory triangles that turn over, enclosed holes in an accessory's
//!   coverage (rasterised at 4× the canvas resolution) that were not there at rest, the change
//!   of distance between coincident boundaries (95th percentile, pixels), and the largest
//!   stretch of an accessory triangle (95th percentile of the deformation gradient's larger
//!   singular value).
//!
//! DAG correctness against `rig_truth.json` (`{"attach_to": {"<layer>": "<parent>"}}`): strict
//! (the parent is the truth) and lenient (the parent is the truth or hangs from it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::edit::arap_drag::arap_drag;
use crate::edit::bind::Binding;
use crate::error::{Error, Result};
use crate::geom::triangle_grid::TriangleGrid;
use crate::progress::{Progress, Silent};
use crate::puppet::rig_data::{Constraint, RigData, RigEdge, RigOverrides};
use crate::puppet::{LayerKind, Puppet};
use crate::rig::dag::{layer_dag, DagOptions};
use crate::rig::deform::{bind_point, deform, DeformOptions};
use crate::rig::mask::Mask;
use crate::rng::Rng;
use crate::synth::{true_positions, Truth};
use crate::user_file;

/// The truth file of a character of a rig evaluation set.
pub const TRUTH_FILE: &str = "rig_truth.json";

/// `rig_truth.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigTruth {
    /// Each accessory's true parent, by name.
    pub attach_to: BTreeMap<String, String>,
}

impl RigTruth {
    /// Reads a `rig_truth.json`.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::CONFIG`];
    /// [`Error::Format`] naming the file for anything but `{"attach_to": {"layer": "parent"}}`.
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_bytes(path, user_file::CONFIG)?, path)
    }

    /// Parses the bytes of a `rig_truth.json`; `path` only names the file in errors.
    ///
    /// # Errors
    /// [`Error::Format`] naming `path` for anything but `{"attach_to": {"layer": "parent"}}`.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self> {
        serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("not a rig truth file: {e}")))
    }
}

/// A body layer an edit acts on, found by geometry, not by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The body layer highest in the frame (least mean y of its rest vertices).
    Head,
    /// The root body layer; when the root is the head, the largest other body layer (the head
    /// if it is alone). The layers an edit carries along are those hanging, through joints,
    /// from the edited layer on the side away from the torso.
    Torso,
}

/// One body edit of the suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Edit {
    /// Scale a layer (and the body layers hanging from it) horizontally about its centroid.
    Widen {
        /// Which layer.
        layer: Role,
        /// The factor.
        factor: f32,
    },
    /// Turn a layer (and the body layers hanging from it) about its joint with its parent.
    Tilt {
        /// Which layer.
        layer: Role,
        /// Degrees, counter-clockwise on screen.
        degrees: f32,
    },
    /// Scale every body vertex vertically about the root's centroid.
    Squash {
        /// The factor.
        factor: f32,
    },
    /// Drag the centres of two random body layers other than the root by ARAP (the root
    /// anchored, joints welded).
    Drag {
        /// The seed of the points and their targets.
        seed: u64,
        /// How far, as a fraction of the larger frame side.
        reach: f32,
    },
}

/// A named edit. (Unknown keys are refused by [`Edit`]: serde's `deny_unknown_fields` here
/// would refuse every key of the flattened edit, `kind` included.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NamedEdit {
    /// Its name in the report.
    pub name: String,
    /// What it does.
    #[serde(flatten)]
    pub edit: Edit,
}

/// The committed suite (issue 13): widen the head 10 % and 20 %, tilt it ±12°, squash the body
/// to 0.8 of its height, widen the body (the torso and all it carries) 15 %, five seeded ARAP drags.
pub fn default_edits() -> Vec<NamedEdit> {
    let named = |name: &str, edit| NamedEdit { name: name.into(), edit };
    let mut edits = vec![
        named(
            "head wider 10%",
            Edit::Widen {
                layer: Role::Head,
                factor: 1.1,
            },
        ),
        named(
            "head wider 20%",
            Edit::Widen {
                layer: Role::Head,
                factor: 1.2,
            },
        ),
        named(
            "head tilt +12°",
            Edit::Tilt {
                layer: Role::Head,
                degrees: 12.0,
            },
        ),
        named(
            "head tilt -12°",
            Edit::Tilt {
                layer: Role::Head,
                degrees: -12.0,
            },
        ),
        named("body squash 0.8", Edit::Squash { factor: 0.8 }),
        named(
            "body wider 15%",
            Edit::Widen {
                layer: Role::Torso,
                factor: 1.15,
            },
        ),
    ];
    for seed in 1..=5 {
        edits.push(named(&format!("drag {seed}"), Edit::Drag { seed, reach: 0.06 }));
    }
    edits
}

/// An edits file (`--edits`): `[[edit]]` tables of [`NamedEdit`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EditsFile {
    /// The edits.
    #[serde(rename = "edit")]
    pub edits: Vec<NamedEdit>,
}

impl EditsFile {
    /// Reads an edits file.
    ///
    /// # Errors
    /// [`Error::Io`]/[`Error::Format`] naming the file; [`Error::Limit`] if it is larger than
    /// [`user_file::CONFIG`].
    pub fn load(path: &Path) -> Result<Vec<NamedEdit>> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses the text of an edits file; `path` only names the file in errors.
    ///
    /// # Errors
    /// [`Error::Format`] naming `path` for bad TOML, an unknown key or no edit.
    pub fn parse(text: &str, path: &Path) -> Result<Vec<NamedEdit>> {
        let file: EditsFile = toml::from_str(text).map_err(|e| Error::format(path, format!("invalid edits file: {e}")))?;
        if file.edits.is_empty() {
            return Err(Error::format(path, "no [[edit]] entries"));
        }
        Ok(file.edits)
    }
}

/// The scores of one way of moving the accessories under one edit.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Scores {
    /// Share of the hidden body outline still covered.
    pub occlusion_kept: f64,
    /// Deepest exposure of the hidden outline, pixels.
    pub deepest_exposure: f64,
    /// Runs of more than 4 px of exposed outline.
    pub leak_blobs: usize,
    /// Share of the outline each accessory hid of the body layer it follows still covered by
    /// those accessories (module doc).
    pub own_occlusion_kept: f64,
    /// Deepest exposure of that outline, pixels.
    pub own_deepest_exposure: f64,
    /// Median over accessories of overlap area after / before.
    pub overlap_retention: f64,
    /// Mean distance between the two places each overlap anchor goes, pixels.
    pub anchor_drift: f64,
    /// Accessory triangles turned over.
    pub inverted: usize,
    /// Enclosed holes in accessories' coverage not there at rest.
    pub new_holes: usize,
    /// 95th percentile of the change of distance between coincident boundaries, pixels (`None`
    /// without coincident constraints).
    pub seam_change_p95: Option<f64>,
    /// 95th percentile of the accessory triangles' larger stretch.
    pub stretch_p95: f64,
}

/// One edit of one character: the rig and the two baselines.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EditReport {
    /// The edit's name.
    pub edit: String,
    /// The accessory rig.
    pub rig: Scores,
    /// Accessories left at rest.
    pub unchanged: Scores,
    /// Accessories stuck to the body under them.
    pub sticker: Scores,
}

/// DAG correctness of one character.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DagScore {
    /// Accessories with a true parent.
    pub judged: usize,
    /// Whose parent is the truth.
    pub strict: usize,
    /// Whose parent is the truth or hangs from it.
    pub lenient: usize,
    /// Accessories whose parent differs from the truth: (layer, chosen, true).
    pub wrong: Vec<(String, String, String)>,
}

/// One way of moving the accessories along a synthetic sequence's true body motion, against
/// the accessories' true places.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MotionScores {
    /// Mean distance of the accessory vertices from their true places, pixels.
    pub accessory_error: f64,
    /// Mean, over frames and accessories, of the IoU of an accessory's coverage with its true
    /// coverage.
    pub accessory_iou: f64,
    /// The worst of the pose scores over the frames.
    pub scores: Scores,
}

/// A synthetic character's accessories along its sequence's true body motion.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionReport {
    /// Frames scored.
    pub frames: usize,
    /// The accessory rig.
    pub rig: MotionScores,
    /// Accessories left at rest.
    pub unchanged: MotionScores,
    /// Accessories stuck to the body under them.
    pub sticker: MotionScores,
    /// The accessories where the generator drew them: what the pose scores are for the true
    /// motion itself (a sleeve swinging with its arm uncovers the torso outline it hid at rest).
    pub truth: Scores,
}

/// One character's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CharacterReport {
    /// The character's folder name.
    pub name: String,
    /// Its layers and accessories.
    pub layers: usize,
    /// Its accessories.
    pub accessories: usize,
    /// DAG correctness, if the character has a truth file.
    pub dag: Option<DagScore>,
    /// Per edit.
    pub edits: Vec<EditReport>,
    /// For a synthetic sequence, along its true motion ([`evaluate_motion`]).
    pub motion: Option<MotionReport>,
}

/// The whole set's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RigReport {
    /// Per character.
    pub characters: Vec<CharacterReport>,
}

/// One character of a rig evaluation set.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Member {
    /// The subfolder's name.
    pub name: String,
    /// The folder holding `character.toml`.
    pub artwork: PathBuf,
    /// For a synthetic sequence (`puppet synth --accessories`), its folder, which holds
    /// `truth.json` and the artwork in `template/`.
    pub sequence: Option<PathBuf>,
}

/// The characters of a set, in name order: every subfolder holding `character.toml`, or a
/// synthetic sequence (`template/character.toml` beside `truth.json`).
///
/// # Errors
/// [`Error::Io`] if `dir` cannot be read; [`Error::Format`] if it holds no character.
pub fn set_members(dir: &Path) -> Result<Vec<Member>> {
    let mut out: Vec<Member> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            if p.join("character.toml").is_file() {
                Some(Member {
                    name,
                    artwork: p,
                    sequence: None,
                })
            } else if p.join("template/character.toml").is_file() && p.join(crate::synth::truth::TRUTH_FILE).is_file() {
                Some(Member {
                    name,
                    artwork: p.join("template"),
                    sequence: Some(p),
                })
            } else {
                None
            }
        })
        .collect();
    out.sort();
    if out.is_empty() {
        return Err(Error::format(
            dir,
            "no character folders (subfolders with character.toml, or synthetic sequences with template/ and truth.json)",
        ));
    }
    Ok(out)
}

/// Scores the rig of `puppet` (rigged, at rest) under `edits`; `truth` judges the DAG.
///
/// # Errors
/// [`Error::Setting`] if the puppet has no rig; errors of an ARAP drag that cannot be set up.
pub fn evaluate_character(
    name: &str,
    puppet: &Puppet,
    truth: Option<&RigTruth>,
    edits: &[NamedEdit],
    progress: &dyn Progress,
) -> Result<CharacterReport> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting(format!("character {name:?}"), "no rig", "a character with accessory layers"))?;
    let scene = Scene::new(puppet, &rig.edges);
    let sticker = Sticker::new(puppet);
    let rest = puppet.rest_vertices();
    let mut reports = Vec::with_capacity(edits.len());
    for edit in edits {
        let body = apply_edit(puppet, &edit.edit)?;
        let rigged = deform(puppet, rig, &body, &DeformOptions::default());
        let mut unchanged = body.clone();
        for k in scene.accessory_vertices() {
            unchanged[k] = rest[k];
        }
        let stuck = sticker.apply(&body);
        reports.push(EditReport {
            edit: edit.name.clone(),
            rig: scene.score(&rigged),
            unchanged: scene.score(&unchanged),
            sticker: scene.score(&stuck),
        });
        progress.advance(1);
    }
    Ok(CharacterReport {
        name: name.to_string(),
        layers: puppet.layers.len(),
        accessories: rig.accessories.len(),
        dag: truth.map(|t| dag_score(puppet, rig, t)),
        edits: reports,
        motion: None,
    })
}

/// Scores the rig of `puppet` (rigged, built from the template of the synthetic sequence whose
/// ground truth is `truth`) along the sequence: in every frame the body takes its true pose, and
/// the accessories placed by the rig, left at rest, or stuck to the body under them are compared
/// with where the generator drew them.
///
/// # Errors
/// [`Error::Setting`] if the puppet has no rig; as [`true_positions`] if a layer is not a part
/// of the truth.
pub fn evaluate_motion(puppet: &Puppet, truth: &Truth, progress: &dyn Progress) -> Result<MotionReport> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting(format!("character {:?}", truth.name), "no rig", "a character with accessory layers"))?;
    let scene = Scene::new(puppet, &rig.edges);
    let motion = Motion::new(puppet, rig, truth);
    let accessory: Vec<usize> = scene.accessory_vertices().collect();
    let mut sums = [[0.0f64; 2]; 3];
    let mut scores: [Vec<Scores>; 3] = Default::default();
    let mut truth_scores = Vec::with_capacity(truth.frames.len());
    progress.stage("true motion", truth.frames.len() as u64);
    for frame in 0..truth.frames.len() {
        let [rigged, unchanged, stuck, true_v] = motion.poses(frame)?;
        let poses = [rigged, unchanged, stuck];
        for (m, pose) in poses.iter().enumerate() {
            let error = accessory.iter().map(|&k| f64::from(dist(pose[k], true_v[k]))).sum::<f64>();
            sums[m][0] += error / accessory.len().max(1) as f64;
            let iou = scene
                .accessories
                .iter()
                .map(|&l| {
                    let (got, want) = (scene.layer_mask(l, pose), scene.layer_mask(l, &true_v));
                    got.and(&want).count() as f64 / got.or(&want).count().max(1) as f64
                })
                .sum::<f64>();
            sums[m][1] += iou / scene.accessories.len().max(1) as f64;
            scores[m].push(scene.score(pose));
        }
        truth_scores.push(scene.score(&true_v));
        progress.advance(1);
    }
    let n = truth.frames.len().max(1) as f64;
    let [rig_scores, unchanged, sticker] = [0, 1, 2].map(|m| MotionScores {
        accessory_error: sums[m][0] / n,
        accessory_iou: sums[m][1] / n,
        scores: Scores::worst(&scores[m]),
    });
    Ok(MotionReport {
        frames: truth.frames.len(),
        rig: rig_scores,
        unchanged,
        sticker,
        truth: Scores::worst(&truth_scores),
    })
}

/// The worst of the rig's scores over whole poses of `puppet` — its body posed by anything
/// (fits, in-betweens, drags), its accessories where the rig (or, on a puppet trained without
/// one, the network) put them; `None` without accessory layers or poses. Attachments are judged
/// against the rig's parents, or on an unrigged puppet against the parents the rig would choose
/// (default DAG options), so both are scored the same way; an unrigged puppet whose DAG cannot
/// be built (an accessory far from every layer) is not scored, with a warning saying why.
pub fn pose_scores(puppet: &Puppet, poses: &[Vec<[f32; 2]>], progress: &dyn Progress) -> Option<Scores> {
    if poses.is_empty() || puppet.layers.iter().all(|l| l.kind == LayerKind::Body) {
        return None;
    }
    let edges = match &puppet.rig {
        Some(rig) => rig.edges.clone(),
        None => {
            let masks: Vec<Mask> = puppet.layers.iter().map(|l| Mask::of_layer(l, 0.5)).collect();
            match layer_dag(puppet, &masks, &RigOverrides::default(), &DagOptions::default(), &Silent) {
                Ok(edges) => edges,
                Err(e) => {
                    progress.warn(&format!("accessories not scored: {e}"));
                    return None;
                }
            }
        }
    };
    let scene = Scene::new(puppet, &edges);
    let scores: Vec<Scores> = poses.iter().map(|p| scene.score(p)).collect();
    Some(Scores::worst(&scores))
}

/// A synthetic sequence's frames posed four ways: the body at its true pose, the accessories
/// placed by the rig, left at rest, stuck to the body under them, and at their true places.
struct Motion<'a> {
    puppet: &'a Puppet,
    rig: &'a RigData,
    truth: &'a Truth,
    sticker: Sticker,
    rest: Vec<[f32; 2]>,
    accessory_vertices: Vec<usize>,
}

impl<'a> Motion<'a> {
    fn new(puppet: &'a Puppet, rig: &'a RigData, truth: &'a Truth) -> Self {
        Motion {
            puppet,
            rig,
            truth,
            sticker: Sticker::new(puppet),
            rest: puppet.rest_vertices(),
            accessory_vertices: puppet.accessory_vertices(),
        }
    }

    /// Frame `frame` as [rig, unchanged, sticker, truth].
    fn poses(&self, frame: usize) -> Result<[Vec<[f32; 2]>; 4]> {
        let true_v = true_positions(self.truth, frame, self.puppet)?;
        let mut unchanged = true_v.clone();
        self.accessory_vertices.iter().for_each(|&k| unchanged[k] = self.rest[k]);
        Ok([
            deform(self.puppet, self.rig, &true_v, &DeformOptions::default()),
            unchanged,
            self.sticker.apply(&true_v),
            true_v,
        ])
    }
}

/// A picture of `puppet` (rigged, from the template of the sequence `truth` describes) along the
/// true motion: `rows` frames spread over the sequence, each drawn with the accessories placed
/// by the rig | where the generator drew them | stuck to the body | left at rest.
///
/// # Errors
/// [`Error::Setting`] without a rig; as [`true_positions`]; render errors.
pub fn motion_sheet(puppet: &Puppet, truth: &Truth, rows: usize) -> Result<crate::picture::Picture> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting("motion sheet", "a puppet without a rig", "a rigged puppet"))?;
    let motion = Motion::new(puppet, rig, truth);
    let scale = (256 / puppet.width.max(puppet.height)).clamp(1, 4);
    let n = truth.frames.len();
    let rows = rows.min(n).max(1);
    let mut cells = Vec::new();
    for r in 0..rows {
        let [rigged, unchanged, stuck, true_v] = motion.poses(r * n / rows)?;
        for pose in [rigged, true_v, stuck, unchanged] {
            cells.push(crate::render::render_crisp(puppet, &pose, puppet.width, puppet.height)?.upscaled_on_white(scale));
        }
    }
    let refs: Vec<&crate::picture::Picture> = cells.iter().collect();
    Ok(crate::picture::contact_sheet(&refs, 4))
}

/// The DAG's parents against the truth.
fn dag_score(puppet: &Puppet, rig: &RigData, truth: &RigTruth) -> DagScore {
    let parent_of = |child: usize| rig.edges.iter().find(|e| e.child == child).map(|e| e.parent);
    let mut score = DagScore::default();
    for (child, want) in &truth.attach_to {
        let (Some(c), Some(w)) = (puppet.layer_index(child), puppet.layer_index(want)) else {
            continue;
        };
        score.judged += 1;
        let Some(got) = parent_of(c) else { continue };
        if got == w {
            score.strict += 1;
            score.lenient += 1;
            continue;
        }
        // Lenient: the chosen parent hangs (through its own parents) from the true one.
        let mut at = got;
        let mut hangs = false;
        for _ in 0..puppet.layers.len() {
            match parent_of(at) {
                Some(p) if p == w => {
                    hangs = true;
                    break;
                }
                Some(p) => at = p,
                None => break,
            }
        }
        score.lenient += usize::from(hangs);
        score.wrong.push((child.clone(), puppet.layers[got].name.clone(), want.clone()));
    }
    score
}

/// The body vertices of `puppet` after `edit` (accessory vertices at rest).
///
/// # Errors
/// As [`arap_drag`] for a drag.
pub fn apply_edit(puppet: &Puppet, edit: &Edit) -> Result<Vec<[f32; 2]>> {
    let mut pose = puppet.rest_vertices();
    let offsets = puppet.vertex_offsets();
    let centroid = |l: usize| {
        let pts = &puppet.layers[l].mesh.vertices;
        let n = pts.len().max(1) as f32;
        pts.iter().fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n])
    };
    match *edit {
        Edit::Widen { layer, factor } => {
            let layers = hanging(puppet, role(puppet, layer));
            let c = centroid(layers[0]);
            for &l in &layers {
                for p in &mut pose[offsets[l]..offsets[l + 1]] {
                    p[0] = c[0] + factor * (p[0] - c[0]);
                }
            }
        }
        Edit::Tilt { layer, degrees } => {
            let l = role(puppet, layer);
            let layers = hanging(puppet, l);
            let pivot = joint_with_parent(puppet, l).map_or_else(|| centroid(l), |v| pose[v]);
            let (s, c) = degrees.to_radians().sin_cos();
            for &l in &layers {
                for p in &mut pose[offsets[l]..offsets[l + 1]] {
                    let d = [p[0] - pivot[0], p[1] - pivot[1]];
                    // Counter-clockwise on screen (y down): a negative angle in maths coordinates.
                    *p = [pivot[0] + c * d[0] + s * d[1], pivot[1] - s * d[0] + c * d[1]];
                }
            }
        }
        Edit::Squash { factor } => {
            let c = centroid(puppet.root);
            for l in body_layers(puppet) {
                for p in &mut pose[offsets[l]..offsets[l + 1]] {
                    p[1] = c[1] + factor * (p[1] - c[1]);
                }
            }
        }
        Edit::Drag { seed, reach } => {
            let mut rng = Rng::new(seed ^ 0xD4A6);
            let movable: Vec<usize> = body_layers(puppet).filter(|&l| l != puppet.root).collect();
            let movable = if movable.is_empty() { vec![puppet.root] } else { movable };
            let size = puppet.width.max(puppet.height) as f32;
            let pins: Vec<(Binding, [f32; 2])> = (0..2)
                .map(|_| {
                    // A layer's vertex nearest its centroid: pulling an interior point moves the
                    // layer smoothly where a boundary vertex would fold it.
                    let l = movable[rng.below(movable.len())];
                    let c = centroid(l);
                    let mesh = &puppet.layers[l].mesh;
                    let v = offsets[l]
                        + (0..mesh.vertices.len())
                            .min_by(|&a, &b| dist(mesh.vertices[a], c).total_cmp(&dist(mesh.vertices[b], c)))
                            .unwrap_or(0);
                    let angle = rng.range(0.0, std::f32::consts::TAU);
                    let to = [pose[v][0] + reach * size * angle.cos(), pose[v][1] + reach * size * angle.sin()];
                    // The vertex itself, as a binding with all its weight on it.
                    let binding = Binding {
                        layer: l,
                        vertices: [v as u32; 3],
                        weights: [1.0, 0.0, 0.0],
                    };
                    (binding, to)
                })
                .collect();
            let dragged = arap_drag(puppet, &pose, &pins)?;
            for l in body_layers(puppet) {
                pose[offsets[l]..offsets[l + 1]].copy_from_slice(&dragged[offsets[l]..offsets[l + 1]]);
            }
        }
    }
    Ok(pose)
}

fn body_layers(puppet: &Puppet) -> impl Iterator<Item = usize> + '_ {
    (0..puppet.layers.len()).filter(|&l| puppet.layers[l].kind == LayerKind::Body)
}

/// The body layer playing `role` (doc of [`Role`]).
fn role(puppet: &Puppet, role: Role) -> usize {
    let head = body_layers(puppet)
        .min_by(|&a, &b| top(puppet, a).total_cmp(&top(puppet, b)))
        .unwrap_or(puppet.root);
    match role {
        Role::Head => head,
        Role::Torso if puppet.root != head => puppet.root,
        Role::Torso => body_layers(puppet)
            .filter(|&l| l != head)
            .max_by(|&a, &b| puppet.layers[a].mesh.area().total_cmp(&puppet.layers[b].mesh.area()))
            .unwrap_or(head),
    }
}

/// The mean y of a layer's rest vertices.
fn top(puppet: &Puppet, l: usize) -> f32 {
    let v = &puppet.layers[l].mesh.vertices;
    v.iter().map(|p| p[1]).sum::<f32>() / v.len().max(1) as f32
}

/// `layer` and the body layers hanging from it (through joints, away from the torso).
fn hanging(puppet: &Puppet, layer: usize) -> Vec<usize> {
    let tree = body_tree(puppet);
    let mut out = vec![layer];
    let mut k = 0;
    while k < out.len() {
        let l = out[k];
        out.extend((0..puppet.layers.len()).filter(|&c| tree[c] == Some(l)));
        k += 1;
    }
    out
}

/// Each body layer's parent in the joint tree rooted at the torso (breadth first).
fn body_tree(puppet: &Puppet) -> Vec<Option<usize>> {
    let n = puppet.layers.len();
    let torso = role(puppet, Role::Torso);
    let mut parent = vec![None; n];
    let mut seen = vec![false; n];
    seen[torso] = true;
    let mut queue = vec![torso];
    let mut k = 0;
    while k < queue.len() {
        let l = queue[k];
        for j in &puppet.joints {
            for (a, b) in [(j.a.layer, j.b.layer), (j.b.layer, j.a.layer)] {
                if a == l && !seen[b] && puppet.layers[b].kind == LayerKind::Body {
                    seen[b] = true;
                    parent[b] = Some(l);
                    queue.push(b);
                }
            }
        }
        k += 1;
    }
    parent
}

/// The global index of `layer`'s vertex at its joint with its parent in the body tree.
fn joint_with_parent(puppet: &Puppet, layer: usize) -> Option<usize> {
    let parent = body_tree(puppet)[layer]?;
    puppet.joints.iter().find_map(|j| {
        if j.a.layer == layer && j.b.layer == parent {
            Some(puppet.global_index(j.a))
        } else if j.b.layer == layer && j.a.layer == parent {
            Some(puppet.global_index(j.b))
        } else {
            None
        }
    })
}

/// The sticker baseline's bindings: each accessory vertex in the front-most body layer under it
/// (or off the nearest body layer, keeping its offset from that layer's nearest point).
struct Sticker {
    /// (global accessory vertex, the body point it follows, its offset from that point at rest).
    bound: Vec<(usize, Bound, [f32; 2])>,
}

impl Sticker {
    fn new(puppet: &Puppet) -> Self {
        let offsets = puppet.vertex_offsets();
        let bodies: Vec<usize> = body_layers(puppet).collect();
        let rest = puppet.rest_vertices();
        let mut bound = Vec::new();
        for (l, layer) in puppet.layers.iter().enumerate() {
            if layer.kind == LayerKind::Body {
                continue;
            }
            for (v, &p) in layer.mesh.vertices.iter().enumerate() {
                let holding = bodies.iter().rev().find(|&&b| {
                    let m = &puppet.layers[b].mesh;
                    m.triangles
                        .iter()
                        .any(|t| crate::geom::triangle::contains(t.map(|i| m.vertices[i as usize]), p, 0.0))
                });
                let b = holding.copied().unwrap_or_else(|| {
                    *bodies
                        .iter()
                        .min_by(|&&x, &&y| nearest(puppet, x, p).total_cmp(&nearest(puppet, y, p)))
                        .expect("a puppet has a body layer")
                });
                let (t, w) = bind_point(&puppet.layers[b].mesh, p);
                let tri = puppet.layers[b].mesh.triangles[t as usize].map(|i| offsets[b] + i as usize);
                let at = position(&(tri, w), &rest);
                bound.push((offsets[l] + v, (tri, w), [p[0] - at[0], p[1] - at[1]]));
            }
        }
        Sticker { bound }
    }

    fn apply(&self, body: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let mut out = body.to_vec();
        for (v, point, offset) in &self.bound {
            let at = position(point, body);
            out[*v] = [at[0] + offset[0], at[1] + offset[1]];
        }
        out
    }
}

/// The distance from `p` to the nearest vertex of layer `l`.
fn nearest(puppet: &Puppet, l: usize, p: [f32; 2]) -> f32 {
    puppet.layers[l]
        .mesh
        .vertices
        .iter()
        .map(|q| (q[0] - p[0]).hypot(q[1] - p[1]))
        .fold(f32::INFINITY, f32::min)
}

/// A point bound to a layer's rest mesh: its triangle's corners (global numbering), barycentric
/// weights.
type Bound = ([usize; 3], [f32; 3]);

/// An accessory's attachment to its parent at rest.
struct Attachment {
    child: usize,
    parent: usize,
    /// Pixels the two share at rest.
    overlap: usize,
    /// Up to 16 points of the shared region, bound to the child and to the parent.
    anchors: Vec<(Bound, Bound)>,
}

/// A body layer's outline samples hidden at rest by a set of accessories.
struct Hidden {
    /// The accessories that hide them.
    cover: Vec<usize>,
    /// Runs of hidden samples (in outline order), each bound to the layer's rest mesh as
    /// (triangle corners, global numbering; weights).
    rings: Vec<Vec<Bound>>,
    /// Samples over all runs.
    count: usize,
}

/// Layer `l`'s triangles (corner positions) in `pose`, its vertices from global index `offset`.
fn placed_triangles(puppet: &Puppet, l: usize, pose: &[[f32; 2]], offset: usize) -> Vec<[[f32; 2]; 3]> {
    puppet.layers[l]
        .mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| pose[offset + i as usize]))
        .collect()
}

/// Where a bound point is in `pose`.
fn position((tri, w): &Bound, pose: &[[f32; 2]]) -> [f32; 2] {
    [0, 1].map(|c| w[0] * pose[tri[0]][c] + w[1] * pose[tri[1]][c] + w[2] * pose[tri[2]][c])
}

/// How much of some hidden outline a pose keeps covered.
struct Covered {
    /// Share of the samples covered (1 without samples).
    share: f64,
    /// Deepest exposure, pixels.
    deepest: f64,
    /// Runs of more than 4 uncovered samples.
    blobs: usize,
    /// Where the uncovered samples are, pixels.
    exposed: Vec<[f32; 2]>,
}

/// Carries each sample of `groups` by the pose (`at`) and checks it against the union of its
/// group's accessory triangles in that pose (`placed`): exactly, not on pixels, so a motion
/// smaller than a pixel does not flip a sample that lies near a pixel's edge.
fn covered(groups: &[Hidden], placed: &dyn Fn(usize) -> Vec<[[f32; 2]; 3]>, at: &dyn Fn(&Bound) -> [f32; 2]) -> Covered {
    let (mut kept, mut total, mut deepest, mut blobs) = (0usize, 0usize, 0.0f64, 0usize);
    let mut exposed = Vec::new();
    for group in groups {
        total += group.count;
        let cover = TriangleGrid::new(group.cover.iter().flat_map(|&a| placed(a)).collect(), COVER_CELL);
        for ring in &group.rings {
            let mut run = 0usize;
            for bound in ring {
                let q = at(bound);
                if cover.covers(q) {
                    kept += 1;
                    blobs += usize::from(run > 4);
                    run = 0;
                } else {
                    run += 1;
                    deepest = deepest.max(f64::from(cover.distance(q)));
                    exposed.push(q);
                }
            }
            blobs += usize::from(run > 4);
        }
    }
    Covered {
        share: if total == 0 { 1.0 } else { kept as f64 / total as f64 },
        deepest,
        blobs,
        exposed,
    }
}

/// Grid cell (pixels) of the accessory triangles the occlusion samples are checked against.
const COVER_CELL: f32 = 4.0;

/// How deep under its accessories an outline sample must lie at rest to count as hidden
/// (pixels). A sample within half a pixel of the cover's rim shares its pixel with the rim: the
/// artwork does not hide it, it draws the accessory's edge along it (a cap drawn to the head's
/// curve), and any motion at all, even a rigid one rounded differently, would "expose" it.
const HIDDEN_MARGIN: f32 = 0.5;

/// What the metrics measure against, prepared once per character at rest.
struct Scene<'a> {
    puppet: &'a Puppet,
    offsets: Vec<usize>,
    accessories: Vec<usize>,
    /// Per body layer, its outline hidden by the accessories in front of it.
    hidden: Vec<Hidden>,
    /// Per body layer, its outline hidden by the accessories that follow it.
    own: Vec<Hidden>,
    /// Per accessory, its attachment to its first parent.
    attachments: Vec<Attachment>,
    /// Coincident seams: a child point, the parent point nearest it, their rest distance.
    seams: Vec<(Bound, Bound, f32)>,
    /// Per accessory, the holes of its coverage at rest.
    rest_holes: Vec<usize>,
}

impl<'a> Scene<'a> {
    fn new(puppet: &'a Puppet, edges: &[RigEdge]) -> Self {
        let offsets = puppet.vertex_offsets();
        let masks: Vec<Mask> = puppet.layers.iter().map(|l| Mask::of_layer(l, 0.5)).collect();
        let accessories: Vec<usize> = (0..puppet.layers.len())
            .filter(|&l| puppet.layers[l].kind == LayerKind::Accessory)
            .collect();
        let bind = |l: usize, p: [f32; 2]| {
            let (t, w) = bind_point(&puppet.layers[l].mesh, p);
            (puppet.layers[l].mesh.triangles[t as usize].map(|i| offsets[l] + i as usize), w)
        };
        let rest = puppet.rest_vertices();
        let at_rest = |bound: &Bound| position(bound, &rest);
        // What covers at rest is what the meshes cover (within the mesher's tolerance of the
        // artwork), so an unedited pose keeps every sample and every overlap.
        let mesh_mask = |l: usize| {
            let m = &puppet.layers[l].mesh;
            Mask::of_triangles(&m.vertices, &m.triangles, puppet.width, puppet.height)
        };
        // The body layer each accessory follows, through its first parents.
        let follows = |a: usize| {
            let mut at = a;
            for _ in 0..puppet.layers.len() {
                if puppet.layers[at].kind == LayerKind::Body {
                    return Some(at);
                }
                at = edges.iter().find(|e| e.child == at)?.parent;
            }
            None
        };
        let hidden_by = |b: usize, cover: Vec<usize>| {
            let front = TriangleGrid::new(
                cover.iter().flat_map(|&a| placed_triangles(puppet, a, &rest, offsets[a])).collect(),
                COVER_CELL,
            );
            let (mut ring, mut rings, mut count) = (Vec::new(), Vec::new(), 0);
            for s in masks[b].outline(1.0) {
                // Judged where the score will look for it: an outline pixel just outside the
                // layer's mesh is bound to the mesh's nearest point, and that point is the sample.
                let bound = bind(b, s);
                if front.covers_disc(at_rest(&bound), HIDDEN_MARGIN) {
                    ring.push(bound);
                    count += 1;
                } else if !ring.is_empty() {
                    rings.push(std::mem::take(&mut ring));
                }
            }
            if !ring.is_empty() {
                rings.push(ring);
            }
            (count > 0).then_some(Hidden { cover, rings, count })
        };
        let (mut hidden, mut own) = (Vec::new(), Vec::new());
        for b in body_layers(puppet) {
            let front: Vec<usize> = accessories.iter().copied().filter(|&a| a > b).collect();
            let following: Vec<usize> = front.iter().copied().filter(|&a| follows(a) == Some(b)).collect();
            hidden.extend(hidden_by(b, front));
            own.extend(hidden_by(b, following));
        }
        let mut attachments = Vec::new();
        let mut seams = Vec::new();
        for e in edges {
            let (c, p) = (e.child, e.parent);
            if !attachments.iter().any(|a: &Attachment| a.child == c) {
                let shared = masks[c].and(&masks[p]);
                let pixels: Vec<usize> = (0..shared.inside.len()).filter(|&i| shared.inside[i]).collect();
                let anchors = (0..16.min(pixels.len()))
                    .map(|k| {
                        let q = shared.centre(pixels[k * pixels.len() / 16.min(pixels.len())]);
                        (bind(c, q), bind(p, q))
                    })
                    .collect();
                attachments.push(Attachment {
                    child: c,
                    parent: p,
                    // Counted as the score counts it, on the meshes, so a pose that moves
                    // nothing retains exactly 1.
                    overlap: mesh_mask(c).and(&mesh_mask(p)).count(),
                    anchors,
                });
            }
            if e.constraints.contains(&Constraint::Coincident) {
                let parent_edge = masks[p].outline(1.0);
                for q in masks[c].outline(2.0) {
                    if let Some(r) = parent_edge
                        .iter()
                        .copied()
                        .min_by(|a, b| dist(*a, q).total_cmp(&dist(*b, q)))
                        .filter(|r| dist(*r, q) <= 1.0)
                    {
                        seams.push((bind(c, q), bind(p, r), dist(q, r)));
                    }
                }
            }
        }
        let rest_holes = accessories.iter().map(|&a| fine_holes(puppet, a, &rest, offsets[a])).collect();
        Scene {
            puppet,
            offsets,
            accessories,
            hidden,
            own,
            attachments,
            seams,
            rest_holes,
        }
    }

    fn accessory_vertices(&self) -> impl Iterator<Item = usize> + '_ {
        self.accessories.iter().flat_map(|&l| self.offsets[l]..self.offsets[l + 1])
    }

    fn layer_mask(&self, l: usize, pose: &[[f32; 2]]) -> Mask {
        let p = self.puppet;
        Mask::of_triangles(
            &pose[self.offsets[l]..self.offsets[l + 1]],
            &p.layers[l].mesh.triangles,
            p.width,
            p.height,
        )
    }

    /// Where `pose` uncovers outline its accessories hid at rest, pixels.
    fn exposed(&self, pose: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let placed = |a: usize| placed_triangles(self.puppet, a, pose, self.offsets[a]);
        covered(&self.hidden, &placed, &|bound: &Bound| position(bound, pose)).exposed
    }

    fn score(&self, pose: &[[f32; 2]]) -> Scores {
        let at = |bound: &Bound| position(bound, pose);
        let masks: BTreeMap<usize, Mask> = self.accessories.iter().map(|&a| (a, self.layer_mask(a, pose))).collect();
        let placed = |a: usize| placed_triangles(self.puppet, a, pose, self.offsets[a]);
        let occlusion = covered(&self.hidden, &placed, &at);
        let own = covered(&self.own, &placed, &at);
        let mut retention = Vec::new();
        let mut drift = Vec::new();
        for a in &self.attachments {
            if a.overlap > 0 {
                let parent = masks.get(&a.parent).cloned().unwrap_or_else(|| self.layer_mask(a.parent, pose));
                retention.push(masks[&a.child].and(&parent).count() as f64 / a.overlap as f64);
            }
            drift.extend(a.anchors.iter().map(|(x, y)| f64::from(dist(at(x), at(y)))));
        }
        let (mut inverted, mut stretch) = (0usize, Vec::new());
        for &l in &self.accessories {
            let mesh = &self.puppet.layers[l].mesh;
            for t in &mesh.triangles {
                let r = t.map(|i| mesh.vertices[i as usize]);
                let d = t.map(|i| pose[self.offsets[l] + i as usize]);
                let area = |c: [[f32; 2]; 3]| (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
                if area(d) * area(r).signum() <= 0.0 {
                    inverted += 1;
                }
                stretch.push(largest_stretch(r, d));
            }
        }
        let seam_change: Vec<f64> = self
            .seams
            .iter()
            .map(|(a, b, rest)| f64::from((dist(at(a), at(b)) - rest).abs()))
            .collect();
        Scores {
            occlusion_kept: occlusion.share,
            deepest_exposure: occlusion.deepest,
            leak_blobs: occlusion.blobs,
            own_occlusion_kept: own.share,
            own_deepest_exposure: own.deepest,
            overlap_retention: median(&mut retention),
            anchor_drift: if drift.is_empty() {
                0.0
            } else {
                drift.iter().sum::<f64>() / drift.len() as f64
            },
            inverted,
            new_holes: self
                .accessories
                .iter()
                .zip(&self.rest_holes)
                .map(|(&a, &before)| fine_holes(self.puppet, a, pose, self.offsets[a]).saturating_sub(before))
                .sum(),
            seam_change_p95: (!seam_change.is_empty()).then(|| percentile(&mut seam_change.clone(), 0.95)),
            stretch_p95: percentile(&mut stretch, 0.95),
        }
    }
}

/// Enclosed holes in the coverage of layer `l` (its vertices from global index `offset`) in
/// `pose`, rasterised at [`HOLE_SUPERSAMPLING`] times the canvas resolution: at the canvas's
/// own, a stroke of line art thinner than a pixel in places is rasterised with gaps, which open
/// and close as it moves (a glasses frame whose lens is enclosed in one pose and not the next).
fn fine_holes(puppet: &Puppet, l: usize, pose: &[[f32; 2]], offset: usize) -> usize {
    let mesh = &puppet.layers[l].mesh;
    holes_of_triangles(
        &mesh.triangles,
        &pose[offset..offset + mesh.vertices.len()],
        puppet.width,
        puppet.height,
    )
}

/// [`fine_holes`] of a mesh placed at `placed` on a `width` × `height` canvas.
fn holes_of_triangles(triangles: &[[u32; 3]], placed: &[[f32; 2]], width: u32, height: u32) -> usize {
    let k = HOLE_SUPERSAMPLING as f32;
    // Rasterised over the layer's bounding box, with a free pixel round it: a piece of the
    // complement that reaches the box's rim is open to the outside, as one reaching the
    // canvas's edge would be.
    let (lo, hi) = placed.iter().fold(([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    let clip = |x: f32, n: u32| (x * k).clamp(0.0, (n as f32) * k);
    let origin = [clip(lo[0], width).floor() - 1.0, clip(lo[1], height).floor() - 1.0];
    let size = |h: f32, n: u32, o: f32| (clip(h, n).ceil() - o + 2.0).max(1.0) as u32;
    let (w, h) = (size(hi[0], width, origin[0]), size(hi[1], height, origin[1]));
    let scaled: Vec<[f32; 2]> = placed.iter().map(|p| [p[0] * k - origin[0], p[1] * k - origin[1]]).collect();
    holes(&Mask::of_triangles(&scaled, triangles, w, h))
}

/// Samples per canvas pixel, per axis, of the coverage that holes are counted in.
const HOLE_SUPERSAMPLING: u32 = 4;

/// Enclosed holes of a coverage mask: pieces of its complement that do not touch the canvas edge.
fn holes(silhouette: &Mask) -> usize {
    let complement = Mask {
        width: silhouette.width,
        height: silhouette.height,
        inside: silhouette.inside.iter().map(|&i| !i).collect(),
    };
    let (w, h) = (silhouette.width as usize, silhouette.height as usize);
    complement
        .pieces()
        .iter()
        .filter(|piece| piece.iter().all(|&i| i % w != 0 && i % w != w - 1 && i / w != 0 && i / w != h - 1))
        .count()
}

/// The larger singular value of the affine map taking triangle `r` to `d`.
fn largest_stretch(r: [[f32; 2]; 3], d: [[f32; 2]; 3]) -> f64 {
    let e = |t: [[f32; 2]; 3]| [[t[1][0] - t[0][0], t[2][0] - t[0][0]], [t[1][1] - t[0][1], t[2][1] - t[0][1]]];
    let (a, b) = (e(r), e(d));
    let det = f64::from(a[0][0] * a[1][1] - a[0][1] * a[1][0]);
    if det.abs() < 1e-12 {
        return 1.0;
    }
    // F = B A⁻¹.
    let inv = [
        [f64::from(a[1][1]) / det, -f64::from(a[0][1]) / det],
        [-f64::from(a[1][0]) / det, f64::from(a[0][0]) / det],
    ];
    let f = [0, 1].map(|i| [0, 1].map(|j| f64::from(b[i][0]) * inv[0][j] + f64::from(b[i][1]) * inv[1][j]));
    let (p, q, r2, s) = (f[0][0], f[0][1], f[1][0], f[1][1]);
    let sum = p * p + q * q + r2 * r2 + s * s;
    let det_f = p * s - q * r2;
    ((sum + (sum * sum - 4.0 * det_f * det_f).max(0.0).sqrt()) / 2.0).sqrt()
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 1.0;
    }
    percentile(values, 0.5)
}

/// The `q` quantile (nearest rank) of `values` (0 for none).
fn percentile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let k = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len()) - 1;
    values[k]
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

impl Scores {
    /// The worst of `scores`, score by score: the lowest shares, the largest distances and
    /// stretches, and the counts summed — how one way of moving accessories did over a
    /// character's edits, or over the set.
    pub fn worst<'a>(scores: impl IntoIterator<Item = &'a Scores>) -> Self {
        let mut s = Scores {
            occlusion_kept: 1.0,
            own_occlusion_kept: 1.0,
            overlap_retention: f64::INFINITY,
            ..Scores::default()
        };
        for x in scores {
            s.occlusion_kept = s.occlusion_kept.min(x.occlusion_kept);
            s.deepest_exposure = s.deepest_exposure.max(x.deepest_exposure);
            s.leak_blobs += x.leak_blobs;
            s.own_occlusion_kept = s.own_occlusion_kept.min(x.own_occlusion_kept);
            s.own_deepest_exposure = s.own_deepest_exposure.max(x.own_deepest_exposure);
            s.overlap_retention = s.overlap_retention.min(x.overlap_retention);
            s.anchor_drift = s.anchor_drift.max(x.anchor_drift);
            s.inverted += x.inverted;
            s.new_holes += x.new_holes;
            s.seam_change_p95 = match (s.seam_change_p95, x.seam_change_p95) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            s.stretch_p95 = s.stretch_p95.max(x.stretch_p95);
        }
        if s.overlap_retention.is_infinite() {
            s.overlap_retention = 1.0;
        }
        s
    }

    /// The column titles of [`Scores::row`].
    pub fn header() -> String {
        format!(
            "{:>9} {:>7} {:>5} {:>8} {:>8} {:>7} {:>6} {:>5} {:>5} {:>7} {:>7}",
            "occl.kept", "deepest", "leaks", "own.kept", "own.deep", "overlap", "drift", "inv", "holes", "seam95", "stretch"
        )
    }

    /// One row of the report table.
    pub fn row(&self) -> String {
        format!(
            "{:>8.2}% {:>7.2} {:>5} {:>7.2}% {:>8.2} {:>7.3} {:>6.2} {:>5} {:>5} {:>7} {:>7.2}",
            100.0 * self.occlusion_kept,
            self.deepest_exposure,
            self.leak_blobs,
            100.0 * self.own_occlusion_kept,
            self.own_deepest_exposure,
            self.overlap_retention,
            self.anchor_drift,
            self.inverted,
            self.new_holes,
            self.seam_change_p95.map_or("-".into(), |v| format!("{v:.2}")),
            self.stretch_p95
        )
    }
}

impl RigReport {
    /// DAG correctness over the set: (judged, strict, lenient).
    pub fn dag(&self) -> (usize, usize, usize) {
        self.characters
            .iter()
            .filter_map(|c| c.dag.as_ref())
            .fold((0, 0, 0), |(j, s, l), d| (j + d.judged, s + d.strict, l + d.lenient))
    }

    /// The report as a table: per character and over the set, each way of moving accessories.
    pub fn table(&self) -> String {
        let header = format!("{:<22} {:>9} | {:<9} {}\n", "character", "DAG s/l", "method", Scores::header());
        let mut out = header;
        fn method(report: &EditReport, k: usize) -> &Scores {
            match k {
                0 => &report.rig,
                1 => &report.sticker,
                _ => &report.unchanged,
            }
        }
        let names = ["rig", "sticker", "unchanged"];
        for c in &self.characters {
            let dag = c
                .dag
                .as_ref()
                .map_or("-".to_string(), |d| format!("{}/{}/{}", d.strict, d.lenient, d.judged));
            for (k, name) in names.iter().enumerate() {
                let summary = Scores::worst(c.edits.iter().map(|e| method(e, k)));
                let label = if k == 0 { c.name.as_str() } else { "" };
                let dag = if k == 0 { dag.as_str() } else { "" };
                out.push_str(&format!("{label:<22} {dag:>9} | {name:<9} {}\n", summary.row()));
            }
        }
        let (judged, strict, lenient) = self.dag();
        for (k, name) in names.iter().enumerate() {
            let summary = Scores::worst(self.characters.iter().flat_map(|c| c.edits.iter().map(move |e| method(e, k))));
            let label = if k == 0 { "all" } else { "" };
            let dag = if k == 0 {
                format!("{strict}/{lenient}/{judged}")
            } else {
                String::new()
            };
            out.push_str(&format!("{label:<22} {dag:>9} | {name:<9} {}\n", summary.row()));
        }
        let motions: Vec<(&str, &MotionReport)> = self
            .characters
            .iter()
            .filter_map(|c| c.motion.as_ref().map(|m| (c.name.as_str(), m)))
            .collect();
        if !motions.is_empty() {
            out.push_str(&format!(
                "\n{:<22} {:>9} | {:<9} {:>6} {:>6} {}\n",
                "true motion",
                "frames",
                "method",
                "acc.px",
                "IoU",
                Scores::header()
            ));
            fn pick(m: &MotionReport, k: usize) -> &MotionScores {
                match k {
                    0 => &m.rig,
                    1 => &m.sticker,
                    _ => &m.unchanged,
                }
            }
            for (name, m) in &motions {
                let truth = MotionScores {
                    accessory_error: 0.0,
                    accessory_iou: 1.0,
                    scores: m.truth.clone(),
                };
                for (k, method) in names.iter().chain(&["truth"]).enumerate() {
                    let s = if k < names.len() { pick(m, k) } else { &truth };
                    let (label, frames) = if k == 0 {
                        (*name, m.frames.to_string())
                    } else {
                        ("", String::new())
                    };
                    out.push_str(&format!(
                        "{label:<22} {frames:>9} | {method:<9} {:>6.2} {:>6.3} {}\n",
                        s.accessory_error,
                        s.accessory_iou,
                        s.scores.row()
                    ));
                }
            }
        }
        out
    }
}

/// A picture of `puppet` under the first `rows` of `edits`: per row, the edit with the rig |
/// with the sticker baseline | with the accessories unchanged, the hidden outline each uncovers
/// dotted in red.
///
/// # Errors
/// As [`apply_edit`]; render errors.
pub fn edit_sheet(puppet: &Puppet, edits: &[NamedEdit], rows: usize) -> Result<crate::picture::Picture> {
    let rig = puppet
        .rig
        .as_ref()
        .ok_or_else(|| Error::setting("edit sheet", "a puppet without a rig", "a rigged puppet"))?;
    let sticker = Sticker::new(puppet);
    let scene = Scene::new(puppet, &rig.edges);
    let rest = puppet.rest_vertices();
    let accessory_vertices = puppet.accessory_vertices();
    let scale = (256 / puppet.width.max(puppet.height)).clamp(1, 4);
    let mut cells = Vec::new();
    for edit in edits.iter().take(rows) {
        let body = apply_edit(puppet, &edit.edit)?;
        let rigged = deform(puppet, rig, &body, &DeformOptions::default());
        let mut unchanged = body.clone();
        accessory_vertices.iter().for_each(|&k| unchanged[k] = rest[k]);
        for pose in [rigged, sticker.apply(&body), unchanged] {
            let mut cell = crate::render::render_crisp(puppet, &pose, puppet.width, puppet.height)?.upscaled_on_white(scale);
            let s = scale as f32;
            for q in scene.exposed(&pose) {
                crate::picture::draw::dot(&mut cell, [q[0] * s, q[1] * s], (0.5 * s).max(1.0), [0.9, 0.1, 0.1]);
            }
            cells.push(cell);
        }
    }
    let refs: Vec<&crate::picture::Picture> = cells.iter().collect();
    Ok(crate::picture::contact_sheet(&refs, 3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unrigged_dressed_puppet_is_scored_against_the_dag_the_rig_would_choose_or_warned_about() {
        use crate::progress::Recorder;
        use crate::test_util::{layered_puppet, rect_layer, stripes};
        let mut p = layered_puppet();
        let arm = p.layer_index("arm_front").unwrap();
        p.layers[arm].kind = LayerKind::Accessory;
        let rest = p.rest_vertices();
        let recorder = Recorder::default();
        let at_rest = pose_scores(&p, std::slice::from_ref(&rest), &recorder).expect("scored");
        assert_eq!(at_rest.occlusion_kept, 1.0, "{at_rest:?}");
        // The sleeve moved 6 px off the torso: outline it hid is uncovered.
        let offsets = p.vertex_offsets();
        let mut moved = rest;
        for v in &mut moved[offsets[arm]..offsets[arm + 1]] {
            v[1] += 6.0;
        }
        let off = pose_scores(&p, &[moved], &recorder).expect("scored");
        assert!(off.occlusion_kept < 0.9 && off.deepest_exposure >= 2.0, "{off:?}");
        assert!(recorder.warnings().is_empty(), "{:?}", recorder.warnings());
        // A patch far from every layer: no DAG, so no scores — and a warning naming it.
        let mut far = rect_layer("patch", (p.width, p.height), [0.0, 37.0, 3.0, 40.0], (1, 1), stripes([0.5; 3], 4.0));
        far.kind = LayerKind::Accessory;
        let mut p = layered_puppet();
        p.layers.push(far);
        let rest = p.rest_vertices();
        assert!(pose_scores(&p, &[rest], &recorder).is_none());
        let warnings = recorder.warnings();
        assert!(warnings.len() == 1 && warnings[0].contains("patch"), "{warnings:?}");
    }

    #[test]
    fn a_frame_thinner_than_a_pixel_encloses_its_hole_wherever_it_lies() {
        // A square frame 0.6 px wide round [x0, x0 + 12]²: four bars, two triangles each.
        let frame = |x0: f32| {
            let (a, b, c, d) = (x0, x0 + 0.6, x0 + 11.4, x0 + 12.0);
            let bars = [[a, a, d, b], [a, c, d, d], [a, a, b, d], [c, a, d, d]];
            let mut vertices = Vec::new();
            let mut triangles = Vec::new();
            for [x1, y1, x2, y2] in bars {
                let k = vertices.len() as u32;
                vertices.extend([[x1, y1], [x2, y1], [x2, y2], [x1, y2]]);
                triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
            }
            (vertices, triangles)
        };
        for x0 in [2.0, 2.3, 2.6, 2.9] {
            let (vertices, triangles) = frame(x0);
            assert_eq!(holes_of_triangles(&triangles, &vertices, 20, 20), 1, "frame at {x0}");
        }
        // At the canvas's own resolution the frame at 2.6 covers no pixel centre of its left
        // and top bars, and encloses nothing.
        let (vertices, triangles) = frame(2.6);
        assert_eq!(holes(&Mask::of_triangles(&vertices, &triangles, 20, 20)), 0);
    }

    #[test]
    fn an_edits_file_reads_back_the_suite_and_refuses_an_unknown_key() {
        let path = Path::new("edits.toml");
        let text = toml::to_string(&EditsFile { edits: default_edits() }).unwrap();
        assert_eq!(EditsFile::parse(&text, path).unwrap(), default_edits());
        let typo = "[[edit]]\nname = \"t\"\nkind = \"tilt\"\nlayer = \"head\"\ndegree = 12.0\n";
        let err = EditsFile::parse(typo, path).unwrap_err().to_string();
        assert!(err.contains("edits.toml") && err.contains("degree"), "{err}");
    }
}
