//! `puppet retarget` end to end on the tiny test character with a small untrained model: the
//! shipped BVH walk and another character's poses played on it, the result exported to Spine,
//! and every bad input of issue 57 — a skeleton that matches no layer, another layer tree
//! without a map, a file that is not a motion, a malformed BVH file — refused with an error
//! naming the file, nothing written.

use std::path::Path;

use crate::edit::{s, setup};
use crate::util::{puppet, repo, Run};
use puppet::puppet::pose_file::PoseFile;

/// The shipped walk.
fn walk() -> String {
    repo().join("data/motion/walk.bvh").to_str().unwrap().to_string()
}

/// Runs `puppet retarget` with `model` on `motion` into `out`, then `extra`.
fn retarget(tmp: &Path, model: &Path, motion: &str, out: &str, extra: &[&str]) -> Run {
    puppet(tmp, &[&["retarget", "--model", s(model), motion, "-o", out][..], extra].concat())
}

#[test]
fn the_bvh_walk_plays_on_the_character_and_exports_to_spine() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let (model, _, _) = setup(t);
    std::fs::write(t.join("map.toml"), "[retarget]\nLeftArm = \"arm\"\n").unwrap();
    let run = retarget(
        t,
        &model,
        &walk(),
        "walk",
        &["--map", "map.toml", "--fps", "15", "--gif", "walk/walk.gif"],
    );
    run.assert_ok();
    assert!(
        run.stdout.contains("LeftArm → arm") && run.stdout.contains("Head → head"),
        "{}",
        run.stdout
    );
    // 36 frames at 30 frames a second, 1.17 s: 18 frames at 15.
    let out = t.join("walk");
    for k in [0, 17] {
        assert!(out.join(format!("frame_{k:03}.png")).is_file() && out.join(format!("frame_{k:03}.json")).is_file());
        assert!(out.join(format!("rigid/frame_{k:03}.png")).is_file());
    }
    assert!(!out.join("frame_018.png").exists());
    for file in ["sprites.png", "sprites.json", "walk.gif"] {
        assert!(out.join(file).is_file(), "{file}");
    }
    let atlas: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("sprites.json")).unwrap()).unwrap();
    assert!(atlas.to_string().contains("67"), "frames of 1000/15 ms: {atlas}");
    let spine = puppet(t, &["export", "spine", "--model", s(&model), s(&out), "-o", "spine"]);
    spine.assert_ok();
    assert!(spine.stdout.contains("walk (18 keys)"), "{}", spine.stdout);
    // The plain turns alone, on the spot.
    retarget(t, &model, &walk(), "rigid", &["--map", "map.toml", "--rigid", "--in-place"]).assert_ok();
    assert!(t.join("rigid/frame_035.json").is_file() && !t.join("rigid/rigid").exists());
}

#[test]
fn another_characters_poses_play_on_this_one() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let (model, _, _) = setup(t);
    // Two poses of the model's own character: at rest, and moved 2 px to the right.
    let p = puppet::puppet::format::load(&model.join("puppet")).unwrap();
    std::fs::create_dir_all(t.join("poses")).unwrap();
    for (k, dx) in [0.0, 2.0].into_iter().enumerate() {
        let pose = PoseFile {
            vertices: p.rest_vertices().iter().map(|v| [v[0] + dx, v[1]]).collect(),
        };
        std::fs::write(t.join(format!("poses/pose_{k}.json")), pose.to_json()).unwrap();
    }
    // Without the character they pose, pose files cannot be read.
    retarget(t, &model, "poses", "none", &[]).assert_error(&["poses", "--from"]);
    assert!(!t.join("none").exists());
    retarget(t, &model, "poses", "again", &["--from", s(&model), "--rigid"]).assert_ok();
    let moved: PoseFile = serde_json::from_slice(&std::fs::read(t.join("again/frame_001.json")).unwrap()).unwrap();
    let shift = moved.vertices[0][0] - p.rest_vertices()[0][0];
    assert!((shift - 2.0).abs() < 1e-3, "the root moved {shift} px, not 2");
}

/// Asserts `puppet retarget` of `motion` fails naming each of `needles`, and writes nothing.
fn refused(tmp: &Path, model: &Path, motion: &str, extra: &[&str], needles: &[&str]) {
    let out = tmp.join("refused");
    retarget(tmp, model, motion, s(&out), extra).assert_error(needles);
    assert!(!out.exists(), "{motion}: a refused retarget writes nothing");
}

#[test]
fn bad_motions_are_refused_naming_the_file_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup(tmp.path());
    let t = tmp.path();
    // A skeleton whose joints match no layer: both lists named.
    let odd = std::fs::read_to_string(walk())
        .unwrap()
        .replace("Head", "Bone1")
        .replace("Chest", "Bone2")
        .replace("Spine", "Bone3")
        .replace("LeftArm", "Bone4");
    std::fs::write(t.join("odd.bvh"), &odd).unwrap();
    refused(
        t,
        &model,
        "odd.bvh",
        &[],
        &[
            "odd.bvh",
            "no part of the motion matches",
            "\"Bone1\"",
            "\"torso\", \"head\", \"arm\"",
        ],
    );
    // Poses of another layer tree, with no map: the unmatched layers of both named.
    let art = crate::util::write_layer_character(&t.join("other_art"), "");
    let toml = std::fs::read_to_string(art.join("character.toml")).unwrap();
    let renamed = toml
        .replace("\"torso\"", "\"core\"")
        .replace("\"head\"", "\"knob\"")
        .replace("\"arm\"", "\"flap\"");
    std::fs::write(art.join("character.toml"), renamed).unwrap();
    puppet(t, &["build", s(&art), "-o", "other"]).assert_ok();
    let other = puppet::puppet::format::load(&t.join("other")).unwrap();
    let pose = PoseFile {
        vertices: other.rest_vertices(),
    };
    std::fs::write(t.join("other_pose.json"), pose.to_json()).unwrap();
    refused(
        t,
        &model,
        "other_pose.json",
        &["--from", "other"],
        &[
            "other_pose.json",
            "another layer tree",
            "\"knob\"",
            "\"flap\"",
            "\"head\"",
            "\"arm\"",
            "[retarget]",
        ],
    );
    // Not motions.
    refused(t, &model, s(&a), &[], &["a.png", "a PNG image, not a motion"]);
    refused(
        t,
        &model,
        s(&model.join("puppet/puppet.json")),
        &[],
        &["puppet.json", "a puppet.json, not a motion"],
    );
    refused(t, &model, s(&t.join("built")), &[], &["built", "a puppet folder, not a motion"]);
    refused(t, &model, s(&model), &[], &["model", "a trained model folder, not a motion"]);
    // Malformed BVH files: cut short, a wrong channel count, a short frame.
    let text = std::fs::read_to_string(walk()).unwrap();
    for (name, bad, needle) in [
        ("cut.bvh", text[..text.len() / 2].to_string(), "values, expected 66"),
        ("hierarchy.bvh", text[..text.find("MOTION").unwrap()].to_string(), "the file ends"),
        (
            "channels.bvh",
            text.replacen("CHANNELS 3", "CHANNELS 2", 1),
            "a channel past the 2 of CHANNELS",
        ),
        ("more.bvh", text.replacen("CHANNELS 3", "CHANNELS 4", 1), "is not a channel"),
        (
            "frames.bvh",
            text.replace("Frames: 36", "Frames: 40"),
            "40 frames announced, 36 found",
        ),
        ("huge.bvh", text.replace("Frames: 36", "Frames: 1000000000"), "above the limit"),
    ] {
        std::fs::write(t.join(name), bad).unwrap();
        refused(t, &model, name, &[], &[name, needle]);
    }
    // A map naming a joint the file does not have.
    std::fs::write(t.join("map.toml"), "[retarget]\nTail = \"arm\"\n").unwrap();
    refused(
        t,
        &model,
        &walk(),
        &["--map", "map.toml"],
        &["map.toml", "retarget.Tail", "has no part \"Tail\""],
    );
}
