//! Regressions of closed issues, one test per reported problem (`issue_<n>_<what>`).
//!
//! Issue 12 (ground for the second half): no lost work — a refused resume changes no byte, a
//! resume works from elsewhere and after a move, no output replaces a file puppet did not write
//! or another output of the same run; bounded resources — every hostile input of the issue is
//! refused by a limit, named, before the memory is spent; commands over many frames score what
//! they can and exit 1; a closed stdout or a full disk ends a command without a panic.

use std::path::{Path, PathBuf};

use crate::util::{puppet, write_layer_character, Run};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A 4-frame synthetic walker at 64² and a model trained on it for a few steps (one frame held
/// out), in `dir`: (sequence, config, model folder).
fn tiny_run(dir: &Path, steps: u64) -> (PathBuf, PathBuf, PathBuf) {
    let seq = dir.join("seq");
    puppet(dir, &["synth", "-o", s(&seq), "--seed", "5", "--frames", "4", "--size", "64x64"]).assert_ok();
    let model = dir.join("runs/tiny");
    let config = dir.join("configs/tiny.toml");
    std::fs::create_dir_all(config.parent().unwrap()).unwrap();
    // Paths relative to the config, as configs/ in the repository are written.
    std::fs::write(
        &config,
        format!(
            "puppet = \"../seq/template\"\nframes = \"../seq\"\noutput = \"../runs/tiny\"\ntest_fraction = 0.25\n\
             [model]\ninput_size = 32\nlatent = 16\n[train]\nsteps = {steps}\nbatch = 3\ncheckpoint_every = 2\neval_every = 2\nsigma = [1.0, 1.0]\n"
        ),
    )
    .unwrap();
    (seq, config, model)
}

/// Every file under `dir` with its bytes, sorted by path.
pub fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push((path.clone(), std::fs::read(&path).unwrap()));
            }
        }
    }
    out.sort();
    out
}

fn train(cwd: &Path, config: &Path, extra: &[&str]) -> Run {
    let mut args = vec!["train", s(config)];
    args.extend(extra);
    puppet(cwd, &args)
}

#[test]
fn issue_12_a_refused_resume_changes_no_byte_of_the_model_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, config, model) = tiny_run(tmp.path(), 4);
    train(tmp.path(), &config, &["--pause-at", "2"]).assert_ok();
    let before = snapshot(&model);
    assert!(before.len() > 8, "a model folder: {before:?}");
    let original = std::fs::read_to_string(&config).unwrap();
    // An edited learning rate, an edited split, training without --resume: all refused.
    for (edit, needle) in [
        (original.replace("[train]", "[train]\nlearning_rate = 5e-4"), "train.learning_rate"),
        (original.replace("test_fraction = 0.25", "test_fraction = 0.5"), "test_fraction"),
    ] {
        std::fs::write(&config, edit).unwrap();
        train(tmp.path(), &config, &["--resume"]).assert_error(&["cannot resume", needle]);
        assert!(snapshot(&model) == before, "a refused resume changed the model folder ({needle})");
    }
    std::fs::write(&config, &original).unwrap();
    train(tmp.path(), &config, &[]).assert_error(&["holds a checkpoint", "--resume"]);
    assert!(snapshot(&model) == before, "a refused fresh run changed the model folder");
}

#[test]
fn issue_12_a_run_resumes_from_another_folder_and_after_its_folder_moved() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, config, model) = tiny_run(tmp.path(), 6);
    train(tmp.path(), &config, &["--pause-at", "2"]).assert_ok();
    // From another working directory: the config's paths resolve the same.
    let elsewhere = tmp.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    train(
        &elsewhere,
        &Path::new("..").join("configs/tiny.toml"),
        &["--resume", "--pause-at", "4"],
    )
    .assert_ok();
    // After moving the run folder (and pointing the config at its new place).
    let moved = tmp.path().join("runs/moved");
    std::fs::rename(&model, &moved).unwrap();
    let text = std::fs::read_to_string(&config).unwrap().replace("../runs/tiny", "../runs/moved");
    std::fs::write(&config, text).unwrap();
    let run = train(tmp.path(), &config, &["--resume"]);
    run.assert_ok();
    assert!(run.stdout.contains("done: 6 steps"), "{}", run.stdout);
    let log = std::fs::read_to_string(moved.join("log.csv")).unwrap();
    assert_eq!(log.lines().count(), 7, "each step logged once:\n{log}");
    assert!(
        log.lines()
            .nth(2)
            .unwrap()
            .split(',')
            .nth(8)
            .unwrap()
            .parse::<f64>()
            .unwrap()
            .is_finite(),
        "held-out loss at step 2:\n{log}"
    );
}

#[test]
fn issue_12_demo_refuses_a_model_folder_it_did_not_write() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("demo");
    std::fs::create_dir_all(out.join("model")).unwrap();
    std::fs::write(out.join("model/notes.txt"), b"mine").unwrap();
    puppet(tmp.path(), &["demo", "-o", s(&out), "--steps", "1"]).assert_error(&["model", "refusing to overwrite it", "--force"]);
    assert_eq!(std::fs::read(out.join("model/notes.txt")).unwrap(), b"mine");
}

#[test]
fn issue_14_the_demo_runs_end_to_end_and_a_rerun_replaces_its_own_files() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("demo");
    for _ in 0..2 {
        let run = puppet(tmp.path(), &["demo", "-o", s(&out), "--steps", "2"]);
        run.assert_ok();
        assert!(run.stdout.contains("demo done"), "{}", run.stdout);
    }
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    for shown in ["inbetween_walk.gif", "inbetween_walk_dressed.gif", "drag.gif", "fits.png", "hair"] {
        assert!(page.contains(shown), "the page lacks {shown}");
    }
    for file in [
        "inbetween_walk_dressed.gif",
        "inbetween_walk_dressed_sheet.png",
        "model/weights.bpk",
    ] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
}

#[test]
fn issue_12_outputs_never_replace_a_users_file_or_each_other() {
    let tmp = tempfile::tempdir().unwrap();
    let (seq, config, model) = tiny_run(tmp.path(), 2);
    train(tmp.path(), &config, &[]).assert_ok();
    // Two frames with the same name from two folders: both written, under distinct names.
    let (one, two) = (tmp.path().join("one/frames"), tmp.path().join("two/frames"));
    for (dir, k) in [(&one, 0), (&two, 1)] {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::copy(seq.join(format!("frames/frame_00{k}.png")), dir.join("frame.png")).unwrap();
    }
    let out = tmp.path().join("fits");
    let fit = |extra: &[&str]| {
        let mut args = vec!["fit", "--model", s(&model), s(&one), s(&two), "-o", s(&out), "--one-pass"];
        args.extend(extra);
        puppet(tmp.path(), &args)
    };
    fit(&[]).assert_ok();
    for stem in ["one_frames_frame", "two_frames_frame"] {
        assert!(out.join(format!("{stem}_render.png")).is_file(), "{stem}");
    }
    fit(&[]).assert_ok();
    // A file of the user's where an output goes: refused before anything is written.
    std::fs::write(out.join("sheet.png"), b"user's").unwrap();
    fit(&[]).assert_error(&["sheet.png", "not written by puppet", "--force"]);
    assert_eq!(std::fs::read(out.join("sheet.png")).unwrap(), b"user's");
    fit(&["--force"]).assert_ok();
    // correspond's picture never takes the JSON's name; pose refuses a non-PNG output.
    let frame = seq.join("frames/frame_000.png");
    let json = tmp.path().join("c.png");
    puppet(
        tmp.path(),
        &[
            "correspond",
            "--model",
            s(&model),
            s(&frame),
            s(&frame),
            "-o",
            s(&json),
            "--one-pass",
        ],
    )
    .assert_ok();
    assert!(
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(&json).unwrap()).is_ok(),
        "c.png holds the JSON"
    );
    assert!(tmp.path().join("c_pairs.png").is_file());
    puppet(
        tmp.path(),
        &["pose", "--model", s(&model), s(&frame), "--pin", "32,40:34,40", "-o", "x.json"],
    )
    .assert_error(&["x.json", ".png"]);
}

#[test]
fn issue_12_eval_scores_the_readable_frames_names_the_bad_one_and_exits_1() {
    let tmp = tempfile::tempdir().unwrap();
    let (seq, config, model) = tiny_run(tmp.path(), 2);
    train(tmp.path(), &config, &[]).assert_ok();
    let bad = seq.join("frames/frame_001.png");
    let bytes = std::fs::read(&bad).unwrap();
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
    let run = puppet(tmp.path(), &["eval", "--model", s(&model), s(&seq), "--all", "--one-pass"]);
    assert_eq!(run.code, 1, "{}\n{}", run.stdout, run.stderr);
    assert!(
        run.stderr.contains("frame_001.png") && !run.stderr.contains("panicked"),
        "{}",
        run.stderr
    );
    for good in ["frame_000.png", "frame_002.png", "frame_003.png"] {
        assert!(run.stdout.contains(good), "{good} was not scored:\n{}", run.stdout);
    }
    assert!(!run.stdout.contains("frame_001.png"), "{}", run.stdout);
}

#[test]
fn issue_12_a_closed_pipe_or_a_full_disk_ends_a_command_without_a_panic() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_layer_character(&tmp.path().join("art"), "");
    let built = tmp.path().join("built");
    puppet(tmp.path(), &["build", s(&art), "-o", s(&built)]).assert_ok();
    let bin = env!("CARGO_BIN_EXE_puppet");
    // `puppet info … | true`: the reader is gone before puppet writes.
    let piped = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("'{bin}' info '{}' | true; echo status ${{PIPESTATUS:-0}}", built.display()))
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&piped.stderr).contains("panicked"), "{piped:?}");
    if Path::new("/dev/full").exists() {
        let full = std::process::Command::new(bin)
            .args(["info", s(&built)])
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&full.stderr);
        assert_eq!(full.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("puppet: error: cannot write to standard output") && !stderr.contains("panicked"),
            "{stderr}"
        );
    }
}

/// Writes a zip with the given (name, bytes) entries, deflated.
fn write_zip(path: &Path, entries: &[(&str, &[u8])]) {
    use std::io::Write;
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        zip.start_file(*name, deflated).unwrap();
        zip.write_all(bytes).unwrap();
    }
    zip.finish().unwrap();
}

/// A valid grey PNG of `w`×`h` (small on disk: all zeros).
fn big_png(path: &Path, w: u32, h: u32) {
    image::GrayImage::new(w, h).save(path).unwrap();
}

#[test]
fn issue_12_hostile_artwork_is_refused_by_its_header_not_by_running_out_of_memory() {
    let tmp = tempfile::tempdir().unwrap();
    let build = |artwork: &Path| puppet(tmp.path(), &["build", s(artwork), "-o", s(&tmp.path().join("out"))]);
    // An .ora declaring a 20000×20000 canvas.
    let mut layer = Vec::new();
    image::RgbaImage::from_pixel(4, 4, image::Rgba([255, 0, 0, 255]))
        .write_to(&mut std::io::Cursor::new(&mut layer), image::ImageFormat::Png)
        .unwrap();
    let canvas = tmp.path().join("canvas.ora");
    let stack = br#"<image w="20000" h="20000"><stack><layer name="a" src="a.png"/></stack></image>"#;
    write_zip(
        &canvas,
        &[("mimetype", b"image/openraster"), ("stack.xml", stack), ("a.png", &layer)],
    );
    build(&canvas).assert_error(&["canvas.ora", "20000×20000", "above the limit"]);
    // An .ora whose stack.xml inflates far past any real one.
    let bomb = tmp.path().join("bomb.ora");
    let mut xml = br#"<image w="4" h="4"><stack><layer name="a" src="a.png"/></stack></image>"#.to_vec();
    xml.resize(64 << 20, b' ');
    write_zip(&bomb, &[("mimetype", b"image/openraster"), ("stack.xml", &xml), ("a.png", &layer)]);
    build(&bomb).assert_error(&["bomb.ora", "stack.xml inflated", "above the limit"]);
    // Layer PNGs of 8000×8000.
    let art = write_layer_character(&tmp.path().join("big"), "");
    big_png(&art.join("torso.png"), 8000, 8000);
    big_png(&art.join("head.png"), 8000, 8000);
    build(&art).assert_error(&["torso.png", "8000×8000", "above the limit"]);
}

#[test]
fn issue_12_hostile_frames_steps_and_batches_are_refused_or_reduced_with_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let (seq, config, model) = tiny_run(tmp.path(), 2);
    // A batch larger than the training frames: reduced, said once.
    let text = std::fs::read_to_string(&config).unwrap().replace("batch = 3", "batch = 100");
    std::fs::write(&config, text).unwrap();
    let run = train(tmp.path(), &config, &[]);
    run.assert_ok();
    assert!(
        run.stderr.contains("warning: train.batch = 100 is more than the 3 training frames"),
        "{}",
        run.stderr
    );
    let text = std::fs::read_to_string(&config).unwrap().replace("batch = 100", "batch = 1000");
    std::fs::write(&config, text).unwrap();
    train(tmp.path(), &config, &["--force"]).assert_error(&["tiny.toml", "train.batch = 1000", "from 1 to 256"]);
    // An 8000×8000 frame: refused from its header (the puppet's frames are 64×64).
    let huge = tmp.path().join("huge.png");
    big_png(&huge, 8000, 8000);
    puppet(tmp.path(), &["fit", "--model", s(&model), s(&huge), "-o", "f", "--one-pass"]).assert_error(&["huge.png", "8000×8000", "64×64"]);
    // Ten thousand in-betweens: above the limit unless asked for.
    let frame = seq.join("frames/frame_000.png");
    let ib = |steps: &str, extra: &[&str]| {
        let mut args = vec![
            "inbetween",
            "--model",
            s(&model),
            s(&frame),
            s(&frame),
            "-o",
            "ib",
            "--steps",
            steps,
        ];
        args.extend(extra);
        puppet(tmp.path(), &args)
    };
    ib("10000", &[]).assert_error(&["10000", "above the limit of 1000"]);
    // The step count is said as given; every frame is written.
    let run = ib("4", &["--training", s(&seq), "--latent-steps", "0"]);
    run.assert_ok();
    assert!(
        run.stdout.contains("4 in-betweens (6 frames with the two ends, linear)"),
        "{}",
        run.stdout
    );
    assert!(tmp.path().join("ib/nearest/step_005.png").is_file());
}

#[test]
fn issue_12_folders_of_the_wrong_kind_say_what_was_expected_and_what_to_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, config, model) = tiny_run(tmp.path(), 2);
    train(tmp.path(), &config, &[]).assert_ok();
    let info = puppet(tmp.path(), &["info", s(&model)]);
    info.assert_ok();
    assert!(
        info.stdout.contains("trained 2 of 2 steps") && info.stdout.contains("root layer"),
        "{}",
        info.stdout
    );
    let built = tmp.path().join("seq/template");
    puppet(tmp.path(), &["eval", "--model", s(&built), "seq"]).assert_error(&["expected a model folder", "puppet train"]);
    puppet(tmp.path(), &["info", "nowhere"]).assert_error(&["nowhere", "expected a puppet folder", "puppet build"]);
}

/// Each package's features as `cargo tree` resolves them, with or without the dev-dependencies.
fn resolved_features(with_dev: bool) -> std::collections::BTreeSet<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut args = vec!["tree", "--offline", "--locked", "--prefix", "none", "--no-dedupe", "-f", "{p} {f}"];
    if !with_dev {
        args.extend(["-e", "no-dev"]);
    }
    let out = std::process::Command::new(cargo)
        .args(&args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).lines().map(str::to_string).collect()
}

#[test]
fn issue_12_run_and_test_share_one_build_of_the_dependencies() {
    // `cargo run --release` builds the dependencies with the features the normal dependencies
    // ask for; `cargo test --release` adds the dev-dependencies' requests. Any package whose
    // features differ is built twice, and everything above it (Burn) with it.
    let (run, test) = (resolved_features(false), resolved_features(true));
    let name = |line: &String| line.split(' ').take(2).collect::<Vec<_>>().join(" ");
    let test_names: std::collections::BTreeSet<String> = test.iter().map(name).collect();
    let differ: Vec<&String> = run.iter().filter(|l| !test.contains(*l) && test_names.contains(&name(l))).collect();
    assert!(
        differ.is_empty(),
        "built with other features under `cargo test` (unify them in Cargo.toml): {differ:?}"
    );
}
