//! Every subcommand end to end on `data/` and on tiny characters written by the test.

use crate::util::{puppet, repo, write_hatted_character, write_label_character, write_layer_character};
use puppet::puppet::format;

/// Builds `artwork` into `tmp/out` and checks the puppet and its preview.
fn build_and_check(tmp: &std::path::Path, artwork: &std::path::Path, layers: usize) -> puppet::puppet::Puppet {
    let out = tmp.join("out");
    let run = puppet(tmp, &["build", artwork.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    run.assert_ok();
    assert!(run.stdout.contains("preview.png"), "{}", run.stdout);
    let p = format::load(&out).unwrap();
    assert_eq!(p.layers.len(), layers);
    for layer in &p.layers {
        layer.mesh.check_invariants().unwrap();
        assert!(
            layer.mesh.min_angle_degrees() >= 25.0,
            "layer {:?}: min angle {}",
            layer.name,
            layer.mesh.min_angle_degrees()
        );
    }
    let preview = image::open(out.join("preview.png")).unwrap();
    assert!(preview.width() >= p.width * 4, "preview is upscaled for small sprites");
    p
}

#[test]
fn build_and_info_on_layer_pngs() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_layer_character(&tmp.path().join("c"), "");
    let p = build_and_check(tmp.path(), &art, 3);
    assert_eq!(p.joints.len(), 2);
    let info = puppet(tmp.path(), &["info", "out"]);
    info.assert_ok();
    assert!(info.stdout.contains("torso ↔ arm at (42.0, 30.0)"), "{}", info.stdout);
    assert!(info.stdout.contains("joints (2)"), "{}", info.stdout);
}

#[test]
fn build_on_a_label_map_and_an_ora_gives_the_same_layers() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_label_character(&tmp.path().join("c"));
    let from_labels = build_and_check(tmp.path(), &art, 3);
    let names: Vec<&str> = from_labels.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["torso", "head", "arm"]);
    assert_eq!(from_labels.joints.len(), 2);
    // The same layers saved as OpenRaster build the same meshes.
    let artwork = puppet::puppet::artwork::load(&art, &Default::default()).unwrap();
    let ora = tmp.path().join("tiny.ora");
    puppet::puppet::ora::save(&artwork, &ora).unwrap();
    let out = tmp.path().join("from_ora");
    puppet(tmp.path(), &["build", ora.to_str().unwrap(), "-o", out.to_str().unwrap()]).assert_ok();
    let from_ora = format::load(&out).unwrap();
    for (a, b) in from_labels.layers.iter().zip(&from_ora.layers) {
        assert_eq!((&a.name, &a.mesh), (&b.name, &b.mesh));
    }
}

#[test]
fn subdivision_multiplies_triangles_by_four() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_layer_character(&tmp.path().join("c"), "");
    let plain = build_and_check(tmp.path(), &art, 3);
    let out = tmp.path().join("sub");
    puppet(
        tmp.path(),
        &["build", art.to_str().unwrap(), "-o", out.to_str().unwrap(), "--subdivide", "1"],
    )
    .assert_ok();
    let sub = format::load(&out).unwrap();
    for (a, b) in plain.layers.iter().zip(&sub.layers) {
        assert_eq!(b.mesh.triangles.len(), 4 * a.mesh.triangles.len(), "layer {:?}", a.name);
    }
    // Joints are still exact: both ends at the same position.
    for j in &sub.joints {
        assert_eq!(
            sub.layers[j.a.layer].mesh.vertices[j.a.vertex as usize],
            sub.layers[j.b.layer].mesh.vertices[j.b.vertex as usize]
        );
    }
}

#[test]
fn unconnected_body_layer_is_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = write_layer_character(&tmp.path().join("c"), "");
    let mut far = image::RgbaImage::new(64, 64);
    for y in 56..62 {
        for x in 2..10 {
            far.put_pixel(x, y, image::Rgba([9, 9, 9, 255]));
        }
    }
    far.save(dir.join("tail.png")).unwrap();
    let toml = std::fs::read_to_string(dir.join("character.toml")).unwrap();
    std::fs::write(
        dir.join("character.toml"),
        format!("{toml}[[layer]]\nname = \"tail\"\nfile = \"tail.png\"\n"),
    )
    .unwrap();
    puppet(tmp.path(), &["build", "c", "-o", "out"])
        .assert_ok_warning("c/character.toml: no joint connects these body layers to the root \"torso\": tail");
}

/// The bundled Kenney characters: every part meshed, joints where parts meet.
fn kenney(name: &str, expected_joints: &[[&str; 2]]) {
    let tmp = tempfile::tempdir().unwrap();
    let art = repo().join("data/kenney").join(name);
    let character = puppet::puppet::character::CharacterFile::load(&art.join("character.toml")).unwrap();
    let p = build_and_check(tmp.path(), &art, character.layers.len());
    let joined: Vec<[&str; 2]> = p
        .joints
        .iter()
        .map(|j| [p.layers[j.a.layer].name.as_str(), p.layers[j.b.layer].name.as_str()])
        .collect();
    for pair in expected_joints {
        let found = joined
            .iter()
            .any(|j| (j[0] == pair[0] && j[1] == pair[1]) || (j[0] == pair[1] && j[1] == pair[0]));
        assert!(found, "{name}: no joint {pair:?} among {joined:?}");
    }
    let run = puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", "again"]);
    assert!(!run.stderr.contains("warning"), "{name}: {}", run.stderr);
}

#[test]
fn build_kenney_robot() {
    kenney("robot", &[["torso", "head"]]);
}

#[test]
fn build_kenney_male_adventurer() {
    kenney("male_adventurer", &[["torso", "head"]]);
}

#[test]
fn build_kenney_female_adventurer() {
    kenney("female_adventurer", &[["torso", "head"]]);
}

#[test]
fn build_the_ora_that_gimp_wrote() {
    let tmp = tempfile::tempdir().unwrap();
    let ora = repo().join("data/kenney/robot/robot.ora");
    let labels = puppet::puppet::artwork::load(&repo().join("data/kenney/robot"), &Default::default()).unwrap();
    let p = build_and_check(tmp.path(), &ora, labels.layers.len());
    assert!(!p.joints.is_empty());
}

/// Issue 17: `puppet build` on the .psd Krita wrote: the robot's nine parts and the star, which
/// the `accessories` group makes an accessory and the build rigs.
#[test]
fn build_the_psd_that_krita_wrote() {
    let tmp = tempfile::tempdir().unwrap();
    let p = build_and_check(tmp.path(), &repo().join("data/psd/robot_krita.psd"), 10);
    assert!(!p.joints.is_empty());
    assert_eq!(p.rig.as_ref().map(|r| r.accessories.len()), Some(1));
}

/// Issue 17: a blend mode the import cannot reproduce is a warning on stderr naming the file,
/// the layer and the mode, and the build goes on with the layer drawn as normal.
#[test]
fn build_warns_of_a_psd_layer_in_multiply_mode() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bytes = std::fs::read(repo().join("data/psd/robot_psd_tools.psd")).unwrap();
    // The first layer record's blend mode (the handle, bottom first).
    let at = bytes.windows(8).position(|w| w == b"8BIMnorm").unwrap();
    bytes[at + 4..at + 8].copy_from_slice(b"mul ");
    std::fs::write(tmp.path().join("robot.psd"), bytes).unwrap();
    puppet(tmp.path(), &["build", "robot.psd", "-o", "out"])
        .assert_ok_warning("robot.psd: layer \"handle\": blend mode \"multiply\" is not supported; drawn as normal");
}

#[test]
fn render_rest_pose_reproduces_the_artwork_and_rejects_a_foreign_pose() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_layer_character(&tmp.path().join("c"), "");
    build_and_check(tmp.path(), &art, 3);
    puppet(tmp.path(), &["render", "out", "-o", "rest.png"]).assert_ok();
    let rendered = puppet::picture::Picture::load(&tmp.path().join("rest.png")).unwrap();
    let artwork = puppet::puppet::artwork::load(&art, &Default::default()).unwrap().composite();
    let differing = rendered
        .pixels
        .iter()
        .zip(&artwork.pixels)
        .filter(|(a, b)| (a[3] > 0.5) != (b[3] > 0.5))
        .count();
    assert!(
        differing <= 8,
        "{differing} pixels differ in coverage between the crisp rest render and the artwork"
    );
    std::fs::write(tmp.path().join("pose.json"), r#"{"vertices": [[1.0, 2.0]]}"#).unwrap();
    puppet(tmp.path(), &["render", "out", "--pose", "pose.json", "-o", "x.png"])
        .assert_error(&["pose.json", "1 vertices, but the puppet has"]);
}

/// The tiny character with a hat: an accessory band over the top of the head disc.
#[test]
fn rig_previews_applies_a_pose_and_eval_rig_scores_a_set() {
    let tmp = tempfile::tempdir().unwrap();
    let set = tmp.path().join("set");
    let art = write_hatted_character(&set.join("hatted"));
    std::fs::write(art.join("rig_truth.json"), r#"{"attach_to": {"hat": "head"}}"#).unwrap();
    let p = build_and_check(tmp.path(), &art, 4);
    let rig = p.rig.as_ref().expect("an accessory makes a rig");
    assert_eq!(rig.accessories.len(), 1);

    let preview = puppet(tmp.path(), &["rig", "out", "-o", "rig.png"]);
    preview.assert_ok();
    assert!(preview.stdout.contains("1 accessories"), "{}", preview.stdout);
    assert!(tmp.path().join("rig.png").is_file());

    // The head moved 4 px right: with the rig the hat goes with it, without it stays.
    let head = p.layers.iter().position(|l| l.name == "head").unwrap();
    let offsets = p.vertex_offsets();
    let mut pose = p.rest_vertices();
    for v in &mut pose[offsets[head]..offsets[head + 1]] {
        v[0] += 4.0;
    }
    let json = serde_json::to_string(&serde_json::json!({ "vertices": pose })).unwrap();
    std::fs::write(tmp.path().join("pose.json"), json).unwrap();
    puppet(tmp.path(), &["rig", "apply", "out", "--pose", "pose.json", "-o", "apply.png"]).assert_ok();
    let sheet = puppet::picture::Picture::load(&tmp.path().join("apply.png")).unwrap();
    let half = sheet.width / 2;
    let scale = half / 64;
    // The hat's right edge (x = 42 at rest) is dark in the rigged half at x = 44 only.
    let dark = |x0: u32, x: f32| {
        let px = sheet.get(x0 + (x * scale as f32) as u32, 8 * scale);
        px[0] < 0.3
    };
    assert!(!dark(0, 44.0) && dark(half, 44.0), "the hat does not follow the head");

    let report = tmp.path().join("report.json");
    let eval = puppet(
        tmp.path(),
        &["eval-rig", "set", "-o", report.to_str().unwrap(), "--pictures", "pics"],
    );
    eval.assert_ok();
    assert!(eval.stdout.contains("hatted"), "{}", eval.stdout);
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let dag = &json["characters"][0]["dag"];
    assert_eq!((dag["judged"].as_u64(), dag["strict"].as_u64()), (Some(1), Some(1)), "{dag}");
    // The third row of the sheet is the head tilted 12°: the hat left at rest uncovers the
    // head's outline, dotted red in the third column; the rig's hat keeps it covered.
    let pics = puppet::picture::Picture::load(&tmp.path().join("pics/hatted.png")).unwrap();
    let red_in_column = |k: u32| {
        let (w, h) = (pics.width / 3, pics.height / 6);
        (k * w..(k + 1) * w)
            .flat_map(|x| (2 * h..3 * h).map(move |y| (x, y)))
            .filter(|&(x, y)| {
                let p = pics.get(x, y);
                p[0] > 0.85 && p[1] < 0.15 && p[2] < 0.15
            })
            .count()
    };
    assert!(
        red_in_column(2) > 20 && red_in_column(0) < red_in_column(2) / 4,
        "{} {}",
        red_in_column(0),
        red_in_column(2)
    );

    // A puppet without accessories has no rig to draw; a pose of another puppet is refused.
    let plain = write_layer_character(&tmp.path().join("plain"), "");
    puppet(tmp.path(), &["build", plain.to_str().unwrap(), "-o", "plain_out"]).assert_ok();
    puppet(tmp.path(), &["rig", "plain_out", "-o", "p.png"]).assert_error(&["plain_out", "no accessory rig"]);
    assert!(!tmp.path().join("p.png").exists());
    std::fs::write(tmp.path().join("short.json"), r#"{"vertices": [[1.0, 2.0]]}"#).unwrap();
    puppet(tmp.path(), &["rig", "apply", "out", "--pose", "short.json", "-o", "b.png"]).assert_error(&["short.json", "1 vertices"]);
}

/// `puppet synth --accessories --trim` makes a rig evaluation member with truth: the DAG is
/// judged against the generator's parents and the rig is scored along the true motion, where it
/// must place the accessories far better than leaving them at rest.
#[test]
fn eval_rig_scores_a_dressed_synthetic_sequence_along_its_true_motion() {
    let tmp = tempfile::tempdir().unwrap();
    puppet(
        tmp.path(),
        &[
            "synth",
            "--accessories",
            "--trim",
            "--seed",
            "3",
            "--frames",
            "6",
            "--size",
            "128x128",
            "-o",
            "set/dressed",
        ],
    )
    .assert_ok();
    let edits = tmp.path().join("edits.toml");
    std::fs::write(
        &edits,
        "[[edit]]\nname = \"tilt\"\nkind = \"tilt\"\nlayer = \"head\"\ndegrees = 12.0\n",
    )
    .unwrap();
    let eval = puppet(
        tmp.path(),
        &[
            "eval-rig",
            "set",
            "--edits",
            "edits.toml",
            "-o",
            "report.json",
            "--pictures",
            "pics",
        ],
    );
    eval.assert_ok();
    assert!(eval.stdout.contains("true motion"), "{}", eval.stdout);
    let sheet = puppet::picture::Picture::load(&tmp.path().join("pics/dressed_motion.png")).unwrap();
    // Four columns (rig, truth, sticker, unchanged) and six frames of 128² drawn at 2×, 2 px apart.
    assert_eq!((sheet.width, sheet.height), (4 * 256 + 5 * 2, 6 * 256 + 7 * 2));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(tmp.path().join("report.json")).unwrap()).unwrap();
    let c = &json["characters"][0];
    // Eight accessories, the trim on the vest among them: an accessory → accessory edge, whose
    // shared boundary the rig keeps (the seam's change under the tilt, 95th percentile, px).
    assert_eq!(
        (c["dag"]["judged"].as_u64(), c["dag"]["strict"].as_u64()),
        (Some(8), Some(8)),
        "{}",
        c["dag"]
    );
    let seam = c["edits"][0]["rig"]["seam_change_p95"]
        .as_f64()
        .expect("a coincident seam to score");
    assert!(seam < 1.0, "{seam}");
    let motion = &c["motion"];
    assert_eq!(motion["frames"].as_u64(), Some(6));
    let (rig, unchanged) = (&motion["rig"], &motion["unchanged"]);
    let f = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap();
    eprintln!("rig {rig}\nunchanged {unchanged}");
    assert!(f(rig, "accessory_error") < 0.5 * f(unchanged, "accessory_error"), "{motion}");
    assert!(f(rig, "accessory_iou") > f(unchanged, "accessory_iou"), "{motion}");
}

#[test]
fn a_dicebear_character_of_thin_line_art_builds_and_rigs() {
    // notionists-1's lips and nose are one-stroke line art: refinement at 30° does not finish on
    // them, and the mesher falls back to a lower angle bound instead of refusing the layer.
    let tmp = tempfile::tempdir().unwrap();
    let art = repo().join("data/rigs/dicebear/notionists-1");
    let out = tmp.path().join("out");
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", out.to_str().unwrap()]).assert_ok();
    let p = format::load(&out).unwrap();
    assert_eq!(p.layers.len(), 7);
    for layer in &p.layers {
        layer.mesh.check_invariants().unwrap();
    }
    let rig = p.rig.as_ref().expect("accessories make a rig");
    assert_eq!(rig.accessories.len(), 5);
    let truth: serde_json::Value = serde_json::from_slice(&std::fs::read(art.join("rig_truth.json")).unwrap()).unwrap();
    for edge in &rig.edges {
        let (child, parent) = (&p.layers[edge.child].name, &p.layers[edge.parent].name);
        assert_eq!(truth["attach_to"][child].as_str(), Some(parent.as_str()), "{child}");
    }
}

/// An edit that moves nothing keeps every hidden outline sample covered, on real art whose
/// outline pixels lie partly outside the layer's mesh (the sample is where the mesh puts it).
#[test]
fn eval_rig_keeps_the_whole_hidden_outline_under_an_edit_that_moves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let set = tmp.path().join("set");
    std::fs::create_dir(&set).unwrap();
    let art = repo().join("data/rigs/dicebear/personas-4");
    let member = set.join("personas-4");
    std::fs::create_dir(&member).unwrap();
    for entry in std::fs::read_dir(&art).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, member.join(path.file_name().unwrap())).unwrap();
    }
    let edits = tmp.path().join("edits.toml");
    std::fs::write(
        &edits,
        "[[edit]]\nname = \"still\"\nkind = \"widen\"\nlayer = \"head\"\nfactor = 1.0\n",
    )
    .unwrap();
    let report = tmp.path().join("report.json");
    puppet(
        tmp.path(),
        &[
            "eval-rig",
            "set",
            "--edits",
            edits.to_str().unwrap(),
            "-o",
            report.to_str().unwrap(),
        ],
    )
    .assert_ok();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for method in ["rig", "sticker", "unchanged"] {
        let scores = &json["characters"][0]["edits"][0][method];
        for key in ["occlusion_kept", "own_occlusion_kept"] {
            assert_eq!(scores[key].as_f64(), Some(1.0), "{method} {key}: {scores}");
        }
    }
}

/// Dense pins on real art: the active-set BBW of big-smile-6's seven-piece layer needs 341
/// iterations with a pin every 3.2 px, more than the old limit of 200 allowed; and the
/// overrides choose affine skinning.
#[test]
fn a_dicebear_character_rigs_with_pins_every_three_pixels() {
    let tmp = tempfile::tempdir().unwrap();
    let art = tmp.path().join("big-smile-6");
    std::fs::create_dir(&art).unwrap();
    for entry in std::fs::read_dir(repo().join("data/rigs/dicebear/big-smile-6")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, art.join(path.file_name().unwrap())).unwrap();
    }
    let toml = art.join("character.toml");
    let text = std::fs::read_to_string(&toml).unwrap();
    std::fs::write(&toml, format!("{text}\n[rig]\npin_spacing = 3.2\nskinning = \"affine\"\n")).unwrap();
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", "out"]).assert_ok();
    let p = format::load(&tmp.path().join("out")).unwrap();
    let rig = p.rig.as_ref().expect("a rig");
    assert_eq!(
        (rig.accessories.len(), rig.skinning),
        (4, puppet::puppet::rig_data::Skinning::Affine)
    );
    // A skinning the rig does not know is refused, naming the file and the value; nothing written.
    std::fs::write(&toml, format!("{text}\n[rig]\nskinning = \"sideways\"\n")).unwrap();
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", "refused"]).assert_error(&["character.toml", "sideways"]);
    assert!(!tmp.path().join("refused").exists());
    // So is a pin separation below zero, before anything is meshed.
    std::fs::write(&toml, format!("{text}\n[rig]\npin_separation = -1.0\n")).unwrap();
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", "refused"]).assert_error(&["character.toml", "rig.pin_separation", "-1"]);
    assert!(!tmp.path().join("refused").exists());
    // And a gap bridge wider than any notch.
    std::fs::write(&toml, format!("{text}\n[rig]\nbridge_gaps = 100.0\n")).unwrap();
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", "refused"]).assert_error(&["character.toml", "rig.bridge_gaps", "100"]);
    assert!(!tmp.path().join("refused").exists());
}
