//! Mix and match (accessory-rigs.md Fig. 1 F–H): the same body in other accessories. The body's
//! layers — meshes, textures, hinge joints, z-order among themselves — stay exactly as they are,
//! so anything posing the body (a pose file, a trained network) poses the new outfit too.
//!
//! - [`undress`] takes named accessories off, with every accessory that follows one of them.
//! - [`dress`] puts on the accessories of other artwork drawn over the same rest body, rigged
//!   against the body on the spot; the artwork's own copies of the body layers only place the
//!   accessories in depth.

use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::artwork::Artwork;
use crate::puppet::build::{build, BuildOptions};
use crate::puppet::rig_data::RigData;
use crate::puppet::{Joint, LayerKind, Puppet, VertexRef};

use super::{rig_puppet, RigOptions};

/// Below this share of its pixels inside the puppet's layer of the same name, an artwork's body
/// layer draws a warning: its accessories were likely drawn for another body. (Inside, not
/// intersection over union: a puppet's layers may extend under the layers in front of them.)
pub const BODY_MATCH_WARNING: f32 = 0.9;

/// The folder beside a character's frames that holds its other outfits, one artwork each.
pub const OUTFITS_FOLDER: &str = "outfits";

/// The outfits of the character in `dir`: the folders of `dir/outfits/`, by name (none if there
/// is no such folder).
///
/// # Errors
/// [`Error::Io`] naming the folder if it exists but cannot be listed.
pub fn outfits_in(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    let folder = dir.join(OUTFITS_FOLDER);
    if !folder.is_dir() {
        return Ok(Vec::new());
    }
    let mut found: Vec<std::path::PathBuf> = std::fs::read_dir(&folder)
        .map_err(|e| Error::io(&folder, e))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    found.sort();
    Ok(found)
}

/// `puppet` without the accessories `names`, nor any accessory that follows one of them in the
/// rig (each such one is reported through `progress`).
///
/// # Errors
/// [`Error::Setting`] naming a layer the puppet does not have, or a body layer.
pub fn undress(puppet: &Puppet, names: &[String], progress: &dyn Progress) -> Result<Puppet> {
    let accessories = || {
        let names: Vec<&str> = puppet
            .layers
            .iter()
            .filter(|l| l.kind == LayerKind::Accessory)
            .map(|l| l.name.as_str())
            .collect();
        if names.is_empty() {
            "an accessory (the puppet has none)".to_string()
        } else {
            format!("one of its accessories: {}", names.join(", "))
        }
    };
    let mut dropped = vec![false; puppet.layers.len()];
    for name in names {
        match puppet.layer_index(name) {
            None => return Err(Error::setting("accessory to take off", format!("{name:?}"), accessories())),
            Some(l) if puppet.layers[l].kind == LayerKind::Body => {
                return Err(Error::setting(
                    "accessory to take off",
                    format!("{name:?} (a body layer)"),
                    accessories(),
                ))
            }
            Some(l) => dropped[l] = true,
        }
    }
    if let Some(rig) = &puppet.rig {
        // Children follow parents: repeat until no edge leaves a dropped parent's child behind.
        let mut changed = true;
        while changed {
            changed = false;
            for e in &rig.edges {
                if dropped[e.parent] && !dropped[e.child] {
                    dropped[e.child] = true;
                    changed = true;
                    let (child, parent) = (&puppet.layers[e.child].name, &puppet.layers[e.parent].name);
                    progress.warn(&format!("{child:?} is taken off too: it follows {parent:?}"));
                }
            }
        }
    }
    let mut index = vec![None; puppet.layers.len()];
    let mut kept = 0;
    for (l, slot) in index.iter_mut().enumerate() {
        if !dropped[l] {
            *slot = Some(kept);
            kept += 1;
        }
    }
    let at = |l: usize| index[l].expect("kept layers only refer to kept layers");
    let rig = puppet.rig.as_ref().and_then(|rig| {
        let mut out = RigData {
            version: rig.version,
            edges: rig.edges.iter().filter(|e| !dropped[e.child]).cloned().collect(),
            accessories: rig.accessories.iter().filter(|a| !dropped[a.layer]).cloned().collect(),
            skinning: rig.skinning,
        };
        for e in &mut out.edges {
            (e.parent, e.child) = (at(e.parent), at(e.child));
        }
        for a in &mut out.accessories {
            a.layer = at(a.layer);
            for pin in &mut a.pins {
                pin.parent = at(pin.parent);
            }
        }
        (!out.accessories.is_empty()).then_some(out)
    });
    let layer_ref = |v: VertexRef| VertexRef { layer: at(v.layer), ..v };
    Ok(Puppet {
        width: puppet.width,
        height: puppet.height,
        layers: puppet
            .layers
            .iter()
            .zip(&dropped)
            .filter(|(_, &d)| !d)
            .map(|(l, _)| l.clone())
            .collect(),
        root: at(puppet.root),
        joints: puppet
            .joints
            .iter()
            .filter(|j| !dropped[j.a.layer] && !dropped[j.b.layer])
            .map(|j| Joint {
                a: layer_ref(j.a),
                b: layer_ref(j.b),
            })
            .collect(),
        rig,
    })
}

/// The body of `puppet` (its body layers, unchanged) wearing the accessories of `artwork`,
/// rigged with the artwork's `[rig]` overrides. The artwork is the same character drawn in
/// another outfit: its canvas is the puppet's, and its body layers are the puppet's, by name, in
/// the same order; its accessories are meshed with `build_options` and rigged with `options`.
/// The body keeps the puppet's meshes, textures and joints (the artwork's joints are ignored).
///
/// # Errors
/// [`Error::Mismatch`] for another canvas size; [`Error::Layer`] naming a body layer the puppet
/// does not have, one it has that the artwork lacks, or body layers out of the puppet's order;
/// whatever building and rigging the artwork reports.
pub fn dress(
    puppet: &Puppet,
    artwork: &Artwork,
    build_options: &BuildOptions,
    options: &RigOptions,
    progress: &dyn Progress,
) -> Result<Puppet> {
    let (width, height) = artwork.size();
    if (width, height) != (puppet.width, puppet.height) {
        return Err(Error::mismatch(
            "the outfit's canvas",
            format!("{width}×{height}"),
            format!("{}×{}, the puppet's", puppet.width, puppet.height),
        )
        .with_path(&artwork.source));
    }
    let body: Vec<usize> = (0..puppet.layers.len())
        .filter(|&l| puppet.layers[l].kind == LayerKind::Body)
        .collect();
    // The artwork's body layers, as indices of the puppet's, in the artwork's order.
    let mut matched = Vec::new();
    for layer in artwork.layers.iter().filter(|l| l.kind == LayerKind::Body) {
        match body.iter().find(|&&b| puppet.layers[b].name == layer.name) {
            Some(&b) => matched.push(b),
            None => {
                return Err(Error::layer(
                    &artwork.source,
                    &layer.name,
                    "is a body layer the puppet does not have (an outfit adds accessories only)",
                ))
            }
        }
    }
    if let Some(&missing) = body.iter().find(|b| !matched.contains(b)) {
        return Err(Error::layer(
            &artwork.source,
            &puppet.layers[missing].name,
            "is a body layer of the puppet the outfit does not draw (list it, to place the accessories in depth)",
        ));
    }
    if matched != body {
        return Err(Error::layer(
            &artwork.source,
            &puppet.layers[matched[matched.iter().zip(&body).position(|(a, b)| a != b).unwrap_or(0)]].name,
            "body layers are in another order than the puppet's",
        ));
    }
    for layer in artwork.layers.iter().filter(|l| l.kind == LayerKind::Body) {
        let mine = &puppet.layers[puppet.layer_index(&layer.name).expect("matched above")].texture;
        let overlap = coverage(&layer.picture, mine);
        if overlap < BODY_MATCH_WARNING {
            progress.warn(&format!(
                "{}: body layer {:?} lies {:.0} % inside the puppet's only (drawn for another body?)",
                artwork.source.display(),
                layer.name,
                overlap * 100.0
            ));
        }
    }
    // The body's hinges are the puppet's: the artwork's own joints (if it lists any) are not built.
    let unjoined = Artwork {
        joint_pairs: Some(Vec::new()),
        ..artwork.clone()
    };
    // Its warnings would be about the unjoined body, which is not the one kept; what matters about
    // the accessories (a layer that cannot be meshed or rigged) comes back as an error.
    let (mut dressed, _) = build(&unjoined, build_options, &crate::progress::Silent)?;
    // Layer index in the dressed puppet of each of the puppet's body layers.
    let mut index = vec![usize::MAX; puppet.layers.len()];
    for &b in &body {
        index[b] = dressed
            .layer_index(&puppet.layers[b].name)
            .expect("every body layer is in the artwork");
    }
    let to_dressed = |l: usize| index[l];
    let joints: Vec<Joint> = puppet
        .joints
        .iter()
        .filter(|j| puppet.layers[j.a.layer].kind == LayerKind::Body && puppet.layers[j.b.layer].kind == LayerKind::Body)
        .map(|j| Joint {
            a: VertexRef {
                layer: to_dressed(j.a.layer),
                ..j.a
            },
            b: VertexRef {
                layer: to_dressed(j.b.layer),
                ..j.b
            },
        })
        .collect();
    for &b in &body {
        let at = to_dressed(b);
        dressed.layers[at] = puppet.layers[b].clone();
    }
    dressed.root = to_dressed(puppet.root);
    dressed.joints = joints;
    dressed.rig = None;
    let mesh = build_options.mesh_options(width, height);
    rig_puppet(&dressed, &artwork.rig, &mesh, options, progress)
}

/// The share of `a`'s covered pixels (alpha above one half) that `b` covers too.
fn coverage(a: &Picture, b: &Picture) -> f32 {
    let (mut both, mut mine) = (0usize, 0usize);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let x = p[3] > 0.5;
        both += usize::from(x && q[3] > 0.5);
        mine += usize::from(x);
    }
    if mine == 0 {
        1.0
    } else {
        both as f32 / mine as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::rig::deform::RigMap;
    use crate::test_util::dressed_puppet;

    /// Panics unless `p` passes the checks of loading a saved puppet folder.
    fn consistent(p: &Puppet) {
        let dir = tempfile::tempdir().unwrap();
        crate::puppet::format::save(p, dir.path()).unwrap();
        let loaded = crate::puppet::format::load(dir.path()).unwrap();
        assert_eq!((loaded.layers.len(), loaded.vertex_count()), (p.layers.len(), p.vertex_count()));
    }

    #[test]
    fn undressing_drops_the_layer_and_keeps_the_body_and_its_rig_consistent() {
        let puppet = dressed_puppet();
        let bare = undress(&puppet, &["arm_front".to_string()], &Silent).unwrap();
        assert_eq!(bare.layers.len(), puppet.layers.len() - 1);
        assert!(bare.rig.is_none());
        assert_eq!(bare.free_vertices().len(), puppet.free_vertices().len());
        assert_eq!(bare.layers[bare.root].name, "torso");
        consistent(&bare);
        for name in ["torso", "nothing"] {
            let e = undress(&puppet, &[name.to_string()], &Silent).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains("arm_front"), "{e}");
        }
    }

    #[test]
    fn undressing_a_parent_drops_its_children_and_remaps_the_rest() {
        // Two accessories, one hanging from the other: the back arm follows the front one.
        let mut p = crate::test_util::layered_puppet();
        for name in ["arm_back", "arm_front"] {
            let l = p.layer_index(name).unwrap();
            p.layers[l].kind = LayerKind::Accessory;
        }
        let mesh = BuildOptions::default().mesh_options(p.width, p.height);
        let rigged = rig_puppet(&p, &Default::default(), &mesh, &RigOptions::default(), &Silent).unwrap();
        let rig = rigged.rig.as_ref().unwrap();
        let parent_of = |name: &str| {
            let l = rigged.layer_index(name).unwrap();
            rig.edges
                .iter()
                .find(|e| e.child == l)
                .map(|e| rigged.layers[e.parent].name.clone())
        };
        // Whichever accessory is the other's child, taking off its parent takes both.
        let (parent, child) = match (parent_of("arm_back").as_deref(), parent_of("arm_front").as_deref()) {
            (Some("arm_front"), _) => ("arm_front", "arm_back"),
            (_, Some("arm_back")) => ("arm_back", "arm_front"),
            _ => {
                // Both hang from the body: dropping one keeps the other, remapped.
                let bare = undress(&rigged, &["arm_back".to_string()], &Silent).unwrap();
                consistent(&bare);
                let before = rigged.rest_vertices();
                let mut pose = bare.rest_vertices();
                RigMap::new(&bare, bare.rig.as_ref().unwrap()).apply(&mut pose);
                let front = |q: &Puppet, v: &[[f32; 2]]| {
                    let l = q.layer_index("arm_front").unwrap();
                    let o = q.vertex_offsets();
                    v[o[l]..o[l + 1]].to_vec()
                };
                let moved = front(&bare, &pose)
                    .iter()
                    .zip(front(&rigged, &before))
                    .map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs())
                    .fold(0.0f32, f32::max);
                assert!(moved < 1e-3, "the kept accessory moved {moved} px at rest");
                return;
            }
        };
        let bare = undress(&rigged, &[parent.to_string()], &Silent).unwrap();
        assert!(bare.layer_index(child).is_none() && bare.rig.is_none());
    }

    /// The artwork a user would draw for `puppet`: one full-canvas picture per layer.
    fn artwork_of(puppet: &Puppet) -> Artwork {
        Artwork {
            source: "outfit".into(),
            name: "outfit".into(),
            layers: puppet
                .layers
                .iter()
                .map(|l| crate::puppet::artwork::ArtLayer {
                    name: l.name.clone(),
                    kind: l.kind,
                    picture: l.texture.clone(),
                })
                .collect(),
            root: puppet.root,
            joint_pairs: Some(Vec::new()),
            rig: Default::default(),
        }
    }

    #[test]
    fn dressing_a_bare_body_puts_the_accessory_on_without_touching_the_body() {
        let worn = dressed_puppet();
        let bare = undress(&worn, &["arm_front".to_string()], &Silent).unwrap();
        let art = artwork_of(&worn);
        let dressed = dress(&bare, &art, &BuildOptions::default(), &RigOptions::default(), &Silent).unwrap();
        consistent(&dressed);
        assert_eq!(dressed.layers.len(), 4);
        for l in bare.layers.iter() {
            assert_eq!(Some(l), dressed.layers.iter().find(|d| d.name == l.name), "body layer {}", l.name);
        }
        let body = |q: &Puppet| q.free_vertices().iter().map(|&g| q.rest_vertices()[g]).collect::<Vec<_>>();
        assert_eq!(body(&bare), body(&dressed), "the network's outputs keep their meaning");
        assert!(dressed.rig.is_some());

        // Refusals name what is wrong.
        let mut missing = art.clone();
        missing.layers.retain(|l| l.name != "head");
        missing.root = missing.layers.iter().position(|l| l.name == "torso").unwrap();
        let e = dress(&bare, &missing, &BuildOptions::default(), &RigOptions::default(), &Silent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("head") && e.contains("outfit"), "{e}");
        let mut swapped = art.clone();
        swapped.layers.swap(0, 1);
        swapped.root = 0;
        let e = dress(&bare, &swapped, &BuildOptions::default(), &RigOptions::default(), &Silent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("order"), "{e}");
        let mut small = art.clone();
        for l in &mut small.layers {
            l.picture = Picture::filled(8, 8, [0.0; 4]);
        }
        let e = dress(&bare, &small, &BuildOptions::default(), &RigOptions::default(), &Silent)
            .unwrap_err()
            .to_string();
        assert!(e.contains("8×8"), "{e}");
    }
}
