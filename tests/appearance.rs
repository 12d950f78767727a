//! `puppet appearance train` and `--appearance` end to end on tiny configs: a run paused and
//! resumed ends with the same generator as an uninterrupted one, `eval` and `fit` report and
//! write the redraws, and the bad inputs of issue 15 get clear errors that change nothing.

use std::path::{Path, PathBuf};

use crate::util::puppet;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A 4-frame synthetic walker of `size` with a model trained on it for a few steps (one frame
/// held out): (sequence, model folder).
fn tiny_model(dir: &Path, name: &str, size: &str) -> (PathBuf, PathBuf) {
    let seq = dir.join(format!("seq-{name}"));
    puppet(dir, &["synth", "-o", s(&seq), "--seed", "5", "--frames", "4", "--size", size]).assert_ok();
    let model = dir.join(name);
    let config = dir.join(format!("{name}.toml"));
    std::fs::write(
        &config,
        format!(
            "puppet = \"{seq}/template\"\nframes = \"{seq}\"\noutput = \"{out}\"\ntest_fraction = 0.25\n\
             [model]\ninput_size = 32\nlatent = 16\n[train]\nsteps = 4\nbatch = 3\nsigma = [1.0, 1.0]\n",
            seq = seq.display(),
            out = model.display()
        ),
    )
    .unwrap();
    puppet(dir, &["train", s(&config)]).assert_ok();
    (seq, model)
}

/// The appearance config of these tests: 6 generator steps of 3 frames, the one-pass fit.
fn stage_config(dir: &Path, name: &str, extra: &str) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(
        &path,
        format!("epochs = 6\nbatch = 3\ncheckpoint_every = 2\neval_every = 2\nfit = \"one-pass\"\n{extra}"),
    )
    .unwrap();
    path
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

#[test]
fn a_resumed_stage_matches_an_uninterrupted_one_and_eval_and_fit_use_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (seq, model) = tiny_model(dir, "m", "64x64");
    let other = dir.join("m-copy");
    copy_dir(&model, &other);
    let config = stage_config(dir, "stage", "conditioned = true\n");

    let run = puppet(dir, &["appearance", "train", "--model", s(&model), s(&config)]);
    run.assert_ok();
    assert!(run.stdout.contains("held-out frames, mean L2: rendered"), "{}", run.stdout);
    let stage = model.join("appearance");
    for file in [
        "net.json",
        "generator.bpk",
        "critic.bpk",
        "stage.json",
        "train.toml",
        "fits.json",
        "log.csv",
        "loss.png",
        "sheet.png",
    ] {
        assert!(stage.join(file).is_file(), "{file}");
    }
    assert_eq!(std::fs::read_to_string(stage.join("log.csv")).unwrap().lines().count(), 7);

    puppet(dir, &["appearance", "train", "--model", s(&other), s(&config), "--pause-at", "3"]).assert_ok();
    puppet(dir, &["appearance", "train", "--model", s(&other), s(&config), "--resume"]).assert_ok();
    // Burn's records carry random parameter ids, so compare what the generators draw.
    let scores = |m: &Path| {
        let eval = puppet(dir, &["eval", "--model", s(m), s(&seq), "--all", "--one-pass", "--appearance"]);
        eval.assert_ok();
        let at = eval
            .stdout
            .find("appearance ")
            .unwrap_or_else(|| panic!("no appearance table:\n{}", eval.stdout));
        eval.stdout[at..].to_string()
    };
    let table = scores(&model);
    assert!(table.contains("generated²"), "{table}");
    assert_eq!(table, scores(&other), "paused and resumed ≠ uninterrupted");
    let out = dir.join("fits");
    puppet(
        dir,
        &[
            "fit",
            "--model",
            s(&model),
            s(&seq.join("frames")),
            "-o",
            s(&out),
            "--one-pass",
            "--appearance",
        ],
    )
    .assert_ok();
    let generated = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with("_generated.png"))
        .count();
    assert_eq!(generated, 4, "one redraw per fitted frame");
    let frames: Vec<PathBuf> = {
        let mut f: Vec<PathBuf> = std::fs::read_dir(seq.join("frames")).unwrap().flatten().map(|e| e.path()).collect();
        f.sort();
        f
    };
    let between = dir.join("between");
    puppet(
        dir,
        &[
            "inbetween",
            "--model",
            s(&model),
            s(&frames[0]),
            s(&frames[2]),
            "-o",
            s(&between),
            "--steps",
            "2",
            "--one-pass",
            "--appearance",
        ],
    )
    .assert_ok();
    let pngs = std::fs::read_dir(between.join("generated"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
        .count();
    assert_eq!(pngs, 4, "both keys and two in-betweens");
    let posed = dir.join("posed.png");
    puppet(
        dir,
        &[
            "pose",
            "--model",
            s(&model),
            s(&frames[0]),
            "--pin",
            "32,30:35,28",
            "-o",
            s(&posed),
            "--latent-steps",
            "0",
            "--appearance",
        ],
    )
    .assert_ok();
    assert!(dir.join("posed_generated.png").is_file());
}

#[test]
fn bad_appearance_inputs_are_named_and_change_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (seq, model) = tiny_model(dir, "m", "64x64");
    puppet(dir, &["eval", "--model", s(&model), s(&seq), "--one-pass", "--appearance"])
        .assert_error(&["appearance", "no appearance stage"]);

    let config = stage_config(dir, "stage", "");
    // A file of the user's where the stage would go: refused, left as it was.
    std::fs::create_dir_all(model.join("appearance")).unwrap();
    std::fs::write(model.join("appearance/notes.txt"), "mine").unwrap();
    puppet(dir, &["appearance", "train", "--model", s(&model), s(&config)]).assert_error(&["appearance", "not made by puppet"]);
    assert_eq!(std::fs::read_dir(model.join("appearance")).unwrap().count(), 1);
    std::fs::remove_dir_all(model.join("appearance")).unwrap();
    puppet(dir, &["appearance", "train", "--model", s(&model), s(&config), "--pause-at", "2"]).assert_ok();
    let before = crate::regression::snapshot(&model);
    let changed = stage_config(dir, "changed", "loss = \"lsgan\"\n");
    puppet(dir, &["appearance", "train", "--model", s(&model), s(&changed), "--resume"]).assert_error(&[
        "cannot resume",
        "loss",
        "only epochs may change",
    ]);
    puppet(dir, &["appearance", "train", "--model", s(&model), s(&config)]).assert_error(&["checkpoint", "step 2"]);
    assert!(
        crate::regression::snapshot(&model) == before,
        "a refused run changed the model folder"
    );
    let bad = stage_config(dir, "bad", "critic_steps = 0\n");
    puppet(dir, &["appearance", "train", "--model", s(&model), s(&bad), "--resume"]).assert_error(&["bad.toml", "critic_steps"]);

    // A hostile net.json: refused by its limits before anything is allocated.
    let net = model.join("appearance/net.json");
    let original = std::fs::read_to_string(&net).unwrap();
    std::fs::write(&net, original.replace("\"max_channels\": 64", "\"max_channels\": 1000000000")).unwrap();
    puppet(dir, &["eval", "--model", s(&model), s(&seq), "--one-pass", "--appearance"]).assert_error(&["net.json", "channels"]);
    std::fs::write(&net, original).unwrap();

    // A stage copied into the folder of a model of another puppet.
    let (other_seq, other) = tiny_model(dir, "wide", "80x64");
    copy_dir(&model.join("appearance"), &other.join("appearance"));
    puppet(dir, &["eval", "--model", s(&other), s(&other_seq), "--one-pass", "--appearance"])
        .assert_error(&["appearance", "trained for another puppet"]);
}
