//! `puppet prior data` (issue 56): a character posed by the engine, written with its truth; the
//! refusals write nothing.

use crate::util::{puppet, repo};

#[test]
fn prior_data_poses_the_robot_with_its_truth_and_the_same_seed_gives_the_same_files() {
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
