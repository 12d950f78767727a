//! The suite of body edits `puppet eval-rig` scores rigs under, its file, and how an edit moves
//! a puppet's body (layers chosen by geometry, never by name).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::edit::arap_drag::arap_drag;
use crate::edit::bind::Binding;
use crate::error::{Error, Result};
use crate::puppet::{LayerKind, Puppet};
use crate::rng::Rng;
use crate::user_file;

/// A body layer an edit acts on, found by geometry, not by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EditRole {
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
        layer: EditRole,
        /// The factor.
        factor: f32,
    },
    /// Turn a layer (and the body layers hanging from it) about its joint with its parent.
    Tilt {
        /// Which layer.
        layer: EditRole,
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
                layer: EditRole::Head,
                factor: 1.1,
            },
        ),
        named(
            "head wider 20%",
            Edit::Widen {
                layer: EditRole::Head,
                factor: 1.2,
            },
        ),
        named(
            "head tilt +12°",
            Edit::Tilt {
                layer: EditRole::Head,
                degrees: 12.0,
            },
        ),
        named(
            "head tilt -12°",
            Edit::Tilt {
                layer: EditRole::Head,
                degrees: -12.0,
            },
        ),
        named("body squash 0.8", Edit::Squash { factor: 0.8 }),
        named(
            "body wider 15%",
            Edit::Widen {
                layer: EditRole::Torso,
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
                    let from_centre = |v: usize| (mesh.vertices[v][0] - c[0]).hypot(mesh.vertices[v][1] - c[1]);
                    let v = offsets[l]
                        + (0..mesh.vertices.len())
                            .min_by(|&a, &b| from_centre(a).total_cmp(&from_centre(b)))
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

pub(super) fn body_layers(puppet: &Puppet) -> impl Iterator<Item = usize> + '_ {
    (0..puppet.layers.len()).filter(|&l| puppet.layers[l].kind == LayerKind::Body)
}

/// The body layer playing `role` (doc of [`EditRole`]).
fn role(puppet: &Puppet, role: EditRole) -> usize {
    let head = body_layers(puppet)
        .min_by(|&a, &b| top(puppet, a).total_cmp(&top(puppet, b)))
        .unwrap_or(puppet.root);
    match role {
        EditRole::Head => head,
        EditRole::Torso if puppet.root != head => puppet.root,
        EditRole::Torso => body_layers(puppet)
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
    let torso = role(puppet, EditRole::Torso);
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

#[cfg(test)]
mod tests {
    use super::*;

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
