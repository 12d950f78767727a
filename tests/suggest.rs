//! `puppet suggest` and the continuation it leads to, `puppet train --from`, end to end on a
//! tiny synthetic character (seconds): suggestions written and readable, a pool of true poses
//! ranked, the drawn frame added and the model continued with its held-out frames kept, and bad
//! input refused by name with nothing written.

use std::path::Path;

use crate::edit::s;
use crate::util::puppet;
use puppet::puppet::format;
use puppet::puppet::pose_file::PoseFile;

/// Synthetic character `seed` drawn in `frames` random poses at 64², `motion_seed` seeding them.
fn synth_character(dir: &Path, name: &str, seed: u64, motion_seed: u64, frames: usize) -> std::path::PathBuf {
    let seq = dir.join(name);
    let (seed, motion_seed, frames) = (seed.to_string(), motion_seed.to_string(), frames.to_string());
    let args = ["synth", "-o", s(&seq), "--seed", &seed, "--motion-seed", &motion_seed];
    let more = ["--motion", "random", "--frames", &frames, "--size", "64x64"];
    puppet(dir, &[&args[..], &more[..]].concat()).assert_ok();
    seq
}

/// Synthetic character 8 (as [`synth_character`]).
fn synth(dir: &Path, name: &str, motion_seed: u64, frames: usize) -> std::path::PathBuf {
    synth_character(dir, name, 8, motion_seed, frames)
}

/// Trains a tiny model of `seq` (a quarter of its frames held out) into `dir/model`.
fn train(dir: &Path, seq: &Path) -> std::path::PathBuf {
    let text = format!(
        "puppet = \"{seq}/template\"\nframes = \"{seq}/frames\"\noutput = \"model\"\ntest_fraction = 0.25\n\
         [model]\ninput_size = 32\nlatent = 32\n[train]\nsteps = 8\nbatch = 4\nsigma = [1.0, 1.0]\n",
        seq = seq.display()
    );
    std::fs::write(dir.join("train.toml"), text).unwrap();
    puppet(dir, &["train", "train.toml"]).assert_ok();
    dir.join("model")
}

fn split(model: &Path) -> (Vec<String>, Vec<String>) {
    let record: serde_json::Value = serde_json::from_slice(&std::fs::read(model.join("split.json")).unwrap()).unwrap();
    let names = |k: &str| {
        record[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect()
    };
    (names("train"), names("test"))
}

#[test]
fn suggestions_are_written_and_a_drawing_of_one_continues_the_model() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let seq = synth(t, "seq", 3, 8);
    let model = train(t, &seq);
    let built = format::load(&model.join("puppet")).unwrap();

    let run = puppet(t, &["suggest", "--model", s(&model), "-n", "2", "--turned", "12", "-o", "next"]);
    run.assert_ok();
    assert!(
        run.stdout.contains("next_1: misread") && run.stdout.contains("candidates"),
        "{}",
        run.stdout
    );
    for f in ["next_1.png", "next_2.png", "sheet.png", "suggestions.json"] {
        assert!(t.join("next").join(f).is_file(), "{f}");
    }
    let pose = PoseFile::load(&t.join("next/next_1.json"), &built).unwrap();
    assert_eq!(pose.vertices.len(), built.vertex_count());
    let listing: serde_json::Value = serde_json::from_slice(&std::fs::read(t.join("next/suggestions.json")).unwrap()).unwrap();
    assert_eq!(listing["suggestions"].as_array().unwrap().len(), 2, "{listing}");
    assert_eq!(listing["criterion"], "coverage");
    // The tiny model reads its frames alike, so the search widened past --margin's 25° to find
    // poses 12° from every drawn one.
    assert!(listing["margin_degrees"].as_f64().unwrap() > 25.0, "{listing}");
    for pick in listing["suggestions"].as_array().unwrap() {
        assert!(pick["distance_degrees"].as_f64().unwrap() >= 12.0, "{pick}");
    }

    // The generator as the artist: its frames' true poses ranked, farthest first too.
    let pool = synth(t, "pool", 4, 5);
    let ranked = puppet(
        t,
        &[
            "suggest",
            "--model",
            s(&model),
            "--pool",
            s(&pool),
            "-n",
            "5",
            "--by",
            "distance",
            "-o",
            "pool-next",
        ],
    );
    ranked.assert_ok();
    assert!(ranked.stdout.contains("of the pool"), "{}", ranked.stdout);
    let listing: serde_json::Value = serde_json::from_slice(&std::fs::read(t.join("pool-next/suggestions.json")).unwrap()).unwrap();
    let distances: Vec<f64> = listing["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["distance_degrees"].as_f64().unwrap())
        .collect();
    assert!(distances.windows(2).all(|w| w[0] >= w[1]), "farthest first: {distances:?}");

    // The artist draws the first: here, the pool's frame. It joins a copy of the frames.
    let frames = t.join("frames+1");
    std::fs::create_dir(&frames).unwrap();
    for entry in std::fs::read_dir(seq.join("frames")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, frames.join(path.file_name().unwrap())).unwrap();
    }
    std::fs::copy(pool.join("frames/frame_000.png"), frames.join("drawn.png")).unwrap();
    let more = puppet(
        t,
        &["train", "--from", s(&model), "--frames", s(&frames), "-o", "more", "--steps", "3"],
    );
    more.assert_ok();
    let ((train_before, test_before), (train_after, test_after)) = (split(&model), split(&t.join("more")));
    assert_eq!(test_after, test_before, "the frames held out stay held out");
    assert!(train_after.contains(&"drawn.png".to_string()) && train_after.len() == train_before.len() + 1);
    // It starts from the model's weights: a fresh network decodes the rest pose exactly, so its
    // first step has no ARAP energy; the continued one's first step has the trained bends.
    let first_arap = |m: &Path| -> f64 {
        let log = std::fs::read_to_string(m.join("log.csv")).unwrap();
        let header: Vec<&str> = log.lines().next().unwrap().split(',').collect();
        let column = header.iter().position(|h| *h == "arap").unwrap();
        log.lines().nth(1).unwrap().split(',').nth(column).unwrap().parse().unwrap()
    };
    assert_eq!(first_arap(&model), 0.0, "a fresh start decodes the rest pose");
    assert!(
        first_arap(&t.join("more")) > 0.0,
        "the continuation starts from the trained weights"
    );
}

#[test]
fn bad_pools_and_starts_are_refused_by_name_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let seq = synth(t, "seq", 3, 8);
    let model = train(t, &seq);
    // A pose of another puppet.
    std::fs::write(t.join("other.json"), r#"{"vertices": [[1.0, 2.0]]}"#).unwrap();
    let run = puppet(t, &["suggest", "--model", s(&model), "--pool", "other.json", "-o", "refused"]);
    run.assert_error(&["other.json", "vertices"]);
    // Not a pose at all.
    std::fs::write(t.join("words.json"), "hello").unwrap();
    puppet(t, &["suggest", "--model", s(&model), "--pool", "words.json", "-o", "refused"]).assert_error(&["words.json"]);
    puppet(t, &["suggest", "--model", s(&model), "-n", "0", "-o", "refused"]).assert_error(&["count"]);
    // No candidate is that far from every drawn pose, even searched widest.
    let far = puppet(t, &["suggest", "--model", s(&model), "--separation", "60", "-o", "refused"]);
    far.assert_error(&["60°", "from every drawn pose", "widened by 90°", "--separation"]);
    assert!(!t.join("refused").exists());
    // Continuing a model of another character.
    let other = synth_character(t, "other-seq", 9, 3, 4);
    let cont = puppet(
        t,
        &[
            "train",
            "--from",
            s(&model),
            "--artwork",
            s(&other.join("template")),
            "--frames",
            s(&other.join("frames")),
            "-o",
            "continued",
        ],
    );
    cont.assert_error(&["the puppet of the model to start from", "model"]);
    assert!(!t.join("continued").exists());
    let not_a_model = puppet(t, &["train", "--from", s(&seq), "--frames", s(&seq.join("frames")), "-o", "x"]);
    not_a_model.assert_error(&["seq"]);
    assert!(!t.join("x").exists());
}
