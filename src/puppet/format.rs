//! `puppet.json`: the puppet on disk (DESIGN.md "Formats"), versioned, beside one PNG texture per
//! layer in `textures/`. Saving then loading gives back an identical [`Puppet`]: positions are
//! f32 written in shortest round-trip form, textures are 8-bit like the artwork they came from.
//! Schema 2 adds the optional `rig` section (its own version inside), layers named as in joints;
//! schema 1 files (no rig) still load.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::rig_data::{AccessoryRig, Constraint, Origin, RigData, RigEdge, RigPin, Skinning};
use super::{Joint, Layer, LayerKind, Mesh, Puppet, VertexRef};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::user_file;

/// The schema version this build writes and the newest it reads.
pub const SCHEMA_VERSION: u32 = 2;

/// The file name of a puppet inside its folder.
pub const PUPPET_FILE: &str = "puppet.json";

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PuppetFile {
    schema: u32,
    width: u32,
    height: u32,
    root: String,
    layers: Vec<LayerFile>,
    joints: Vec<JointFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rig: Option<RigFile>,
}

/// The rig section, layers by name.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile {
    version: u32,
    edges: Vec<EdgeFile>,
    accessories: Vec<AccessoryFile>,
    /// Absent in rigs written before it existed, which skinned by translation.
    #[serde(default)]
    skinning: Skinning,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct EdgeFile {
    parent: String,
    child: String,
    constraints: Vec<Constraint>,
    origin: Origin,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct AccessoryFile {
    layer: String,
    pins: Vec<PinFile>,
    /// Per vertex, `[pin, weight]` pairs.
    weights: Vec<Vec<(u32, f32)>>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PinFile {
    vertex: u32,
    parent: String,
    triangle: u32,
    weights: [f32; 3],
    constraint: Constraint,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LayerFile {
    name: String,
    kind: LayerKind,
    texture: PathBuf,
    vertices: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
    uvs: Vec<[f32; 2]>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointFile {
    a: JointEnd,
    b: JointEnd,
}

/// A joint end by layer *name*, so the file reads well and survives layer reordering by hand.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointEnd {
    layer: String,
    vertex: u32,
}

/// Only the version, read first so a newer file gets a clear message instead of a field error.
#[derive(Deserialize)]
struct Version {
    schema: u32,
}

/// Writes `puppet` into folder `dir` as `puppet.json` + `textures/NN_<layer>.png`.
///
/// # Errors
/// [`Error::Io`]/[`Error::Image`] naming the file that could not be written.
pub fn save(puppet: &Puppet, dir: &Path) -> Result<()> {
    let mut layers = Vec::new();
    for (i, layer) in puppet.layers.iter().enumerate() {
        let texture = PathBuf::from("textures").join(format!("{i:02}_{}.png", file_safe(&layer.name)));
        layer.texture.save_png(&dir.join(&texture))?;
        layers.push(LayerFile {
            name: layer.name.clone(),
            kind: layer.kind,
            texture,
            vertices: layer.mesh.vertices.clone(),
            triangles: layer.mesh.triangles.clone(),
            uvs: layer.uvs.clone(),
        });
    }
    let end = |v: VertexRef| JointEnd {
        layer: puppet.layers[v.layer].name.clone(),
        vertex: v.vertex,
    };
    let file = PuppetFile {
        schema: SCHEMA_VERSION,
        width: puppet.width,
        height: puppet.height,
        root: puppet.layers[puppet.root].name.clone(),
        layers,
        joints: puppet.joints.iter().map(|j| JointFile { a: end(j.a), b: end(j.b) }).collect(),
        rig: puppet.rig.as_ref().map(|rig| rig_file(puppet, rig)),
    };
    let json = serde_json::to_vec_pretty(&file).expect("puppet file serialises: plain data, string keys");
    crate::atomic_file::write_atomic(&dir.join(PUPPET_FILE), &json)
}

/// Reads a puppet from a folder holding `puppet.json` (or from the `puppet.json` path itself).
///
/// # Errors
/// [`Error::WrongFolder`] if there is no `puppet.json`; [`Error::Io`] if unreadable;
/// [`Error::Limit`] if larger than [`user_file::DATA`]; as [`parse`] for its contents, and
/// [`Error::Io`]/[`Error::Image`]/[`Error::Limit`] naming a texture that cannot be read.
pub fn load(path: &Path) -> Result<Puppet> {
    let json_path = if path.is_dir() {
        path.join(PUPPET_FILE)
    } else {
        path.to_path_buf()
    };
    if !json_path.is_file() {
        let problem = if path.join("net.json").is_file() {
            "this is a trained model folder; its puppet is in its puppet/ folder"
        } else if path.exists() {
            "no puppet.json"
        } else {
            "no such file or folder"
        };
        return Err(Error::WrongFolder {
            path: path.to_path_buf(),
            expected: crate::error::FolderKind::Puppet,
            problem: problem.into(),
        });
    }
    let dir = json_path.parent().unwrap_or(Path::new("."));
    let bytes = user_file::read_bytes(&json_path, user_file::DATA)?;
    parse(&bytes, &json_path, |texture| Picture::load(&dir.join(texture)))
}

/// Parses the bytes of the `puppet.json` at `json_path` (which only names it in errors);
/// `texture` reads a layer's texture from its path relative to the puppet folder, a path already
/// checked to stay inside that folder.
///
/// # Errors
/// [`Error::Format`] for bad JSON, a schema newer than [`SCHEMA_VERSION`], or inconsistent
/// content (index out of range, UV count, texture size, joint naming an unknown layer or vertex);
/// [`Error::Layer`] for a texture path that leaves the folder; what `texture` returns for a
/// texture it cannot read. Every bad layer is reported at once ([`Error::Partial`]).
pub fn parse(bytes: &[u8], json_path: &Path, mut texture: impl FnMut(&Path) -> Result<Picture>) -> Result<Puppet> {
    let version: Version = serde_json::from_slice(bytes).map_err(|e| Error::format(json_path, format!("not a puppet file: {e}")))?;
    if version.schema > SCHEMA_VERSION {
        return Err(Error::format(
            json_path,
            format!(
                "schema version {} is newer than this puppet understands ({SCHEMA_VERSION}); use a newer puppet",
                version.schema
            ),
        ));
    }
    let file: PuppetFile = serde_json::from_slice(bytes).map_err(|e| Error::format(json_path, format!("invalid puppet file: {e}")))?;
    let mut problems = Vec::new();
    let mut layers = Vec::new();
    for lf in file.layers {
        // Textures live inside the puppet folder: a path that leaves it is refused, not read.
        if lf.texture.is_absolute() || lf.texture.components().any(|c| !matches!(c, std::path::Component::Normal(_))) {
            problems.push(Error::layer(
                json_path,
                &lf.name,
                format!(
                    "texture path {:?} leaves the puppet folder (expected e.g. textures/00_torso.png)",
                    lf.texture
                ),
            ));
            continue;
        }
        let texture = match texture(&lf.texture) {
            Ok(t) => t,
            Err(e) => {
                problems.push(e);
                continue;
            }
        };
        let layer = Layer {
            name: lf.name,
            kind: lf.kind,
            mesh: Mesh {
                vertices: lf.vertices,
                triangles: lf.triangles,
            },
            uvs: lf.uvs,
            texture,
        };
        if let Err(problem) = check_layer(&layer, file.width, file.height) {
            problems.push(Error::layer(json_path, &layer.name, problem));
        }
        layers.push(layer);
    }
    Error::collect(problems)?;
    let find = |name: &str| layers.iter().position(|l| l.name == name);
    let root = find(&file.root).ok_or_else(|| Error::format(json_path, format!("root {:?} is not a layer", file.root)))?;
    let mut joints = Vec::new();
    for (k, j) in file.joints.iter().enumerate() {
        let resolve = |end: &JointEnd| match find(&end.layer) {
            Some(layer) if (end.vertex as usize) < layers[layer].mesh.vertices.len() => Ok(VertexRef { layer, vertex: end.vertex }),
            Some(_) => Err(Error::format(
                json_path,
                format!("joint {k}: layer {:?} has no vertex {}", end.layer, end.vertex),
            )),
            None => Err(Error::format(json_path, format!("joint {k}: no layer {:?}", end.layer))),
        };
        joints.push(Joint {
            a: resolve(&j.a)?,
            b: resolve(&j.b)?,
        });
    }
    let mut puppet = Puppet {
        width: file.width,
        height: file.height,
        layers,
        root,
        joints,
        rig: None,
    };
    if let Some(rig) = file.rig {
        let data = rig_data(&puppet, rig).map_err(|problem| Error::format(json_path, format!("rig: {problem}")))?;
        data.check(&puppet)
            .map_err(|problem| Error::format(json_path, format!("rig: {problem}")))?;
        puppet.rig = Some(data);
    }
    Ok(puppet)
}

fn rig_file(puppet: &Puppet, rig: &RigData) -> RigFile {
    let name = |l: usize| puppet.layers[l].name.clone();
    RigFile {
        version: rig.version,
        edges: rig
            .edges
            .iter()
            .map(|e| EdgeFile {
                parent: name(e.parent),
                child: name(e.child),
                constraints: e.constraints.clone(),
                origin: e.origin,
            })
            .collect(),
        accessories: rig
            .accessories
            .iter()
            .map(|a| AccessoryFile {
                layer: name(a.layer),
                pins: a
                    .pins
                    .iter()
                    .map(|p| PinFile {
                        vertex: p.vertex,
                        parent: name(p.parent),
                        triangle: p.triangle,
                        weights: p.weights,
                        constraint: p.constraint,
                    })
                    .collect(),
                weights: a.weights.clone(),
            })
            .collect(),
        skinning: rig.skinning,
    }
}

/// The rig section with layer names resolved (the indices are checked by [`RigData::check`]).
fn rig_data(puppet: &Puppet, rig: RigFile) -> std::result::Result<RigData, String> {
    let find = |n: &str| puppet.layer_index(n).ok_or_else(|| format!("no layer {n:?}"));
    let edges = rig
        .edges
        .into_iter()
        .map(|e| {
            Ok(RigEdge {
                parent: find(&e.parent)?,
                child: find(&e.child)?,
                constraints: e.constraints,
                origin: e.origin,
            })
        })
        .collect::<std::result::Result<_, String>>()?;
    let accessories = rig
        .accessories
        .into_iter()
        .map(|a| {
            let pins = a
                .pins
                .into_iter()
                .map(|p| {
                    Ok(RigPin {
                        vertex: p.vertex,
                        parent: find(&p.parent)?,
                        triangle: p.triangle,
                        weights: p.weights,
                        constraint: p.constraint,
                    })
                })
                .collect::<std::result::Result<_, String>>()?;
            Ok(AccessoryRig {
                layer: find(&a.layer)?,
                pins,
                weights: a.weights,
            })
        })
        .collect::<std::result::Result<_, String>>()?;
    Ok(RigData {
        version: rig.version,
        edges,
        accessories,
        skinning: rig.skinning,
    })
}

fn check_layer(layer: &Layer, width: u32, height: u32) -> std::result::Result<(), String> {
    layer.mesh.check_invariants()?;
    if layer.uvs.len() != layer.mesh.vertices.len() {
        return Err(format!("{} UVs for {} vertices", layer.uvs.len(), layer.mesh.vertices.len()));
    }
    if (layer.texture.width, layer.texture.height) != (width, height) {
        return Err(format!(
            "texture is {}×{}, expected {width}×{height}",
            layer.texture.width, layer.texture.height
        ));
    }
    Ok(())
}

/// A layer name made safe for a file name (letters, digits, `-`, `_`; others become `_`).
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found while writing the puppet_json target's area invariant (by hand, not by the fuzzer):
    /// finite vertices 3e38 apart gave a triangle of infinite area, which the winding check
    /// (`area <= 0`) let through.
    #[test]
    fn a_triangle_whose_area_overflows_is_refused_naming_the_layer() {
        let json = br#"{"schema":1,"width":4,"height":4,"root":"torso","joints":[],"layers":[{"name":"torso","kind":"body",
            "texture":"t.png","vertices":[[0,0],[0,3e38],[3e38,3e38]],"triangles":[[0,2,1]],"uvs":[[0,0],[0,1],[1,1]]}]}"#;
        let err = parse(json, Path::new("p/puppet.json"), |_| Ok(Picture::filled(4, 4, [1.0; 4]))).unwrap_err();
        assert_eq!(
            err.to_string(),
            "p/puppet.json: layer \"torso\": triangle 0 [0, 2, 1] is too large (its area is inf)"
        );
    }

    #[test]
    fn a_rig_keeps_its_skinning_and_one_written_without_it_skins_by_translation() {
        let tmp = tempfile::tempdir().unwrap();
        let mut puppet = crate::test_util::dressed_puppet();
        puppet.rig.as_mut().unwrap().skinning = Skinning::Affine;
        save(&puppet, tmp.path()).unwrap();
        assert_eq!(load(tmp.path()).unwrap().rig.unwrap().skinning, Skinning::Affine);
        let path = tmp.path().join("puppet.json");
        let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        json["rig"]
            .as_object_mut()
            .unwrap()
            .remove("skinning")
            .expect("the skinning is written");
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        assert_eq!(load(tmp.path()).unwrap().rig.unwrap().skinning, Skinning::Translation);
    }
}
