//! Artwork forms and the puppet file: each form imports to the same layers, .ora round-trips,
//! joints land where parts overlap, puppet.json saves and loads losslessly.

use crate::util::{write_label_character, write_layer_character};
use puppet::picture::Picture;
use puppet::puppet::artwork::{self, ImportOptions};
use puppet::puppet::joints::{find_joints, unconnected_body_layers, JointOptions};
use puppet::puppet::{format, ora, Joint, Layer, LayerKind, Mesh, Puppet, VertexRef};

#[test]
fn layer_png_form_imports_layers_in_order() {
    let tmp = tempfile::tempdir().unwrap();
    let art = artwork::load(&write_layer_character(&tmp.path().join("c"), ""), &ImportOptions::default()).unwrap();
    let names: Vec<&str> = art.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["torso", "head", "arm"]);
    assert_eq!(art.name, "tiny");
    assert_eq!(art.root, 0);
    assert_eq!(art.size(), (64, 64));
}

#[test]
fn ora_round_trip_gives_the_same_artwork() {
    let tmp = tempfile::tempdir().unwrap();
    let art = artwork::load(&write_layer_character(&tmp.path().join("c"), ""), &ImportOptions::default()).unwrap();
    let path = tmp.path().join("tiny.ora");
    ora::save(&art, &path).unwrap();
    let back = artwork::load(&path, &ImportOptions::default()).unwrap();
    assert_eq!(back.layers, art.layers);
    assert_eq!(back.root, 0, "root is the body layer with the most opaque pixels: the torso");
}

#[test]
fn label_map_form_cuts_parts_and_extends_them_under_front_parts() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_label_character(&tmp.path().join("c"));
    let art = artwork::load(&dir, &ImportOptions::default()).unwrap();
    let reference = Picture::load(&dir.join("reference.png")).unwrap();
    // Compositing the parts gives the reference frame back: growth is hidden under front parts.
    assert_eq!(art.composite(), reference);
    // The arm (front) covers the torso from x = 40 in rows 26..34; the torso (back) grew 2 px
    // under it: pixel (41, 30) is now torso too, (42, 30) is 3 px from the torso and is not.
    let torso = &art.layers[0].picture;
    assert_eq!(torso.get(41, 30)[3], 1.0);
    assert_eq!(
        torso.get(41, 30)[..3],
        reference.get(39, 30)[..3],
        "colour copied from the nearest torso pixel"
    );
    assert_eq!(torso.get(42, 30)[3], 0.0);
    // The arm (frontmost) does not grow.
    let arm = &art.layers[2].picture;
    assert_eq!(arm.get(39, 30)[3], 0.0);
}

#[test]
fn joints_sit_at_overlap_centroids_of_overlapping_pairs() {
    let tmp = tempfile::tempdir().unwrap();
    let art = artwork::load(&write_layer_character(&tmp.path().join("c"), ""), &ImportOptions::default()).unwrap();
    let (sites, missing) = find_joints(&art, &JointOptions::default());
    assert!(missing.is_empty());
    let pairs: Vec<[usize; 2]> = sites.iter().map(|s| [s.a, s.b]).collect();
    assert_eq!(pairs, [[0, 1], [0, 2]], "torso–head and torso–arm; head and arm do not touch");
    // Torso–arm overlap is x 40..44, y 26..34: centroid (42, 30).
    assert_eq!(sites[1].point, [42.0, 30.0]);
    assert_eq!(sites[1].overlap, 32);
    assert!(unconnected_body_layers(&art, &sites).is_empty());
    assert_eq!(unconnected_body_layers(&art, &sites[..1]), ["arm"]);
}

#[test]
fn listed_joints_restrict_pairs_and_report_non_overlapping_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "joints = [[\"torso\", \"arm\"], [\"head\", \"arm\"]]");
    let art = artwork::load(&dir, &ImportOptions::default()).unwrap();
    let (sites, missing) = find_joints(&art, &JointOptions::default());
    assert_eq!(sites.len(), 1);
    assert_eq!([sites[0].a, sites[0].b], [0, 2]);
    assert_eq!(missing, [[1, 2]]);
}

/// A two-layer puppet made by hand (no mesher), with a joint.
fn hand_made_puppet() -> Puppet {
    let mut texture = Picture::filled(8, 6, [0.0; 4]);
    texture.pixels[9] = [0.2, 0.4, 0.6, 1.0];
    let square = Mesh {
        vertices: vec![[1.0, 1.0], [5.0, 1.0], [5.0, 4.0], [1.0, 4.0]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let tri = Mesh {
        vertices: vec![[4.0, 3.0], [7.5, 3.25], [4.125, 5.9]],
        triangles: vec![[0, 1, 2]],
    };
    let layer = |name: &str, kind, mesh: Mesh| Layer {
        name: name.into(),
        kind,
        uvs: mesh.vertices.iter().map(|v| [v[0] / 8.0, v[1] / 6.0]).collect(),
        mesh,
        texture: texture.clone(),
    };
    Puppet {
        width: 8,
        height: 6,
        layers: vec![layer("body", LayerKind::Body, square), layer("arm/left", LayerKind::Accessory, tri)],
        root: 0,
        joints: vec![Joint {
            a: VertexRef { layer: 0, vertex: 2 },
            b: VertexRef { layer: 1, vertex: 0 },
        }],
        rig: None,
    }
}

#[test]
fn puppet_json_round_trip_is_lossless() {
    let tmp = tempfile::tempdir().unwrap();
    let mut p = hand_made_puppet();
    // Values that need all of f32's digits.
    p.layers[1].mesh.vertices[1] = [7.0 + 1.0 / 3.0, 3.0 + std::f32::consts::PI / 10.0];
    format::save(&p, tmp.path()).unwrap();
    assert!(tmp.path().join("textures/01_arm_left.png").exists());
    assert_eq!(format::load(tmp.path()).unwrap(), p);
}

#[test]
fn puppet_json_with_a_broken_mesh_names_the_layer() {
    let tmp = tempfile::tempdir().unwrap();
    let mut p = hand_made_puppet();
    p.layers[0].mesh.triangles[1] = [0, 3, 2]; // clockwise
    format::save(&p, tmp.path()).unwrap();
    let err = format::load(tmp.path()).unwrap_err().to_string();
    assert!(err.contains("puppet.json: layer \"body\": triangle 1"), "{err}");
}

/// Issue 17: the robot written as .psd by Krita and by psd-tools (data/tools/make_psd.sh) builds
/// the same puppet as the same layers as PNGs: same names, kinds, meshes, joints, root and rig,
/// and textures that are byte-identical once written. The psd-tools file also holds a hidden
/// layer, which is skipped, and the accessory's non-ASCII name comes through both writers.
#[test]
fn psd_from_krita_and_psd_tools_builds_the_same_puppet_as_the_png_layers() {
    use puppet::progress::Silent;
    use puppet::puppet::build::BuildOptions;
    use puppet::rig::{build_rigged, RigOptions};
    let data = crate::util::repo().join("data/psd");
    let build = |path: &std::path::Path| {
        let art = artwork::load(path, &ImportOptions::default()).unwrap();
        build_rigged(&art, &BuildOptions::default(), &RigOptions::default(), &Silent).unwrap()
    };
    let folder = build(&data.join("robot_layers"));
    let names: Vec<&str> = folder.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(
        names,
        ["handle", "leg_l", "leg_r", "torso", "arm_l", "arm_r", "hand_l", "hand_r", "head", "étoile"]
    );
    assert_eq!(folder.layers[9].kind, LayerKind::Accessory);
    assert!(folder.rig.is_some(), "the star is rigged to the body");
    for file in ["robot_krita.psd", "robot_psd_tools.psd"] {
        let psd = build(&data.join(file));
        for (a, b) in folder.layers.iter().zip(&psd.layers) {
            assert_eq!((&a.name, a.kind, &a.mesh, &a.uvs), (&b.name, b.kind, &b.mesh, &b.uvs), "{file}");
            assert_eq!(
                a.texture.to_rgba8().into_raw(),
                b.texture.to_rgba8().into_raw(),
                "{file}: {:?}",
                a.name
            );
        }
        assert_eq!(psd, folder, "{file}");
    }
}

/// A `character.toml` beside a layered file sets its layers' kinds, root, name and joints; one of
/// another form (a label map's, as beside data/kenney/robot/robot.ora) is not applied; a layer the
/// file lacks is an error naming both files.
#[test]
fn a_character_toml_beside_a_psd_or_ora_overrides_kinds_root_and_joints() {
    let tmp = tempfile::tempdir().unwrap();
    let data = crate::util::repo().join("data");
    for (file, from) in [("robot.psd", "psd/robot_psd_tools.psd"), ("robot.ora", "kenney/robot/robot.ora")] {
        let dir = tmp.path().join(file.replace('.', "_"));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(file);
        std::fs::copy(data.join(from), &path).unwrap();
        let plain = artwork::load(&path, &ImportOptions::default()).unwrap();
        let toml =
            "name = \"bot\"\nroot = \"torso\"\njoints = [[\"torso\", \"head\"]]\n[[layer]]\nname = \"handle\"\nkind = \"accessory\"\n";
        std::fs::write(dir.join("character.toml"), toml).unwrap();
        let art = artwork::load(&path, &ImportOptions::default()).unwrap();
        let index = |name: &str| art.layers.iter().position(|l| l.name == name).unwrap();
        assert_eq!(art.name, "bot", "{file}");
        assert_eq!(art.root, index("torso"), "{file}");
        assert_eq!(art.layers[index("handle")].kind, LayerKind::Accessory, "{file}");
        assert_eq!(art.joint_pairs, Some(vec![[index("torso"), index("head")]]), "{file}");
        assert_eq!(art.layers.len(), plain.layers.len());

        std::fs::write(
            dir.join("character.toml"),
            "root = \"torso\"\n[[layer]]\nname = \"nope\"\nkind = \"accessory\"\n",
        )
        .unwrap();
        let err = artwork::load(&path, &ImportOptions::default()).unwrap_err().to_string();
        assert!(
            err.contains("character.toml") && err.contains("nope") && err.contains(file),
            "{err}"
        );
        std::fs::write(
            dir.join("character.toml"),
            "root = \"handle\"\n[[layer]]\nname = \"handle\"\nkind = \"accessory\"\n",
        )
        .unwrap();
        let err = artwork::load(&path, &ImportOptions::default()).unwrap_err().to_string();
        assert!(err.contains("root must be a body layer"), "{err}");
        std::fs::write(dir.join("character.toml"), "root = \"torso\"\nlabel = 3\n").unwrap();
        assert!(
            artwork::load(&path, &ImportOptions::default())
                .unwrap_err()
                .to_string()
                .contains("label"),
            "a misspelt key is an error"
        );

        std::fs::copy(data.join("kenney/robot/character.toml"), dir.join("character.toml")).unwrap();
        let labelled = artwork::load(&path, &ImportOptions::default()).unwrap();
        assert_eq!(
            (labelled.root, &labelled.name),
            (plain.root, &plain.name),
            "a label map's character.toml is not this file's"
        );
    }
}
