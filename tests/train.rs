//! `puppet train`, `fit` and `eval` end to end on tiny configs (seconds each): the loss goes
//! down, a killed run resumes to the same weights as an uninterrupted one, NaN stops the run
//! keeping the last good checkpoint, and bad configs get clear errors.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::util::puppet;

/// A synthetic 4-frame walker at 64² (its template is built by `train`).
fn synth(dir: &Path, frames: usize, size: &str) -> PathBuf {
    let seq = dir.join(format!("seq-{frames}-{size}"));
    puppet(
        dir,
        &[
            "synth",
            "-o",
            seq.to_str().unwrap(),
            "--seed",
            "5",
            "--frames",
            &frames.to_string(),
            "--size",
            size,
        ],
    )
    .assert_ok();
    seq
}

/// A tiny config: 32² working square (the 64² frames are letterboxed at half scale).
fn config(dir: &Path, name: &str, seq: &Path, extra: &str) -> PathBuf {
    let text = format!(
        "puppet = \"{seq}/template\"\nframes = \"{seq}\"\noutput = \"{out}\"\ntest_fraction = 0.0\n\
         [model]\ninput_size = 32\nlatent = 32\n\
         [train]\nbatch = 4\nlearning_rate = 3e-4\nsigma = [1.0, 1.0]\n{extra}",
        seq = seq.display(),
        out = dir.join(name).display()
    );
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

/// Poses the template draws itself, one per drawn frame of a batch (`[train.sampled]`).
const SAMPLED: &str = "[train.sampled]\nshare = 1.0\n";

/// The drawn frames moved and recoloured at each step (`[train.augment]`).
const AUGMENT: &str = "[train.augment]\nshift = 0.05\nscale = 0.05\nmax_degrees = 5.0\ncolour = 0.1\n";

/// A column of a model's training log, by its header name.
fn column(model: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(model.join("log.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("step,total,rec,arap,joints,area,sigma,seconds,held_out,vertex,guide")
    );
    let k = [
        "step", "total", "rec", "arap", "joints", "area", "sigma", "seconds", "held_out", "vertex", "guide",
    ]
    .iter()
    .position(|c| *c == name)
    .unwrap();
    lines.map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect()
}

fn losses(model: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(model.join("log.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn training_lowers_the_reconstruction_loss_and_fit_and_eval_run() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    // At 64² (frames copied, not scaled): at 32² the walker's limbs are a pixel wide and 60
    // steps barely move the loss.
    let cfg = config(tmp.path(), "run", &seq, "steps = 60\ncheckpoint_every = 20\n");
    let text = std::fs::read_to_string(&cfg).unwrap().replace("input_size = 32", "input_size = 64");
    std::fs::write(&cfg, text).unwrap();
    puppet(tmp.path(), &["train", cfg.to_str().unwrap()]).assert_ok();
    let rec = losses(&tmp.path().join("run"));
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
    let (first, last) = (mean(&rec[..5]), mean(&rec[rec.len() - 5..]));
    println!("L_rec: first 5 steps {first:.5}, last 5 {last:.5}");
    assert!(last < 0.8 * first, "L_rec {first} → {last}");
    for f in [
        "loss.png",
        "net.json",
        "weights.bpk",
        "split.json",
        "train.toml",
        "puppet/puppet.json",
    ] {
        assert!(tmp.path().join("run").join(f).is_file(), "{f}");
    }

    let model = tmp.path().join("run");
    let fit_dir = tmp.path().join("fit");
    let frames = seq.join("frames");
    let fit = |out: &std::path::Path, extra: &[&str]| {
        let args = [
            "fit",
            "--model",
            model.to_str().unwrap(),
            frames.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        puppet(tmp.path(), &[&args[..], extra].concat())
    };
    fit(&fit_dir, &[]).assert_ok();
    for f in [
        "sheet.png",
        "frame_000_overlay.png",
        "frame_000_render.png",
        "frame_003_vertices.json",
    ] {
        assert!(fit_dir.join(f).is_file(), "{f}");
    }
    // The plausibility term on, held to the training frames' turns: it fits; a margin that is
    // not a number of degrees is refused by name before anything is written.
    let plausible = |margin: &str, out: &str| {
        fit(
            &tmp.path().join(out),
            &["--plausibility-weight", "10", "--plausible-margin", margin],
        )
    };
    plausible("0", "fit-plausible").assert_ok();
    assert!(tmp.path().join("fit-plausible/frame_003_vertices.json").is_file());
    plausible("nan", "fit-refused").assert_error(&["--plausible-margin"]);
    assert!(!tmp.path().join("fit-refused").exists());
    // Hidden limbs left where the fit puts them fits too; a slack that is no number is refused by
    // name.
    fit(&tmp.path().join("fit-free"), &["--no-hidden-limbs"]).assert_ok();
    fit(&tmp.path().join("fit-slack"), &["--hidden-limb-slack", "nan"]).assert_error(&["--hidden-limb-slack"]);
    assert!(!tmp.path().join("fit-slack").exists());
    // All vertex steps at half size fits; a share past 1 is refused by name.
    fit(&tmp.path().join("fit-coarse"), &["--vertex-coarse-share", "1"]).assert_ok();
    fit(&tmp.path().join("fit-share"), &["--vertex-coarse-share", "1.5"]).assert_error(&["--vertex-coarse-share"]);
    assert!(!tmp.path().join("fit-share").exists());
    fit(&tmp.path().join("fit-gain"), &["--min-round-gain", "nan"]).assert_error(&["--min-round-gain"]);
    assert!(!tmp.path().join("fit-gain").exists());
    // Scored on all four frames: the encoder's fit, refined latents, then refined vertices.
    let scores = |refine: &str, vertices: &str| -> serde_json::Value {
        let out = tmp.path().join(format!("eval-{refine}-{vertices}.json"));
        let eval = puppet(
            tmp.path(),
            &[
                "eval",
                "--model",
                model.to_str().unwrap(),
                seq.to_str().unwrap(),
                "--all",
                "--latent-steps",
                refine,
                "--vertex-steps",
                vertices,
                "-o",
                out.to_str().unwrap(),
            ],
        );
        eval.assert_ok();
        assert!(eval.stdout.contains("mean") && eval.stdout.contains("PCK.05"), "{}", eval.stdout);
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(out).unwrap()).unwrap()["mean"].clone()
    };
    let (plain, refined, on_vertices) = (scores("0", "0"), scores("30", "0"), scores("30", "60"));
    println!("encoder: {plain}\nrefined: {refined}\nthen vertices: {on_vertices}");
    assert!(
        plain["iou"].as_f64().unwrap() > 0.5 && plain["vertex_error"].as_f64().is_some(),
        "{plain}"
    );
    let l2 = |m: &serde_json::Value| m["l2"].as_f64().unwrap();
    // (On this 60-step model the decoder barely responds to z: ~3 % here; 35 % on the walker of
    // configs/synth-walk.toml, docs/results.md "Fitting the synthetic walker".)
    assert!(
        l2(&refined) < 0.99 * l2(&plain),
        "refining should lower L2: {} → {}",
        l2(&plain),
        l2(&refined)
    );
    let err = |m: &serde_json::Value| m["visible_vertex_error"].as_f64().unwrap();
    assert!(
        err(&refined) < err(&plain),
        "and the visible vertices' error: {} → {}",
        err(&plain),
        err(&refined)
    );
    assert!(
        l2(&on_vertices) < 0.9 * l2(&refined) && err(&on_vertices) < err(&refined),
        "refining the vertices should lower L2 and vertex error further: {} → {}, {} → {} px",
        l2(&refined),
        l2(&on_vertices),
        err(&refined),
        err(&on_vertices)
    );
}

/// Starts `puppet train config` in the background and waits until it has checkpointed trained
/// weights (the untrained ones are checkpointed at once, as step 0); the process and the path
/// of `output`'s `checkpoints/latest`.
fn train_until_a_trained_checkpoint(config: &Path, output: &Path) -> (std::process::Child, PathBuf) {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_puppet"))
        .args(["-q", "train", config.to_str().unwrap()])
        .spawn()
        .unwrap();
    let latest = output.join("checkpoints/latest");
    let start = Instant::now();
    while std::fs::read_to_string(&latest).map_or(true, |l| l.trim() == "step-000000") {
        assert!(start.elapsed() < Duration::from_secs(120), "no checkpoint appeared");
        std::thread::sleep(Duration::from_millis(2));
    }
    (child, latest)
}

#[test]
fn a_killed_run_resumes_to_the_weights_of_an_uninterrupted_one() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    // Sampled poses around the network's own poses (they depend on the weights of each step
    // too), shown for the first half of the run (the resumed part crosses the schedule's end),
    // and the drawn frames augmented: all must be functions of the step.
    let settings = &format!("steps = 40\ncheckpoint_every = 4\n{SAMPLED}around = \"fits\"\nuntil = 0.5\n{AUGMENT}");
    let whole = config(tmp.path(), "whole", &seq, settings);
    puppet(tmp.path(), &["train", whole.to_str().unwrap()]).assert_ok();

    let cut = config(tmp.path(), "cut", &seq, settings);
    let (mut child, latest) = train_until_a_trained_checkpoint(&cut, &tmp.path().join("cut"));
    // The killed run's lock goes with it: the resume below is not refused as in use.
    child.kill().unwrap();
    child.wait().unwrap();
    let at_kill = std::fs::read_to_string(&latest).unwrap();
    assert_ne!(at_kill.trim(), "step-000040", "the run finished before it could be killed");
    puppet(tmp.path(), &["train", cut.to_str().unwrap()]).assert_error(&["--resume"]);
    puppet(tmp.path(), &["train", "--resume", cut.to_str().unwrap()]).assert_ok();

    // Burn's records carry random parameter ids, so compare what the weights compute: the fits
    // of every frame, bit for bit.
    let device = ::puppet::backend::device();
    let frames = ::puppet::puppet::sequence::Frames::load(&seq, &Default::default()).unwrap();
    let pictures: Vec<_> = frames.frames.iter().collect();
    let fit = |run: &str| {
        ::puppet::model::Model::load(&tmp.path().join(run), &device)
            .unwrap()
            .fit(&pictures, &device)
            .unwrap()
    };
    assert!(
        fit("whole") == fit("cut"),
        "resumed weights differ from the uninterrupted run's (killed at {at_kill})"
    );
    assert_eq!(
        losses(&tmp.path().join("cut")),
        losses(&tmp.path().join("whole")),
        "each step logged once, same values"
    );
}

#[test]
fn a_second_run_on_a_folder_in_use_is_refused_at_once_and_the_first_goes_on_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let cfg = config(tmp.path(), "busy", &seq, "steps = 100000\ncheckpoint_every = 4\n");
    let (mut first, latest) = train_until_a_trained_checkpoint(&cfg, &tmp.path().join("busy"));
    let holder = format!("pid {}", first.id());
    for args in [
        vec!["train", cfg.to_str().unwrap()],
        vec!["train", "--resume", cfg.to_str().unwrap()],
    ] {
        let asked = Instant::now();
        let second = puppet(tmp.path(), &args);
        assert!(
            asked.elapsed() < Duration::from_secs(1),
            "{args:?} took {:?} to refuse",
            asked.elapsed()
        );
        second.assert_error(&["busy", "in use by", &holder]);
    }
    first.kill().unwrap();
    first.wait().unwrap();
    // The first run's log holds each of its steps once, in order: nothing of the second's.
    let text = std::fs::read_to_string(tmp.path().join("busy/log.csv")).unwrap();
    let steps: Vec<u64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(!steps.is_empty());
    assert_eq!(steps, (1..=steps.len() as u64).collect::<Vec<_>>(), "{text}");
    // The killed run's lock is gone with it: a resume goes on (a few steps, then pauses).
    let done: u64 = std::fs::read_to_string(&latest).unwrap().trim()["step-".len()..].parse().unwrap();
    let pause = (done + 4).to_string();
    puppet(tmp.path(), &["train", "--resume", "--pause-at", &pause, cfg.to_str().unwrap()]).assert_ok();
}

#[test]
fn a_diverging_run_stops_with_a_clear_message_and_keeps_its_checkpoint() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let cfg = config(tmp.path(), "nan", &seq, "steps = 30\ncheckpoint_every = 1\n");
    let text = std::fs::read_to_string(&cfg)
        .unwrap()
        .replace("learning_rate = 3e-4", "learning_rate = 1e30");
    std::fs::write(&cfg, text).unwrap();
    let run = puppet(tmp.path(), &["train", cfg.to_str().unwrap()]);
    run.assert_error(&["not finite", "last good checkpoint"]);
    let latest = std::fs::read_to_string(tmp.path().join("nan/checkpoints/latest")).unwrap();
    let state: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tmp.path().join("nan/checkpoints").join(latest.trim()).join("state.json")).unwrap()).unwrap();
    assert!(state["step"].as_u64().is_some(), "{state}");
}

#[test]
fn bad_configs_get_errors_naming_the_problem() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let other = synth(tmp.path(), 2, "80x80");
    let one = tmp.path().join("one");
    std::fs::create_dir_all(&one).unwrap();
    std::fs::copy(seq.join("frames/frame_000.png"), one.join("a.png")).unwrap();
    let empty = tmp.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();

    let base = std::fs::read_to_string(config(tmp.path(), "x", &seq, "steps = 2\n")).unwrap();
    let frames_line = format!("frames = \"{}\"", seq.display());
    let case = |name: &str, text: String, needles: &[&str]| {
        let path = tmp.path().join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        puppet(tmp.path(), &["train", path.to_str().unwrap()]).assert_error(needles);
    };
    case("missing", base.replace("/template\"", "/nothing-here\""), &["nothing-here"]);
    case(
        "size",
        base.replace(&frames_line, &format!("frames = \"{}\"", other.display())),
        &["frame_000.png", "80×80", "64×64"],
    );
    case(
        "empty",
        base.replace(&frames_line, &format!("frames = \"{}\"", empty.display())),
        &["empty", "no PNG"],
    );
    case(
        "split",
        base.replace(&frames_line, &format!("frames = \"{}\"", one.display()))
            .replace("test_fraction = 0.0", "test_fraction = 0.3"),
        &["test_fraction = 0.3", "leave no frame for training"],
    );
    case("key", base.replace("batch = 4", "batch = 4\nbatches = 2"), &["key.toml", "batches"]);
    case(
        "sampled",
        format!("{base}[train.sampled]\nshare = -1\n"),
        &["train.sampled.share", "-1"],
    );
    case(
        "augment",
        format!("{base}[train.augment]\nmax_degrees = 400\n"),
        &["train.augment.max_degrees", "400"],
    );
}

/// The poses the template draws itself (`[train.sampled]`): their vertex loss is logged, and it
/// is what teaches the network their vertices — the same run with the loss weighted 0 (the same
/// sampled poses at every step: they depend on the seed and the step only) ends further from
/// them. A resumed run's samples are an uninterrupted one's (the resume test above runs with
/// them).
#[test]
fn sampled_poses_are_logged_and_their_vertex_loss_teaches_them() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    // At 64², as the first test (at 32² the limbs are a pixel wide), turns wide.
    let run = |name: &str, weight: f64| -> Vec<f64> {
        let extra = format!("steps = 60\ncheckpoint_every = 20\n{SAMPLED}vertex_weight = {weight}\nmax_degrees = 60.0\n");
        let cfg = config(tmp.path(), name, &seq, &extra);
        let text = std::fs::read_to_string(&cfg)
            .unwrap()
            .replace("input_size = 32", "input_size = 64")
            .replace("learning_rate = 3e-4", "learning_rate = 2e-3");
        std::fs::write(&cfg, text).unwrap();
        puppet(tmp.path(), &["train", cfg.to_str().unwrap()]).assert_ok();
        assert!(tmp.path().join(name).join("sampled.png").is_file(), "the sheet of sampled poses");
        column(&tmp.path().join(name), "vertex")
    };
    let (taught, shown) = (run("taught", 1000.0), run("shown", 0.0));
    assert!(taught.iter().chain(&shown).all(|v| v.is_finite()), "every step has sampled poses");
    let last = |v: &[f64]| v[v.len() - 20..].iter().sum::<f64>() / 20.0;
    assert!(
        last(&taught) < 0.97 * last(&shown),
        "the sampled poses' vertex loss over the last 20 steps: {:.2} px² with its weight, {:.2} without",
        last(&taught),
        last(&shown)
    );
}

/// Training from the prior (`puppet train --prior`): the training frames are fitted by the
/// built-in prior first (guide.png shows the fits), the network's poses are pulled toward them for
/// the guided share of the run and not after, and that pull lowers the guide's vertex loss. With
/// the frames moved by augmentation (the targets moved alike: `augment::moved_point`) the guide
/// runs for its share too.
#[test]
fn training_from_the_prior_follows_its_fits_for_the_guided_steps() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let run = |name: &str, extra: &str| -> Vec<f64> {
        let cfg = config(tmp.path(), name, &seq, &format!("steps = 40\ncheckpoint_every = 20\n{extra}"));
        let text = std::fs::read_to_string(&cfg)
            .unwrap()
            .replace("input_size = 32", "input_size = 64")
            .replace("learning_rate = 3e-4", "learning_rate = 2e-3");
        std::fs::write(&cfg, text).unwrap();
        puppet(tmp.path(), &["train", cfg.to_str().unwrap(), "--prior"]).assert_ok();
        assert!(tmp.path().join(name).join("guide.png").is_file(), "the sheet of the prior's fits");
        let written = std::fs::read_to_string(tmp.path().join(name).join("train.toml")).unwrap();
        assert!(written.contains("[train.guide]"), "the run's config records the guide:\n{written}");
        column(&tmp.path().join(name), "guide")
    };
    let on_for_its_share = |name: &str, guide: &[f64], guided: usize| {
        assert!(
            guide[..guided].iter().all(|v| v.is_finite()),
            "{name}: guided steps log the guide: {guide:?}"
        );
        assert!(
            guide[guided..].iter().all(|v| v.is_nan()),
            "{name}: later steps are not guided: {guide:?}"
        );
    };
    let guide = run("guided", "[train.guide]\nweight = 100.0\nuntil = 0.75\n");
    on_for_its_share("guided", &guide, 30);
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
    let (first, last) = (mean(&guide[..5]), mean(&guide[25..30]));
    assert!(last < 0.85 * first, "the guide's vertex loss {first:.2} → {last:.2} px²");
    // `--prior` alone: the default weight for the default fifth of the run.
    on_for_its_share("guided-moved", &run("guided-moved", AUGMENT), 8);

    // In-betweens whose keyframes may start from the prior: each keyframe is fitted no worse
    // than from the network alone.
    let model = tmp.path().join("guided");
    let frames = seq.join("frames");
    let keys_l2 = |out: &str, extra: &[&str]| -> Vec<f64> {
        let (a, b) = (frames.join("frame_000.png"), frames.join("frame_003.png"));
        let args = [
            "inbetween",
            "--model",
            model.to_str().unwrap(),
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--steps",
            "3",
            "--vertex-steps",
            "10",
            "-o",
            out,
        ];
        let run = puppet(tmp.path(), &[&args[..], extra].concat());
        run.assert_ok();
        assert!(tmp.path().join(out).join("sheet.png").is_file());
        let line = run
            .stdout
            .lines()
            .find(|l| l.starts_with("the first and last frames"))
            .unwrap()
            .to_string();
        if !extra.is_empty() {
            assert!(
                run.stdout.contains("of 2 keyframes kept the fit from the prior's placement"),
                "{}",
                run.stdout
            );
        }
        // "… fits: L2 A to a.png and B to b.png"
        let words: Vec<&str> = line.split_whitespace().collect();
        let after = |w: &str| words[words.iter().rposition(|x| *x == w).unwrap() + 1].parse().unwrap();
        vec![after("L2"), after("and")]
    };
    let (plain, with_prior) = (keys_l2("ib", &[]), keys_l2("ib-prior", &["--prior"]));
    assert_eq!(plain.len(), 2);
    assert!(
        with_prior.iter().zip(&plain).all(|(p, n)| *p <= n + 0.5),
        "keyframe L2 with the prior {with_prior:?}, without {plain:?}"
    );
}

/// An untrained fit that counts its calls: the rest pose for every frame.
#[derive(Debug, Default)]
struct CountingFit(std::sync::atomic::AtomicUsize);

impl puppet::train::guide::UntrainedFit for CountingFit {
    fn fit(&self, model: &puppet::Model, frames: &[&puppet::Picture], _: &dyn puppet::Progress) -> puppet::Result<Vec<Vec<[f32; 2]>>> {
        self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(frames.iter().map(|_| model.puppet.rest_vertices()).collect())
    }
}

/// The training frames are fitted once for the guided steps: a run paused inside them fits them
/// again when resumed, one resumed past them does not.
#[test]
fn a_run_resumed_past_the_guided_steps_does_not_fit_its_frames_again() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let cfg = config(
        tmp.path(),
        "guided",
        &seq,
        "steps = 10\ncheckpoint_every = 1\n[train.guide]\nweight = 10.0\nuntil = 0.3\n",
    );
    let config = puppet::TrainConfig::load(&cfg).unwrap();
    let fit = std::sync::Arc::new(CountingFit::default());
    let run = |resume: bool, pause_at: Option<u64>| {
        let options = puppet::TrainOptions {
            resume,
            pause_at,
            guide: Some(fit.clone()),
            ..puppet::TrainOptions::default()
        };
        puppet::train(&config, &options, &puppet::Silent).unwrap()
    };
    let calls = || fit.0.load(std::sync::atomic::Ordering::Relaxed);
    run(false, Some(2));
    assert_eq!(calls(), 1);
    run(true, Some(5));
    assert_eq!(calls(), 2, "resumed at step 2 of 3 guided ones: fitted again");
    assert!(run(true, None).finished);
    assert_eq!(calls(), 2, "resumed at step 5, past the guided steps: not fitted");
}

/// A config that turns the guide on, trained through the library without a fit to guide by, is
/// refused by name before anything is written.
#[test]
fn a_guide_without_a_fit_is_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let cfg = config(tmp.path(), "unguided", &seq, "steps = 2\n[train.guide]\nweight = 10.0\n");
    let config = puppet::TrainConfig::load(&cfg).unwrap();
    let e = puppet::train(&config, &puppet::TrainOptions::default(), &puppet::Silent)
        .unwrap_err()
        .to_string();
    assert!(e.contains("train.guide.weight"), "{e}");
    assert!(!tmp.path().join("unguided").exists(), "nothing written");
}

/// The drawn frames augmented (`[train.augment]`): the first step's loss is measured on moved
/// frames, so it differs from the same run's without augmentation (the untrained weights are the
/// same: they depend on the seed).
#[test]
fn augmented_frames_are_what_the_first_step_sees() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 4, "64x64");
    let first_loss = |name: &str, extra: &str| {
        let cfg = config(tmp.path(), name, &seq, &format!("steps = 1\n{extra}"));
        puppet(tmp.path(), &["train", cfg.to_str().unwrap()]).assert_ok();
        losses(&tmp.path().join(name))[0]
    };
    let plain = first_loss("plain", "");
    let again = first_loss("again", "");
    let moved = first_loss("moved", AUGMENT);
    assert_eq!(plain, again, "a run's first loss is a function of its config");
    assert!(
        moved.is_finite() && moved != plain,
        "moved frames give another loss: {moved} vs {plain}"
    );
}

/// A rig that skins by affine maps trains, with a warning that networks learn badly through it.
#[test]
fn training_through_an_affine_rig_warns() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("dressed");
    let args = ["synth", "--accessories", "--seed", "5", "--frames", "4", "--size", "64x64", "-o"];
    puppet(tmp.path(), &[&args[..], &[seq.to_str().unwrap()]].concat()).assert_ok();
    let toml = seq.join("template/character.toml");
    let text = std::fs::read_to_string(&toml).unwrap();
    std::fs::write(&toml, format!("{text}\n[rig]\nskinning = \"affine\"\n")).unwrap();
    let cfg = config(tmp.path(), "affine", &seq, "steps = 1\n");
    let run = puppet(tmp.path(), &["train", cfg.to_str().unwrap()]);
    run.assert_ok();
    assert!(run.stderr.contains("skinning = \"affine\""), "{}", run.stderr);
}

/// `split_seed` holds out the same frames for runs of other seeds (whose weights differ); without
/// it the seed picks the split too.
#[test]
fn a_split_seed_keeps_the_held_out_frames_of_another_seed() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = synth(tmp.path(), 8, "64x64");
    let run = |name: &str, seeds: &str| {
        let text = format!(
            "puppet = \"{seq}/template\"\nframes = \"{seq}\"\noutput = \"{out}\"\n{seeds}\ntest_fraction = 0.5\n\
             [model]\ninput_size = 32\nlatent = 32\n[train]\nsteps = 1\nbatch = 4\n",
            seq = seq.display(),
            out = tmp.path().join(name).display()
        );
        let cfg = tmp.path().join(format!("{name}.toml"));
        std::fs::write(&cfg, text).unwrap();
        puppet(tmp.path(), &["train", cfg.to_str().unwrap()]).assert_ok();
        let split: serde_json::Value = serde_json::from_slice(&std::fs::read(tmp.path().join(name).join("split.json")).unwrap()).unwrap();
        let weights = std::fs::read(tmp.path().join(name).join("weights.bpk")).unwrap();
        (split["test"].clone(), weights)
    };
    let (one, one_weights) = run("one", "seed = 1");
    let (two, two_weights) = run("two", "seed = 2\nsplit_seed = 1");
    let (three, _) = run("three", "seed = 3");
    assert_eq!(one, two, "the same held-out frames");
    assert_ne!(one_weights, two_weights, "other weights");
    assert_ne!(one, three, "seed 3 alone splits otherwise");
}
