//! `puppet prior data` (issue 56): a character posed by the engine, written with its truth and
//! scored by `prior eval`; the refusals write nothing.

use crate::util::{puppet, repo};

#[test]
fn prior_data_poses_the_robot_with_its_truth_one_seed_gives_the_same_files_and_eval_scores_them() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = repo().join("data/kenney/robot");
    let run = |out: &str| {
        puppet(
            tmp.path(),
            &["prior", "data", robot.to_str().unwrap(), "-o", out, "--poses", "3", "--seed", "1"],
        )
    };
    run("a").assert_ok();
    let dir = tmp.path().join("a/robot");
    let built = puppet::puppet::format::load(&dir).unwrap();
    for file in ["rest.png", "sheet.png", "layers.json", "puppet.json"] {
        assert!(dir.join(file).is_file(), "{file} is missing");
    }
    for k in 0..3 {
        let frame = image::open(dir.join(format!("pose_{k:03}.png"))).unwrap();
        let labels = image::open(dir.join(format!("pose_{k:03}_labels.png"))).unwrap();
        assert_eq!((frame.width(), frame.height()), (built.width, built.height));
        assert_eq!((labels.width(), labels.height()), (built.width, built.height));
        let truth: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join(format!("pose_{k:03}.json"))).unwrap()).unwrap();
        let vertices = truth["vertices"].as_array().unwrap();
        let visible = truth["visible"].as_array().unwrap();
        assert_eq!(vertices.len(), built.vertex_count());
        assert_eq!(visible.len(), built.vertex_count());
        let shown = visible.iter().filter(|v| v.as_bool().unwrap()).count();
        assert!(shown > built.vertex_count() / 2, "pose {k}: only {shown} vertices shown");
    }
    assert!(!dir.join("pose_003.png").exists());
    run("b").assert_ok();
    for k in 0..3 {
        let name = format!("pose_{k:03}.json");
        assert_eq!(
            std::fs::read(dir.join(&name)).unwrap(),
            std::fs::read(tmp.path().join("b/robot").join(&name)).unwrap(),
            "{name} differs between two runs with one seed"
        );
    }
    // Writing again into a folder puppet made is allowed.
    run("a").assert_ok();
    // The table is `prior eval`'s result, so --quiet keeps it: a PCK per network, in percent.
    let scored = puppet(tmp.path(), &["-q", "prior", "eval", dir.to_str().unwrap()]);
    scored.assert_ok();
    for row in ["robot", "mean over characters"] {
        for net in ["prior", "parts"] {
            let line = scored
                .stdout
                .lines()
                .find(|l| l.starts_with(row) && l.split_whitespace().any(|w| w == net))
                .unwrap_or_else(|| panic!("no {row} row for the {net} network in:\n{}", scored.stdout));
            let pck: Vec<f64> = line.split_whitespace().filter_map(|w| w.strip_suffix('%')?.parse().ok()).collect();
            assert_eq!(pck.len(), 3, "{line}");
            assert!(pck.iter().all(|p| (0.0..=100.0).contains(p)), "{line}");
        }
    }
}

#[test]
fn prior_data_refuses_bad_pose_counts_and_bad_artwork_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = repo().join("data/kenney/robot");
    for bad in ["0", "10001"] {
        let out = tmp.path().join(format!("n{bad}"));
        puppet(
            tmp.path(),
            &[
                "prior",
                "data",
                robot.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--poses",
                bad,
            ],
        )
        .assert_error(&[&format!("--poses {bad}"), "1 to 10000"]);
        assert!(!out.exists(), "a refused command made {}", out.display());
    }
    let missing = tmp.path().join("no_such_character");
    let out = tmp.path().join("m");
    puppet(
        tmp.path(),
        &[
            "prior",
            "data",
            robot.to_str().unwrap(),
            missing.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--poses",
            "1",
        ],
    )
    .assert_error(&["no_such_character"]);
    assert!(!out.exists(), "a refused command made {}", out.display());
}

/// The mean L2 of `puppet eval` run with `args` in `dir`, read from its JSON report.
fn eval_l2(dir: &std::path::Path, args: &[&str], report: &str) -> f64 {
    let mut all = vec!["eval"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["-o", report]);
    puppet(dir, &all).assert_ok();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join(report)).unwrap()).unwrap();
    json["mean"]["l2"].as_f64().unwrap()
}

#[test]
fn a_character_nobody_trained_is_fitted_from_the_prior() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = repo().join("data/kenney/robot");
    let frames = tmp.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    for name in ["robot_walk0.png", "robot_fall.png"] {
        std::fs::copy(robot.join("frames").join(name), frames.join(name)).unwrap();
    }
    let (r, f) = (robot.to_str().unwrap(), frames.to_str().unwrap());
    // The prior's placement alone, against the rest pose left where it is.
    let placed = eval_l2(tmp.path(), &["--puppet", r, f, "--one-pass"], "placed.json");
    let rest = eval_l2(tmp.path(), &["--puppet", r, f, "--one-pass", "--from-rest"], "rest.json");
    assert!(
        placed < 0.9 * rest,
        "the prior's placement scores L2 {placed}, the rest pose {rest}"
    );
    // `fit` writes what it writes for a trained model.
    puppet(
        tmp.path(),
        &["fit", "--puppet", r, f, "-o", "fits", "--vertex-steps", "4", "--vertex-rounds", "1"],
    )
    .assert_ok();
    for name in [
        "robot_walk0_render.png",
        "robot_walk0_vertices.json",
        "robot_fall_overlay.png",
        "sheet.png",
    ] {
        assert!(tmp.path().join("fits").join(name).is_file(), "{name} is missing");
    }
    // `correspond` maps points between two frames of the character through its prior fits.
    let (a, b) = (frames.join("robot_walk0.png"), frames.join("robot_fall.png"));
    let run = puppet(
        tmp.path(),
        &[
            "correspond",
            "--puppet",
            r,
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "-o",
            "pairs.json",
            "--vertex-steps",
            "4",
            "--vertex-rounds",
            "1",
        ],
    );
    run.assert_ok();
    let pairs: serde_json::Value = serde_json::from_slice(&std::fs::read(tmp.path().join("pairs.json")).unwrap()).unwrap();
    let mapped = pairs.as_array().unwrap().iter().filter(|m| !m["to"].is_null()).count();
    assert!(mapped > 10, "{} points mapped: {}", mapped, run.stdout);
}

#[test]
fn zero_shot_fitting_refuses_a_frame_of_another_size_and_a_puppet_that_draws_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = repo().join("data/kenney/robot");
    let small = tmp.path().join("small.png");
    image::RgbaImage::from_pixel(40, 30, image::Rgba([200, 10, 10, 128]))
        .save(&small)
        .unwrap();
    let out = tmp.path().join("out");
    puppet(
        tmp.path(),
        &[
            "fit",
            "--puppet",
            robot.to_str().unwrap(),
            small.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    )
    .assert_error(&["small.png", "40×30"]);
    assert!(!out.exists(), "a refused fit made {}", out.display());
    // A character whose only layer is transparent everywhere.
    let blank = tmp.path().join("blank");
    std::fs::create_dir(&blank).unwrap();
    image::RgbaImage::new(96, 128).save(blank.join("body.png")).unwrap();
    std::fs::write(
        blank.join("character.toml"),
        "root = \"body\"\n[[layer]]\nname = \"body\"\nfile = \"body.png\"\nkind = \"body\"\n",
    )
    .unwrap();
    let frame = robot.join("frames/robot_walk0.png");
    puppet(
        tmp.path(),
        &[
            "fit",
            "--puppet",
            blank.to_str().unwrap(),
            frame.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    )
    .assert_error(&["body.png", "transparent"]);
    assert!(!out.exists(), "a refused fit made {}", out.display());
    let missing = tmp.path().join("no_such_puppet");
    puppet(
        tmp.path(),
        &["eval", "--puppet", missing.to_str().unwrap(), frame.to_str().unwrap()],
    )
    .assert_error(&["no_such_puppet"]);
}

/// A prior's config of a few steps on a tiny network: one character to train on, one held out.
fn tiny_prior_config(dir: &std::path::Path, held_out: &str) -> std::path::PathBuf {
    let data = repo().join("data/rigs/dicebear");
    let config = dir.join("prior.toml");
    std::fs::write(
        &config,
        format!(
            "characters = [{:?}]\nheld_out = [{:?}]\noutput = \"run\"\ngenerator_share = 0.5\n\
             [net]\nsteps = 3\nbatch = 2\nheld_out = 2\ninput_size = 64\ndepth = 2\nbase_channels = 4\n\
             max_channels = 8\nfeatures = 8\nanchors = 32\nnegatives = 64\ncheckpoint_every = 2\neval_every = 2\n",
            data.join("personas-1"),
            data.join(held_out)
        ),
    )
    .unwrap();
    config
}

#[test]
fn the_prior_trains_from_its_config_and_one_seed_gives_one_network() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_prior_config(tmp.path(), "personas-6");
    let c = config.to_str().unwrap();
    puppet(tmp.path(), &["prior", "train", c]).assert_ok();
    puppet(tmp.path(), &["prior", "train", c, "-o", "again"]).assert_ok();
    // Burn's records carry random parameter ids, so compare what the weights compute: the
    // features of one input, bit for bit.
    let device = puppet::backend::device();
    let input: Vec<f32> = (0..4 * 64 * 64).map(|i| ((i * 37 % 101) as f32) / 101.0).collect();
    let features = |dir: &str| {
        let net = puppet::parts::learn::TrainedNet::load(&tmp.path().join(dir), &device).unwrap();
        puppet::parts::matching::features(&net.net, &[&input], 64, &device)
    };
    assert!(
        features("run") == features("again"),
        "two runs of one config trained different weights"
    );
    for file in ["net.json", "config.toml", "log.csv", "curves.png"] {
        assert!(tmp.path().join("run").join(file).is_file(), "{file} is missing");
    }
    // The run's config records the characters, and a resume holds to them.
    let recorded = std::fs::read_to_string(tmp.path().join("run/config.toml")).unwrap();
    assert!(recorded.contains("personas-1") && recorded.contains("personas-6"), "{recorded}");
    puppet(tmp.path(), &["prior", "train", c]).assert_error(&["--resume"]);
}

#[test]
fn a_prior_config_that_trains_on_its_held_out_characters_is_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_prior_config(tmp.path(), "personas-1");
    puppet(tmp.path(), &["prior", "train", config.to_str().unwrap()]).assert_error(&["held_out", "personas-1", "prior.toml"]);
    assert!(!tmp.path().join("run").exists(), "a refused run made its folder");
}

#[test]
fn the_prior_configs_load_and_every_kenney_figure_comes_from_a_prior_that_never_saw_the_character() {
    const KENNEY: [&str; 3] = ["robot", "male_adventurer", "female_adventurer"];
    let configs = repo().join("configs");
    let trained_on = |file: &str| -> Vec<String> {
        let config = puppet::prior::PriorConfig::load(&configs.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let kenney = repo().join("data/kenney").canonicalize().unwrap();
        config
            .characters
            .iter()
            .filter_map(|p| Some(p.strip_prefix(&kenney).ok()?.to_string_lossy().into_owned()))
            .collect()
    };
    // The shipped prior saw none of them; each leave-one-out prior saw exactly the other two.
    assert_eq!(trained_on("prior.toml"), Vec::<String>::new());
    for left_out in KENNEY {
        let mut seen = trained_on(&format!("prior-without-{left_out}.toml"));
        seen.sort();
        let mut others: Vec<String> = KENNEY.iter().filter(|&&c| c != left_out).map(|c| c.to_string()).collect();
        others.sort();
        assert_eq!(seen, others, "prior-without-{left_out}.toml");
    }
}
