//! What every accepted import or puppet keeps, shared by the targets that produce one.

// Each target includes this file and uses only its own checks.
#![allow(dead_code)]

use puppet::puppet::artwork::{ArtLayer, Artwork};
use puppet::puppet::{LayerKind, Puppet};

/// Layers of one size, every channel of every pixel in [0, 1].
pub fn check_layers(layers: &[ArtLayer]) {
    let Some(first) = layers.first() else { return };
    let size = (first.picture.width, first.picture.height);
    for layer in layers {
        assert_eq!((layer.picture.width, layer.picture.height), size, "layer {:?}", layer.name);
        let bad = layer.picture.pixels.iter().flatten().find(|c| !(0.0..=1.0).contains(*c));
        assert!(bad.is_none(), "layer {:?}: channel {bad:?} outside [0, 1]", layer.name);
    }
}

/// At least one layer, all of one size and none fully transparent, and a root that is a body
/// layer (what the `.ora` import checks).
pub fn check_artwork(art: &Artwork) {
    assert!(!art.layers.is_empty());
    check_layers(&art.layers);
    for layer in &art.layers {
        assert!(layer.picture.pixels.iter().any(|p| p[3] > 0.0), "layer {:?} is empty", layer.name);
    }
    assert_eq!(art.layers[art.root].kind, LayerKind::Body);
}

/// What `puppet.json` promises: valid meshes, one UV per vertex, textures of the puppet's size,
/// joints and the rig indexing real layers and vertices.
pub fn check_puppet(p: &Puppet) {
    assert!(p.root < p.layers.len());
    for layer in &p.layers {
        layer.mesh.check_invariants().expect("an accepted mesh keeps its invariants");
        for &t in &layer.mesh.triangles {
            let area = layer.mesh.signed_area(t);
            assert!(
                area > 0.0 && area.is_finite(),
                "layer {:?}: triangle {t:?} of area {area}",
                layer.name
            );
        }
        assert_eq!(layer.uvs.len(), layer.mesh.vertices.len());
        assert!(
            layer.uvs.iter().flatten().all(|c| c.is_finite()),
            "layer {:?}: a UV is not finite",
            layer.name
        );
        assert_eq!((layer.texture.width, layer.texture.height), (p.width, p.height));
    }
    for j in &p.joints {
        for end in [j.a, j.b] {
            assert!((end.vertex as usize) < p.layers[end.layer].mesh.vertices.len());
        }
    }
    if let Some(rig) = &p.rig {
        rig.check(p).expect("an accepted rig passes its check");
    }
}
