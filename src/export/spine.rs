//! Spine 4.2 export (the "JSON export format" and "texture atlas format" pages of Spine's user
//! guide): a skeleton of one bone per layer, each layer a weighted mesh attachment, and one
//! animation per pose list whose keys reproduce the poses.
//!
//! - **Space.** Spine's y points up; the skeleton's origin is the bottom centre of the puppet's
//!   frame, one unit per frame pixel: frame pixel (x, y) is Spine point (x − W/2, H − y).
//! - **Bones.** The root layer's bone is the root, at its layer's centroid. Every other body
//!   layer hangs from the layer it is hinged to on the way to the root (breadth first over the
//!   joints), its bone at the hinge. An accessory (or a layer no joint reaches) hangs from its rig
//!   parent, else from the root, its bone at its centroid. Setup rotations are 0.
//! - **Attachments.** Each layer is a mesh attachment in its own slot (slots in the puppet's
//!   back-to-front order), every vertex weighted 1 to its layer's bone; UVs address the layer's
//!   region of one atlas page, where each layer's texture is cut to what its UVs use.
//! - **Keys.** Per pose, each bone's world rotation and position are the least-squares rigid
//!   motion of its layer's vertices (rotation about their centroid); they become `rotate` and
//!   `translate` keys relative to the parent, and what the rigid motion misses becomes the
//!   layer's `deform` key (per-vertex offsets in the bone's frame). Offsets are computed against
//!   the bone transforms as a runtime rebuilds them from the written (rounded) values, so
//!   rounding does not accumulate down the bone chain. Keys are linear (Spine's default), so
//!   a runtime plays straight-line interpolation between our poses.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

use super::region_page::{pack, RegionPage};
use crate::atomic_file::Outputs;
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::puppet::{LayerKind, Puppet};

/// The Spine version the files declare.
pub const SPINE_VERSION: &str = "4.2.0";

/// Decimal places written for positions, angles and offsets: 10⁻⁴ px and degrees, far below
/// what a runtime's 32-bit floats resolve on a character of a few hundred pixels.
const DECIMALS: i32 = 4;

/// One animation: poses of the puppet (global vertex numbering, frame pixels), one key each.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseAnimation {
    /// The animation's name in the skeleton.
    pub name: String,
    /// The poses, in order.
    pub poses: Vec<Vec<[f32; 2]>>,
}

/// A skeleton ready to write: the JSON, the atlas text and its page.
#[derive(Clone, Debug)]
pub struct SpineSkeleton {
    /// The skeleton (Spine JSON).
    pub json: Value,
    /// The atlas (Spine's text format), naming the page `<name>.png`.
    pub atlas: String,
    /// The atlas page: every layer's texture, straight alpha.
    pub page: Picture,
}

/// A rotation (degrees, counter-clockwise with y up) then a translation: a bone's world
/// transform, or its transform relative to its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rigid {
    degrees: f64,
    at: [f64; 2],
}

impl Rigid {
    fn turn(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.degrees.to_radians().sin_cos();
        [c * p[0] - s * p[1], s * p[0] + c * p[1]]
    }

    /// `p` in this frame, in the outer frame.
    fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let q = self.turn(p);
        [q[0] + self.at[0], q[1] + self.at[1]]
    }

    /// `p` of the outer frame, in this frame.
    fn local(&self, p: [f64; 2]) -> [f64; 2] {
        let back = Rigid {
            degrees: -self.degrees,
            at: [0.0; 2],
        };
        back.turn([p[0] - self.at[0], p[1] - self.at[1]])
    }

    /// `child` (relative to this frame) in the outer frame.
    fn then(&self, child: &Rigid) -> Rigid {
        Rigid {
            degrees: self.degrees + child.degrees,
            at: self.apply(child.at),
        }
    }
}

/// One bone: its layer, its parent bone, and its world position at rest.
struct Bone {
    layer: usize,
    parent: Option<usize>,
    rest: [f64; 2],
}

/// `x` rounded to [`DECIMALS`] places.
fn round(x: f64) -> f64 {
    let scale = 10f64.powi(DECIMALS);
    (x * scale).round() / scale
}

/// Frame pixels to Spine space (see the module doc).
fn spine_point(p: [f32; 2], puppet: &Puppet) -> [f64; 2] {
    [
        f64::from(p[0]) - f64::from(puppet.width) / 2.0,
        f64::from(puppet.height) - f64::from(p[1]),
    ]
}

/// The centroid of `points`.
fn centroid(points: &[[f64; 2]]) -> [f64; 2] {
    let n = points.len().max(1) as f64;
    let s = points.iter().fold([0.0; 2], |a, p| [a[0] + p[0], a[1] + p[1]]);
    [s[0] / n, s[1] / n]
}

/// The bones of `puppet`, parents first, and each layer's bone index.
fn bones(puppet: &Puppet) -> (Vec<Bone>, Vec<usize>) {
    let n = puppet.layers.len();
    let rest: Vec<Vec<[f64; 2]>> = puppet
        .layers
        .iter()
        .map(|l| l.mesh.vertices.iter().map(|&v| spine_point(v, puppet)).collect())
        .collect();
    let mut bone_of = vec![usize::MAX; n];
    let mut bones = vec![Bone {
        layer: puppet.root,
        parent: None,
        rest: centroid(&rest[puppet.root]),
    }];
    bone_of[puppet.root] = 0;
    let mut queue = VecDeque::from([puppet.root]);
    while let Some(l) = queue.pop_front() {
        for joint in &puppet.joints {
            let there = match (joint.a.layer == l, joint.b.layer == l) {
                (true, false) => joint.b,
                (false, true) => joint.a,
                _ => continue,
            };
            let child = there.layer;
            if bone_of[child] != usize::MAX || puppet.layers[child].kind != LayerKind::Body {
                continue;
            }
            bone_of[child] = bones.len();
            bones.push(Bone {
                layer: child,
                parent: Some(bone_of[l]),
                // The hinge's vertex on the child (the two coincide at rest).
                rest: rest[child][there.vertex as usize],
            });
            queue.push_back(child);
        }
    }
    let rig_parent = |l: usize| {
        puppet
            .rig
            .as_ref()
            .and_then(|r| r.edges.iter().find(|e| e.child == l))
            .map(|e| e.parent)
    };
    // Rig parents come before their children in the rig's order; the rest in layer order.
    let mut rest_order: Vec<usize> = puppet.rig.iter().flat_map(|r| r.accessories.iter().map(|a| a.layer)).collect();
    rest_order.extend(0..n);
    for l in rest_order {
        if bone_of[l] != usize::MAX {
            continue;
        }
        let parent = rig_parent(l).filter(|&p| bone_of[p] != usize::MAX).unwrap_or(puppet.root);
        bone_of[l] = bones.len();
        bones.push(Bone {
            layer: l,
            parent: Some(bone_of[parent]),
            rest: centroid(&rest[l]),
        });
    }
    (bones, bone_of)
}

/// The least-squares rigid motion taking `from` to `to` (rotation about `from`'s centroid).
fn rigid_fit(from: &[[f64; 2]], to: &[[f64; 2]]) -> Rigid {
    let (c0, c1) = (centroid(from), centroid(to));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (p, q) in from.iter().zip(to) {
        let (a, b) = ([p[0] - c0[0], p[1] - c0[1]], [q[0] - c1[0], q[1] - c1[1]]);
        dot += a[0] * b[0] + a[1] * b[1];
        cross += a[0] * b[1] - a[1] * b[0];
    }
    let degrees = if dot == 0.0 && cross == 0.0 {
        0.0
    } else {
        cross.atan2(dot).to_degrees()
    };
    let turned = Rigid { degrees, at: [0.0; 2] }.turn(c0);
    Rigid {
        degrees,
        at: [c1[0] - turned[0], c1[1] - turned[1]],
    }
}

/// The number of leading vertices that walk the mesh's outline in order (Spine's `hull`), or 0
/// when the outline is not listed first.
fn hull_length(triangles: &[[u32; 3]], vertices: usize) -> usize {
    let mut count = std::collections::HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            *count.entry((a, b)).or_insert(0) += 1;
        }
    }
    let outline: std::collections::HashSet<(u32, u32)> = count.into_iter().filter(|&(_, c)| c == 1).map(|(e, _)| e).collect();
    let on_outline: std::collections::HashSet<u32> = outline.iter().flat_map(|&(a, b)| [a, b]).collect();
    let k = on_outline.len();
    let walks = k >= 3
        && k <= vertices
        && (0..k as u32).all(|i| {
            let j = (i + 1) % k as u32;
            outline.contains(&(i.min(j), i.max(j)))
        });
    if walks {
        k
    } else {
        0
    }
}

/// Checks a layer name can name a bone, slot, attachment and atlas region.
fn check_name(name: &str) -> Result<()> {
    if name.is_empty() || name.trim() != name || name.chars().any(char::is_control) {
        return Err(Error::setting(
            "a layer name in a Spine export",
            format!("{name:?}"),
            "a name without leading or trailing spaces or control characters",
        ));
    }
    Ok(())
}

/// Another outfit of the same body, written as a Spine skin of its own: its accessories get
/// bones, slots and attachments; the animations carry their poses too.
#[derive(Clone, Debug, PartialEq)]
pub struct OutfitSkin {
    /// The skin's name.
    pub name: String,
    /// The character in that outfit: the same body layers, other accessories.
    pub puppet: Puppet,
    /// For each animation of the skeleton, in order, the same keys as poses of `puppet`.
    pub poses: Vec<Vec<Vec<[f32; 2]>>>,
}

/// One mesh of the skeleton: its bone, slot, attachment and atlas region share `name`.
struct Part<'p> {
    name: String,
    skin: String,
    /// Where its poses come from: 0 the main puppet, `i + 1` outfit `i`.
    source: usize,
    /// Its layer's index in that puppet.
    layer: usize,
    mesh: &'p crate::puppet::Layer,
    parent: Option<usize>,
    rest: [f64; 2],
    /// Its rest vertices in Spine space.
    vertices: Vec<[f64; 2]>,
}

/// The skin the main puppet's accessories go in when outfits have skins of their own (in the
/// default skin they would show under every skin).
pub const OWN_SKIN: &str = "own";

/// The parts of the skeleton, parents first (the main puppet's bones, then each outfit's
/// accessories), and the draw order as part indices.
fn parts<'p>(puppet: &'p Puppet, outfits: &'p [OutfitSkin]) -> Result<(Vec<Part<'p>>, Vec<usize>)> {
    let (bones, bone_of) = bones(puppet);
    let space = |p: &Puppet, l: usize| -> Vec<[f64; 2]> { p.layers[l].mesh.vertices.iter().map(|&v| spine_point(v, p)).collect() };
    let main_skin = |l: usize| {
        if outfits.is_empty() || puppet.layers[l].kind == LayerKind::Body {
            "default".to_string()
        } else {
            OWN_SKIN.to_string()
        }
    };
    let mut parts: Vec<Part> = bones
        .iter()
        .map(|b| Part {
            name: puppet.layers[b.layer].name.clone(),
            skin: main_skin(b.layer),
            source: 0,
            layer: b.layer,
            mesh: &puppet.layers[b.layer],
            parent: b.parent,
            rest: b.rest,
            vertices: space(puppet, b.layer),
        })
        .collect();
    let mut order: Vec<usize> = (0..puppet.layers.len()).map(|l| bone_of[l]).collect();
    for (i, outfit) in outfits.iter().enumerate() {
        let worn = &outfit.puppet;
        let of_outfit = |parts: &[Part], name: &str| parts.iter().position(|p| p.source == i + 1 && p.mesh.name == name);
        let mut rig_order: Vec<usize> = worn.rig.iter().flat_map(|r| r.accessories.iter().map(|a| a.layer)).collect();
        rig_order.extend(0..worn.layers.len());
        let mut placed = vec![false; worn.layers.len()];
        for l in rig_order {
            if placed[l] || worn.layers[l].kind != LayerKind::Accessory {
                continue;
            }
            placed[l] = true;
            let parent_layer = worn
                .rig
                .as_ref()
                .and_then(|r| r.edges.iter().find(|e| e.child == l))
                .map(|e| e.parent);
            let parent = parent_layer.and_then(|p| {
                let name = &worn.layers[p].name;
                match worn.layers[p].kind {
                    LayerKind::Body => parts
                        .iter()
                        .position(|q| q.source == 0 && q.mesh.kind == LayerKind::Body && &q.mesh.name == name),
                    LayerKind::Accessory => of_outfit(&parts, name),
                }
            });
            let vertices = space(worn, l);
            parts.push(Part {
                name: format!("{}-{}", outfit.name, worn.layers[l].name),
                skin: outfit.name.clone(),
                source: i + 1,
                layer: l,
                mesh: &worn.layers[l],
                parent: Some(parent.unwrap_or(0)),
                rest: centroid(&vertices),
                vertices,
            });
        }
        // Each accessory is drawn just after the body layer below it in the outfit's order.
        let mut at = 0;
        for (l, layer) in worn.layers.iter().enumerate() {
            if layer.kind == LayerKind::Body {
                if let Some(p) = parts.iter().position(|q| q.source == 0 && q.mesh.name == layer.name) {
                    at = order.iter().position(|&o| o == p).map_or(at, |k| k + 1);
                }
            } else if let Some(p) = parts.iter().position(|q| q.source == i + 1 && q.layer == l) {
                order.insert(at, p);
                at += 1;
            }
        }
    }
    let mut names = std::collections::HashSet::new();
    for part in &parts {
        check_name(&part.name)?;
        if !names.insert(part.name.as_str()) {
            return Err(Error::setting(
                "a bone name in a Spine export",
                format!("{:?}", part.name),
                "a name no other layer or outfit accessory has",
            ));
        }
    }
    Ok((parts, order))
}

/// Builds the skeleton of `puppet` with `animations`, keys `seconds_per_pose` apart, and each
/// of `outfits` as a skin; the atlas names its page `<name>.png`.
///
/// # Errors
/// [`Error::Setting`] for no animation, an animation without poses, two with one name, a layer
/// name a Spine file cannot carry or two parts with one name; [`Error::Mismatch`] for a pose of
/// another puppet or an outfit without the same keys; [`Error::Limit`] if the texture page would
/// be too large.
pub fn skeleton(
    puppet: &Puppet,
    animations: &[PoseAnimation],
    outfits: &[OutfitSkin],
    name: &str,
    seconds_per_pose: f64,
) -> Result<SpineSkeleton> {
    if animations.is_empty() {
        return Err(Error::setting("Spine animations", 0, "at least one"));
    }
    let mut names = std::collections::HashSet::new();
    for a in animations {
        if a.poses.is_empty() || !names.insert(a.name.as_str()) {
            return Err(Error::setting(
                "Spine animation",
                format!("{:?} with {} poses", a.name, a.poses.len()),
                "at least one pose, and a name no other animation has",
            ));
        }
        if let Some(p) = a.poses.iter().find(|p| p.len() != puppet.vertex_count()) {
            return Err(Error::mismatch(
                format!("the vertices of a pose of animation {:?}", a.name),
                p.len(),
                puppet.vertex_count(),
            ));
        }
    }
    for outfit in outfits {
        let keys = |poses: &[Vec<Vec<[f32; 2]>>]| poses.iter().map(Vec::len).collect::<Vec<_>>();
        let want: Vec<usize> = animations.iter().map(|a| a.poses.len()).collect();
        if keys(&outfit.poses) != want {
            return Err(Error::mismatch(
                format!("the keys of outfit {:?}", outfit.name),
                format!("{:?}", keys(&outfit.poses)),
                format!("{want:?}"),
            ));
        }
        if let Some(p) = outfit.poses.iter().flatten().find(|p| p.len() != outfit.puppet.vertex_count()) {
            return Err(Error::mismatch(
                format!("the vertices of a pose of outfit {:?}", outfit.name),
                p.len(),
                outfit.puppet.vertex_count(),
            ));
        }
    }
    if !(seconds_per_pose.is_finite() && seconds_per_pose > 0.0) {
        return Err(Error::setting("seconds per pose", seconds_per_pose, "a positive number"));
    }
    let (parts, order) = parts(puppet, outfits)?;
    let RegionPage { regions, page } = pack(&parts.iter().map(|p| p.mesh).collect::<Vec<_>>())?;
    let setup: Vec<Rigid> = parts
        .iter()
        .map(|b| {
            let parent = b.parent.map_or([0.0; 2], |p| parts[p].rest);
            Rigid {
                degrees: 0.0,
                at: [round(b.rest[0] - parent[0]), round(b.rest[1] - parent[1])],
            }
        })
        .collect();
    // The setup world positions as a runtime composes them from the rounded local ones.
    let mut setup_world: Vec<Rigid> = Vec::with_capacity(parts.len());
    for (k, b) in parts.iter().enumerate() {
        let world = b.parent.map_or(setup[k], |p| setup_world[p].then(&setup[k]));
        setup_world.push(world);
    }
    let local_rest: Vec<Vec<[f64; 2]>> = parts
        .iter()
        .zip(&setup_world)
        .map(|(part, w)| part.vertices.iter().map(|&p| w.local(p).map(round)).collect())
        .collect();

    let bones_json: Vec<Value> = parts
        .iter()
        .zip(&setup)
        .map(|(b, s)| {
            let mut bone = Map::new();
            bone.insert("name".into(), json!(b.name));
            if let Some(p) = b.parent {
                bone.insert("parent".into(), json!(parts[p].name));
            }
            bone.insert("x".into(), json!(s.at[0]));
            bone.insert("y".into(), json!(s.at[1]));
            Value::Object(bone)
        })
        .collect();
    let slots: Vec<Value> = order
        .iter()
        .map(|&p| json!({"name": parts[p].name, "bone": parts[p].name, "attachment": parts[p].name}))
        .collect();
    let mut skins: Vec<(String, Map<String, Value>)> = Vec::new();
    let skin_of = |skins: &mut Vec<(String, Map<String, Value>)>, name: &str| -> usize {
        skins.iter().position(|(n, _)| n == name).unwrap_or_else(|| {
            skins.push((name.to_string(), Map::new()));
            skins.len() - 1
        })
    };
    skin_of(&mut skins, "default");
    for (p, part) in parts.iter().enumerate() {
        let layer = part.mesh;
        let region = &regions[p];
        let texture = (layer.texture.width, layer.texture.height);
        // UVs to 10⁻⁶: a 250th of a pixel on the largest page.
        let uvs: Vec<f64> = layer
            .uvs
            .iter()
            .flat_map(|&uv| region.uv(uv, texture))
            .map(|u| (u * 1e6).round() / 1e6)
            .collect();
        let vertices: Vec<Value> = local_rest[p]
            .iter()
            .flat_map(|v| [json!(1), json!(p), json!(v[0]), json!(v[1]), json!(1)])
            .collect();
        let triangles: Vec<u32> = layer.mesh.triangles.iter().flatten().copied().collect();
        let mesh = json!({
            "type": "mesh",
            "uvs": uvs,
            "triangles": triangles,
            "vertices": vertices,
            "hull": hull_length(&layer.mesh.triangles, layer.mesh.vertices.len()),
            "width": region.size.0,
            "height": region.size.1,
        });
        let s = skin_of(&mut skins, &part.skin);
        skins[s].1.insert(part.name.clone(), json!({ part.name.clone(): mesh }));
    }

    let sources: Vec<(&Puppet, Vec<usize>)> = std::iter::once(puppet)
        .chain(outfits.iter().map(|o| &o.puppet))
        .map(|p| (p, p.vertex_offsets()))
        .collect();
    let mut animations_json = Map::new();
    for (a, animation) in animations.iter().enumerate() {
        let mut rotate = vec![Vec::new(); parts.len()];
        let mut translate = vec![Vec::new(); parts.len()];
        let mut deform = vec![Vec::new(); parts.len()];
        let mut last_degrees = vec![0.0f64; parts.len()];
        for k in 0..animation.poses.len() {
            let time = round(k as f64 * seconds_per_pose);
            let posed: Vec<Vec<[f64; 2]>> = parts
                .iter()
                .map(|part| {
                    let (source, offsets) = &sources[part.source];
                    let pose = if part.source == 0 {
                        &animation.poses[k]
                    } else {
                        &outfits[part.source - 1].poses[a][k]
                    };
                    let start = offsets[part.layer];
                    pose[start..start + part.vertices.len()]
                        .iter()
                        .map(|&v| spine_point(v, source))
                        .collect()
                })
                .collect();
            let mut world: Vec<Rigid> = Vec::with_capacity(parts.len());
            for (b, part) in parts.iter().enumerate() {
                let fit = rigid_fit(&part.vertices, &posed[b]);
                let target = Rigid {
                    degrees: fit.degrees,
                    at: fit.apply(part.rest),
                };
                let parent = part.parent.map(|p| world[p]);
                let relative = match parent {
                    Some(p) => Rigid {
                        degrees: target.degrees - p.degrees,
                        at: p.local(target.at),
                    },
                    None => target,
                };
                // Keep the angle within a half turn of the last key: keys interpolate linearly.
                let mut degrees = relative.degrees;
                degrees += 360.0 * ((last_degrees[b] - degrees) / 360.0).round();
                last_degrees[b] = degrees;
                let local = Rigid {
                    degrees: round(degrees),
                    at: [round(relative.at[0] - setup[b].at[0]), round(relative.at[1] - setup[b].at[1])],
                };
                rotate[b].push(json!({"time": time, "value": local.degrees}));
                translate[b].push(json!({"time": time, "x": local.at[0], "y": local.at[1]}));
                let placed = Rigid {
                    degrees: local.degrees,
                    at: [setup[b].at[0] + local.at[0], setup[b].at[1] + local.at[1]],
                };
                world.push(parent.map_or(placed, |p| p.then(&placed)));
                let moved: Vec<f64> = posed[b]
                    .iter()
                    .zip(&local_rest[b])
                    .flat_map(|(&p, r)| {
                        let q = world[b].local(p);
                        [round(q[0] - r[0]), round(q[1] - r[1])]
                    })
                    .collect();
                deform[b].push(json!({"time": time, "vertices": moved}));
            }
        }
        let mut bone_timelines = Map::new();
        let mut deform_timelines: Map<String, Value> = Map::new();
        for (b, part) in parts.iter().enumerate() {
            bone_timelines.insert(part.name.clone(), json!({"rotate": rotate[b], "translate": translate[b]}));
            let skin = deform_timelines.entry(part.skin.clone()).or_insert_with(|| json!({}));
            skin[part.name.as_str()] = json!({ part.name.clone(): {"deform": deform[b]} });
        }
        animations_json.insert(
            animation.name.clone(),
            json!({"bones": bone_timelines, "attachments": deform_timelines}),
        );
    }

    let all: Vec<[f64; 2]> = parts
        .iter()
        .filter(|p| p.source == 0)
        .flat_map(|p| p.vertices.iter().copied())
        .collect();
    let (lo, hi) = all.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    let skins: Vec<Value> = skins
        .into_iter()
        .map(|(name, attachments)| json!({"name": name, "attachments": attachments}))
        .collect();
    let json = json!({
        "skeleton": {
            "hash": "",
            "spine": SPINE_VERSION,
            "x": round(lo[0]),
            "y": round(lo[1]),
            "width": round(hi[0] - lo[0]),
            "height": round(hi[1] - lo[1]),
            "images": "./",
            "audio": "",
        },
        "bones": bones_json,
        "slots": slots,
        "skins": skins,
        "animations": animations_json,
    });
    let mut atlas = format!(
        "{name}.png\nsize: {}, {}\nformat: RGBA8888\nfilter: Linear, Linear\nrepeat: none\npma: false\n",
        page.width, page.height
    );
    for (part, region) in parts.iter().zip(&regions) {
        atlas.push_str(&format!(
            "{}\nbounds: {}, {}, {}, {}\n",
            part.name, region.at.0, region.at.1, region.size.0, region.size.1
        ));
    }
    Ok(SpineSkeleton { json, atlas, page })
}

/// Writes `skeleton` into `dir` as `<name>.json`, `<name>.atlas` and `<name>.png`, each claimed
/// first (nothing is written if one is in the way), and returns the three paths.
///
/// # Errors
/// [`Error::WouldOverwrite`] before writing anything; write errors naming the file.
pub fn write(skeleton: &SpineSkeleton, dir: &Path, name: &str, outputs: &Outputs) -> Result<Vec<PathBuf>> {
    let paths: Vec<PathBuf> = ["json", "atlas", "png"].iter().map(|e| dir.join(format!("{name}.{e}"))).collect();
    for path in &paths {
        outputs.claim(path)?;
    }
    let json = serde_json::to_vec(&skeleton.json).map_err(|e| Error::format(&paths[0], format!("cannot write JSON: {e}")))?;
    outputs.write(&paths[0], &json)?;
    outputs.write(&paths[1], skeleton.atlas.as_bytes())?;
    outputs.write(&paths[2], &skeleton.page.png_bytes(&paths[2])?)?;
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{dressed_puppet, hinged_puppet, Rng};

    /// Spine's documented rules, read from the JSON alone: bone world transforms from setup
    /// values plus linearly interpolated keys, weighted mesh vertices plus deform offsets.
    /// Returns each slot's world vertices at `time`, in frame pixels of a `size` frame.
    /// With `skin`, a slot's attachment is looked up in that skin, then in the default skin (a
    /// slot with neither is not drawn).
    fn evaluate(json: &Value, animation: &str, skin: &str, time: f64, size: (u32, u32)) -> Vec<(String, Vec<[f64; 2]>)> {
        let num = |v: &Value, key: &str| v.get(key).and_then(Value::as_f64).unwrap_or(0.0);
        let keyed = |keys: Option<&Value>, fields: &[&str]| -> Vec<f64> {
            let Some(keys) = keys.and_then(Value::as_array) else {
                return vec![0.0; fields.len()];
            };
            let at = |k: &Value| fields.iter().map(|f| num(k, f)).collect::<Vec<f64>>();
            let next = keys.iter().position(|k| num(k, "time") > time);
            match next {
                None => at(keys.last().unwrap()),
                Some(0) => at(&keys[0]),
                Some(i) => {
                    let (t0, t1) = (num(&keys[i - 1], "time"), num(&keys[i], "time"));
                    let s = (time - t0) / (t1 - t0);
                    at(&keys[i - 1]).iter().zip(at(&keys[i])).map(|(a, b)| a + (b - a) * s).collect()
                }
            }
        };
        let anim = &json["animations"][animation];
        // World transforms: (a, b, c, d, x, y).
        let mut world: Vec<(String, [f64; 6])> = Vec::new();
        for bone in json["bones"].as_array().unwrap() {
            let name = bone["name"].as_str().unwrap().to_string();
            let timelines = &anim["bones"][&name];
            let r = num(bone, "rotation") + keyed(timelines.get("rotate"), &["value"])[0];
            let t = keyed(timelines.get("translate"), &["x", "y"]);
            let (x, y) = (num(bone, "x") + t[0], num(bone, "y") + t[1]);
            let (s, c) = r.to_radians().sin_cos();
            let (la, lb, lc, ld) = (c, -s, s, c);
            let m = match bone.get("parent").and_then(Value::as_str) {
                None => [la, lb, lc, ld, x, y],
                Some(p) => {
                    let [pa, pb, pc, pd, px, py] = world.iter().find(|(n, _)| n == p).unwrap().1;
                    [
                        pa * la + pb * lc,
                        pa * lb + pb * ld,
                        pc * la + pd * lc,
                        pc * lb + pd * ld,
                        pa * x + pb * y + px,
                        pc * x + pd * y + py,
                    ]
                }
            };
            world.push((name, m));
        }
        let skins = json["skins"].as_array().unwrap();
        let attachments = |name: &str| skins.iter().find(|k| k["name"] == name).map(|k| &k["attachments"]);
        json["slots"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|slot| {
                let name = slot["name"].as_str().unwrap();
                let attachment = slot["attachment"].as_str().unwrap();
                let (found_in, mesh) = [skin, "default"].into_iter().find_map(|k| {
                    attachments(k)
                        .and_then(|a| a.get(name))
                        .and_then(|a| a.get(attachment))
                        .map(|m| (k, m))
                })?;
                let raw: Vec<f64> = mesh["vertices"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
                let deform_keys = anim["attachments"][found_in][name][attachment].get("deform");
                let weights = raw.len() / 5;
                let fields: Vec<String> = (0..2 * weights).map(|i| i.to_string()).collect();
                // Deform keys hold arrays; spread them into numbered fields for `keyed`.
                let spread: Option<Value> = deform_keys.map(|keys| {
                    Value::Array(
                        keys.as_array()
                            .unwrap()
                            .iter()
                            .map(|k| {
                                let mut m = Map::new();
                                m.insert("time".into(), k.get("time").cloned().unwrap_or(json!(0)));
                                let offset = num(k, "offset") as usize;
                                for (i, v) in k["vertices"].as_array().unwrap().iter().enumerate() {
                                    m.insert((offset + i).to_string(), v.clone());
                                }
                                Value::Object(m)
                            })
                            .collect(),
                    )
                });
                let names: Vec<&str> = fields.iter().map(String::as_str).collect();
                let offsets = keyed(spread.as_ref(), &names);
                let (mut i, mut entry) = (0, 0);
                let mut out = Vec::new();
                while i < raw.len() {
                    let count = raw[i] as usize;
                    i += 1;
                    let mut p = [0.0; 2];
                    for _ in 0..count {
                        let bone = raw[i] as usize;
                        let (vx, vy) = (raw[i + 1] + offsets[2 * entry], raw[i + 2] + offsets[2 * entry + 1]);
                        let [a, b, c, d, x, y] = world[bone].1;
                        p[0] += (a * vx + b * vy + x) * raw[i + 3];
                        p[1] += (c * vx + d * vy + y) * raw[i + 3];
                        i += 4;
                        entry += 1;
                    }
                    out.push([p[0] + f64::from(size.0) / 2.0, f64::from(size.1) - p[1]]);
                }
                Some((name.to_string(), out))
            })
            .collect()
    }

    /// Poses of `puppet`: rest; the front arm turned 35° about (24, 20) and everything shifted;
    /// every vertex jittered by up to 1.5 px; a full turn of the arm less 10° (an angle that must
    /// not be wrapped the short way).
    fn poses(puppet: &Puppet) -> Vec<Vec<[f32; 2]>> {
        let rest = puppet.rest_vertices();
        let arm = puppet.layer_index("arm_front").unwrap();
        let offsets = puppet.vertex_offsets();
        let arm_range = offsets[arm]..offsets[arm] + puppet.layers[arm].mesh.vertices.len();
        let turned = |degrees: f32, shift: [f32; 2]| -> Vec<[f32; 2]> {
            let (s, c) = degrees.to_radians().sin_cos();
            rest.iter()
                .enumerate()
                .map(|(i, v)| {
                    let p = if arm_range.contains(&i) {
                        let d = [v[0] - 24.0, v[1] - 20.0];
                        [24.0 + c * d[0] - s * d[1], 20.0 + s * d[0] + c * d[1]]
                    } else {
                        *v
                    };
                    [p[0] + shift[0], p[1] + shift[1]]
                })
                .collect()
        };
        let mut rng = Rng::new(7);
        let jittered: Vec<[f32; 2]> = turned(-20.0, [0.0; 2])
            .iter()
            .map(|v| [v[0] + rng.uniform(-1.5, 1.5) as f32, v[1] + rng.uniform(-1.5, 1.5) as f32])
            .collect();
        vec![
            rest.clone(),
            turned(35.0, [3.0, -2.0]),
            jittered,
            turned(170.0, [0.0; 2]),
            turned(350.0, [-1.0, 0.5]),
        ]
    }

    #[test]
    fn the_exported_json_reproduces_every_pose_at_its_key_by_spines_rules() {
        for puppet in [hinged_puppet(), dressed_puppet()] {
            let poses = poses(&puppet);
            let animations = [
                PoseAnimation {
                    name: "walk".into(),
                    poses: poses.clone(),
                },
                PoseAnimation {
                    name: "still".into(),
                    poses: vec![poses[1].clone()],
                },
            ];
            let skeleton = skeleton(&puppet, &animations, &[], "t", 0.1).unwrap();
            // Through text, as a runtime reads it.
            let json: Value = serde_json::from_slice(&serde_json::to_vec(&skeleton.json).unwrap()).unwrap();
            let offsets = puppet.vertex_offsets();
            let mut worst = 0.0f64;
            for animation in &animations {
                for (k, pose) in animation.poses.iter().enumerate() {
                    let slots = evaluate(&json, &animation.name, "default", k as f64 * 0.1, (puppet.width, puppet.height));
                    assert_eq!(slots.len(), puppet.layers.len());
                    for (l, (name, vertices)) in slots.iter().enumerate() {
                        assert_eq!(name, &puppet.layers[l].name, "slots keep the draw order");
                        for (i, v) in vertices.iter().enumerate() {
                            let want = pose[offsets[l] + i];
                            let error = (v[0] - f64::from(want[0])).hypot(v[1] - f64::from(want[1]));
                            worst = worst.max(error);
                        }
                    }
                }
            }
            assert!(worst < 0.01, "a vertex is {worst} px from its pose");
            // Between keys the runtime interpolates; halfway between the rest and the turned
            // arm, the arm's bone is turned halfway.
            let half = evaluate(&json, "walk", "default", 0.05, (puppet.width, puppet.height));
            let arm = puppet.layer_index("arm_front").unwrap();
            let rest_arm = &puppet.layers[arm].mesh.vertices;
            let moved = half[arm].1.iter().zip(rest_arm).any(|(v, r)| (v[0] - f64::from(r[0])).abs() > 0.5);
            assert!(moved, "halfway, the arm has moved");
        }
    }

    /// Poses of `puppet` shifted by `dx` px.
    fn shifted(poses: &[Vec<[f32; 2]>], dx: f32) -> Vec<Vec<[f32; 2]>> {
        poses.iter().map(|p| p.iter().map(|v| [v[0] + dx, v[1]]).collect()).collect()
    }

    #[test]
    fn an_outfit_is_a_skin_whose_accessories_replace_the_models_own() {
        let puppet = dressed_puppet();
        let size = (puppet.width, puppet.height);
        let main = poses(&puppet);
        let sleeve = OutfitSkin {
            name: "sleeve".into(),
            puppet: dressed_puppet(),
            poses: vec![shifted(&main, 2.0)],
        };
        let exported = skeleton(
            &puppet,
            &[PoseAnimation {
                name: "a".into(),
                poses: main.clone(),
            }],
            std::slice::from_ref(&sleeve),
            "t",
            0.1,
        )
        .unwrap();
        let json: Value = serde_json::from_slice(&serde_json::to_vec(&exported.json).unwrap()).unwrap();
        let names: Vec<&str> = json["slots"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["name"].as_str().unwrap())
            .collect();
        assert_eq!(
            names,
            ["arm_back", "torso", "head", "sleeve-arm_front", "arm_front"],
            "the outfit's accessory drawn where the outfit draws it"
        );
        let offsets = puppet.vertex_offsets();
        let arm = puppet.layer_index("arm_front").unwrap();
        for (k, pose) in main.iter().enumerate() {
            let time = k as f64 * 0.1;
            let own = evaluate(&json, "a", OWN_SKIN, time, size);
            let worn = evaluate(&json, "a", "sleeve", time, size);
            let drawn = |slots: &[(String, Vec<[f64; 2]>)]| slots.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
            assert_eq!(drawn(&own), ["arm_back", "torso", "head", "arm_front"]);
            assert_eq!(drawn(&worn), ["arm_back", "torso", "head", "sleeve-arm_front"]);
            let near = |got: &[[f64; 2]], pose: &[[f32; 2]], start: usize| {
                got.iter()
                    .enumerate()
                    .all(|(i, v)| (v[0] - f64::from(pose[start + i][0])).hypot(v[1] - f64::from(pose[start + i][1])) < 0.01)
            };
            assert!(near(&own[3].1, pose, offsets[arm]), "key {k}: the model's own sleeve");
            assert!(near(&worn[3].1, &sleeve.poses[0][k], offsets[arm]), "key {k}: the outfit's sleeve");
            assert!(
                near(&worn[1].1, pose, offsets[puppet.layer_index("torso").unwrap()]),
                "key {k}: the body"
            );
        }
        let uneven = OutfitSkin {
            poses: vec![main[..2].to_vec()],
            ..sleeve
        };
        let err = skeleton(
            &puppet,
            &[PoseAnimation {
                name: "a".into(),
                poses: main,
            }],
            &[uneven],
            "t",
            0.1,
        )
        .unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
    }

    #[test]
    fn bones_follow_the_joints_and_the_rig_and_angles_do_not_wrap_the_short_way() {
        let hinged = hinged_puppet();
        let (bones, bone_of) = bones(&hinged);
        let torso = hinged.layer_index("torso").unwrap();
        let arm = hinged.layer_index("arm_front").unwrap();
        assert_eq!(bones[0].layer, torso, "the root layer's bone is the root");
        let arm_bone = &bones[bone_of[arm]];
        assert_eq!(arm_bone.parent, Some(0));
        let hinge = spine_point([24.0, 20.0], &hinged);
        assert!((arm_bone.rest[0] - hinge[0]).abs() < 1.0 && (arm_bone.rest[1] - hinge[1]).abs() < 1.0);
        let dressed = dressed_puppet();
        let (bones, bone_of) = super::bones(&dressed);
        let sleeve = dressed.layer_index("arm_front").unwrap();
        assert_eq!(bones[bone_of[sleeve]].parent, Some(bone_of[dressed.layer_index("torso").unwrap()]));
        // 170° then 350°: the arm keeps turning (its rotate key goes on past 180°).
        let skeleton = skeleton(
            &hinged,
            &[PoseAnimation {
                name: "a".into(),
                poses: poses(&hinged),
            }],
            &[],
            "t",
            0.1,
        )
        .unwrap();
        let keys = skeleton.json["animations"]["a"]["bones"]["arm_front"]["rotate"]
            .as_array()
            .unwrap()
            .clone();
        let values: Vec<f64> = keys.iter().map(|k| k["value"].as_f64().unwrap()).collect();
        // Spine's rotation is counter-clockwise with y up; a turn of +35° on screen (y down) is −35°.
        assert!((values[1] + 35.0).abs() < 0.5, "{values:?}");
        assert!((values[4] - values[3] + 180.0).abs() < 1.0, "{values:?}");
    }

    #[test]
    fn the_atlas_page_shows_each_layer_where_its_uvs_point() {
        let puppet = dressed_puppet();
        let skeleton = skeleton(
            &puppet,
            &[PoseAnimation {
                name: "a".into(),
                poses: vec![puppet.rest_vertices()],
            }],
            &[],
            "t",
            0.1,
        )
        .unwrap();
        let lines: Vec<&str> = skeleton.atlas.lines().collect();
        assert_eq!(lines[0], "t.png");
        assert_eq!(lines[1], format!("size: {}, {}", skeleton.page.width, skeleton.page.height));
        for (l, layer) in puppet.layers.iter().enumerate() {
            let at = lines.iter().position(|&line| line == layer.name).unwrap();
            let bounds: Vec<f64> = lines[at + 1]
                .strip_prefix("bounds: ")
                .unwrap()
                .split(", ")
                .map(|v| v.parse().unwrap())
                .collect();
            let uvs = skeleton.json["skins"][0]["attachments"][&layer.name][&layer.name]["uvs"]
                .as_array()
                .unwrap();
            for (i, uv) in layer.uvs.iter().enumerate() {
                let (u, v) = (uvs[2 * i].as_f64().unwrap(), uvs[2 * i + 1].as_f64().unwrap());
                assert!(
                    (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v),
                    "layer {l} vertex {i}: {u}, {v}"
                );
                let page = (bounds[0] + u * bounds[2] + 0.25, bounds[1] + v * bounds[3] + 0.25);
                let texture = (
                    f64::from(uv[0]) * f64::from(layer.texture.width) + 0.25,
                    f64::from(uv[1]) * f64::from(layer.texture.height) + 0.25,
                );
                let clamp = |x: f64, n: u32| (x.floor().max(0.0) as u32).min(n - 1);
                let on_page = skeleton
                    .page
                    .get(clamp(page.0, skeleton.page.width), clamp(page.1, skeleton.page.height));
                let drawn = layer
                    .texture
                    .get(clamp(texture.0, layer.texture.width), clamp(texture.1, layer.texture.height));
                assert_eq!(on_page, drawn, "layer {} vertex {i}", layer.name);
            }
        }
    }

    #[test]
    fn poses_of_another_puppet_and_unusable_names_are_refused() {
        let puppet = hinged_puppet();
        let short = PoseAnimation {
            name: "a".into(),
            poses: vec![vec![[0.0; 2]; 3]],
        };
        assert!(matches!(skeleton(&puppet, &[short], &[], "t", 0.1), Err(Error::Mismatch { .. })));
        assert!(skeleton(&puppet, &[], &[], "t", 0.1).is_err());
        let mut named = puppet.clone();
        named.layers[0].name = "arm\nback".into();
        let rest = PoseAnimation {
            name: "a".into(),
            poses: vec![named.rest_vertices()],
        };
        let err = skeleton(&named, std::slice::from_ref(&rest), &[], "t", 0.1)
            .unwrap_err()
            .to_string();
        assert!(err.contains("arm\\nback"), "{err}");
        assert!(
            skeleton(&puppet, &[rest.clone(), rest], &[], "t", 0.1).is_err(),
            "two animations named a"
        );
    }
}
