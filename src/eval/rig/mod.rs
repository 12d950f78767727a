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
//!
//! `edits.rs` holds the suite and applies it, `scene.rs` the metrics, `sticker.rs` the baseline
//! of that name, `motion.rs` the synthetic sequences' true motion, `report.rs` the scores and
//! their table.

mod edits;
mod motion;
mod report;
mod scene;
mod sticker;

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::progress::{Progress, Silent};
use crate::puppet::rig_data::{RigData, RigOverrides};
use crate::puppet::{LayerKind, Puppet};
use crate::rig::dag::{layer_dag, DagOptions};
use crate::rig::deform::{deform, DeformOptions};
use crate::rig::mask::Mask;
use crate::user_file;
pub use edits::{apply_edit, default_edits, Edit, EditRole, EditsFile, NamedEdit};
pub use motion::{evaluate_motion, motion_sheet};
pub use report::{CharacterReport, DagScore, EditReport, Member, MotionReport, MotionScores, RigReport, Scores};
use scene::Scene;
use sticker::Sticker;

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
}
