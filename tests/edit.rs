//! `puppet inbetween`, `pose` and `correspond` end to end on the tiny test character with a small
//! untrained model (it predicts the rest pose, which is all these plumbing tests need), and every
//! bad input issue 6 names: pins off the character, a model for a different puppet, frames of
//! the wrong size or without alpha, `--steps 0`.

use std::path::{Path, PathBuf};

use crate::util::{puppet, write_hatted_character, write_layer_character};
use puppet::model::deformation::DeformationNetConfig;
use puppet::model::Model;
use puppet::puppet::format;

/// Builds the tiny character, saves a small untrained model for it, and writes two frames (the
/// rest render and a copy shifted 2 px right). Returns (model dir, frame a, frame b).
pub fn setup(tmp: &Path) -> (PathBuf, PathBuf, PathBuf) {
    setup_with(tmp, write_layer_character(&tmp.join("art"), ""))
}

/// As [`setup`] for the character whose artwork is in `art` (rigged if it has accessories).
fn setup_with(tmp: &Path, art: PathBuf) -> (PathBuf, PathBuf, PathBuf) {
    let built = tmp.join("built");
    puppet(tmp, &["build", art.to_str().unwrap(), "-o", built.to_str().unwrap()]).assert_ok();
    let device = puppet::backend::device();
    let p = format::load(&built).unwrap();
    let config = DeformationNetConfig::new(p.free_vertices().len())
        .with_input_size(64)
        .with_encoder_hidden([32, 16])
        .with_latent(16)
        .with_decoder_hidden([16, 32]);
    let model = Model::new(config, p, &device).unwrap();
    let dir = tmp.join("model");
    model.save(&dir).unwrap();
    let rest = puppet::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 64, 64).unwrap();
    let a = tmp.join("a.png");
    rest.save_png(&a).unwrap();
    let shifted: Vec<[f32; 2]> = model.puppet.rest_vertices().iter().map(|v| [v[0] + 2.0, v[1]]).collect();
    let b = tmp.join("b.png");
    puppet::render::render_crisp(&model.puppet, &shifted, 64, 64)
        .unwrap()
        .save_png(&b)
        .unwrap();
    (dir, a, b)
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `puppet eval` of a dressed model on a dressed synthetic sequence reports the body's and the
/// accessories' vertex errors apart, and scores the accessories on the fits, on in-betweens of
/// consecutive frames and on drags.
#[test]
fn eval_of_a_dressed_synthetic_sequence_splits_body_and_accessory_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("seq");
    puppet(
        tmp.path(),
        &[
            "synth",
            "--accessories",
            "--seed",
            "5",
            "--frames",
            "3",
            "--size",
            "64x64",
            "-o",
            s(&seq),
        ],
    )
    .assert_ok();
    let (model, _, _) = setup_with(tmp.path(), seq.join("template"));
    let run = puppet(tmp.path(), &["eval", "--model", s(&model), s(&seq), "--one-pass", "-o", "r.json"]);
    run.assert_ok();
    assert!(run.stdout.contains("vertex error, mean (px): body"), "{}", run.stdout);
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(tmp.path().join("r.json")).unwrap()).unwrap();
    let split = &json["mean"]["split"];
    for key in ["body", "body_visible", "accessories", "accessories_visible"] {
        assert!(split[key].as_f64().is_some_and(f64::is_finite), "{key}: {split}");
    }
    // Each layer's error, named: the mean over all vertices lies between the layers' means.
    assert!(run.stdout.contains("vertex error by layer, mean (px): "), "{}", run.stdout);
    for frame in json["frames"].as_array().unwrap() {
        let layers: Vec<f64> = frame["layer_errors"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e.as_f64().unwrap())
            .collect();
        assert_eq!(layers.len(), json["layers"].as_array().unwrap().len());
        let all = frame["vertex_error"].as_f64().unwrap();
        let (lo, hi) = layers.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| (lo.min(e), hi.max(e)));
        assert!(lo <= all + 1e-9 && all <= hi + 1e-9, "{all} outside the layers' [{lo}, {hi}]");
    }
    let accessories = &json["accessories"];
    assert_eq!(accessories["poses"], serde_json::json!([3, 6, 12]), "{accessories}");
    for kind in ["fits", "inbetweens", "drags"] {
        let kept = accessories[kind]["occlusion_kept"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&kept), "{kind}: {kept}");
    }
}

#[test]
fn inbetween_writes_steps_sheets_and_a_gif() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, b) = setup(tmp.path());
    let out = tmp.path().join("ib");
    let gif = tmp.path().join("ib.gif");
    let training = tmp.path().join("training");
    std::fs::create_dir_all(&training).unwrap();
    std::fs::copy(&a, training.join("t0.png")).unwrap();
    std::fs::copy(&b, training.join("t1.png")).unwrap();
    let run = puppet(
        tmp.path(),
        &[
            "inbetween",
            "--model",
            s(&model),
            s(&a),
            s(&b),
            "--steps",
            "3",
            "-o",
            s(&out),
            "--gif",
            s(&gif),
            "--apng",
            s(&tmp.path().join("ib.apng")),
            "--training",
            s(&training),
        ],
    );
    run.assert_ok();
    assert!(run.stdout.contains("3 in-betweens (5 frames"), "{}", run.stdout);
    assert!(
        run.stdout.contains("the first and last frames are the keyframes' fits: L2 "),
        "{}",
        run.stdout
    );
    for k in 0..5 {
        for sub in ["inbetween", "vertex", "arap", "nearest"] {
            assert!(out.join(sub).join(format!("step_00{k}.png")).is_file(), "{sub} step {k}");
        }
        let pose = format!("inbetween/step_00{k}.json");
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join(&pose)).unwrap()).unwrap();
        assert!(json["vertices"].as_array().is_some_and(|v| !v.is_empty()), "{pose}");
    }
    assert!(!out.join("inbetween/step_005.png").exists());
    let sheet = image::open(out.join("sheet.png")).unwrap();
    assert!(sheet.width() > 5 * 64 && sheet.height() > 4 * 64, "four rows of five");
    let sprites = image::open(out.join("sprites.png")).unwrap();
    assert_eq!((sprites.width(), sprites.height()), (5 * 64, 64));
    // The GIF goes there and back: 5 + 3 frames.
    use image::AnimationDecoder;
    let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(std::fs::File::open(&gif).unwrap())).unwrap();
    assert_eq!(decoder.into_frames().collect_frames().unwrap().len(), 8);
    let apng =
        image::codecs::png::PngDecoder::new(std::io::BufReader::new(std::fs::File::open(tmp.path().join("ib.apng")).unwrap())).unwrap();
    let frames = apng.apng().unwrap().into_frames().collect_frames().unwrap();
    assert_eq!(frames.len(), 8);
    assert_eq!(frames[0].buffer().get_pixel(0, 0).0[3], 0, "a transparent background");
    let atlas: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("sprites.json")).unwrap()).unwrap();
    assert_eq!(atlas["frames"].as_object().unwrap().len(), 5);
    assert_eq!(atlas["animations"]["sprites"].as_array().unwrap().len(), 8, "there and back");
    assert_eq!(atlas["meta"]["image"], "sprites.png");
}

/// `puppet export spine` turns an in-between's poses and a dragged pose into one skeleton, and
/// refuses a pose of another puppet naming the file, and an output it would overwrite.
#[test]
fn export_spine_writes_a_skeleton_of_inbetween_and_pose_files() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, b) = setup(tmp.path());
    let ib = tmp.path().join("ib");
    puppet(
        tmp.path(),
        &["inbetween", "--model", s(&model), s(&a), s(&b), "--steps", "2", "-o", s(&ib)],
    )
    .assert_ok();
    let posed = tmp.path().join("posed.png");
    puppet(
        tmp.path(),
        &["pose", "--model", s(&model), s(&a), "--pin", "24,30:26,30", "-o", s(&posed)],
    )
    .assert_ok();
    let out = tmp.path().join("spine");
    let run = puppet(
        tmp.path(),
        &[
            "export",
            "spine",
            "--model",
            s(&model),
            s(&ib.join("inbetween")),
            s(&tmp.path().join("posed.json")),
            "-o",
            s(&out),
            "--name",
            "tiny",
        ],
    );
    run.assert_ok();
    assert!(run.stdout.contains("inbetween (4 keys), posed (1 keys)"), "{}", run.stdout);
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("tiny.json")).unwrap()).unwrap();
    assert_eq!(json["skeleton"]["spine"], "4.2.0");
    let layers = json["slots"].as_array().unwrap().len();
    assert_eq!(json["bones"].as_array().unwrap().len(), layers);
    let walk = &json["animations"]["inbetween"];
    let first_bone = json["bones"][0]["name"].as_str().unwrap();
    assert_eq!(walk["bones"][first_bone]["rotate"].as_array().unwrap().len(), 4);
    assert!(std::fs::read_to_string(out.join("tiny.atlas"))
        .unwrap()
        .starts_with("tiny.png\nsize: "));
    assert!(image::open(out.join("tiny.png")).is_ok());

    std::fs::write(tmp.path().join("other.json"), br#"{"vertices": [[1, 2], [3, 4]]}"#).unwrap();
    let other = puppet(tmp.path(), &["export", "spine", "--model", s(&model), "other.json", "-o", "again"]);
    other.assert_error(&["other.json", "2 vertices, but the puppet has"]);
    assert!(!tmp.path().join("again").exists(), "a refused export writes nothing");
    // A file of the user's where the skeleton would go is never replaced.
    std::fs::write(out.join("mine.atlas"), b"user's").unwrap();
    let clash = puppet(
        tmp.path(),
        &[
            "export",
            "spine",
            "--model",
            s(&model),
            s(&ib.join("inbetween")),
            "-o",
            s(&out),
            "--name",
            "mine",
        ],
    );
    clash.assert_error(&["mine.atlas", "--force"]);
    assert_eq!(std::fs::read(out.join("mine.atlas")).unwrap(), b"user's");
    assert!(!out.join("mine.json").exists(), "nothing is written when one output is in the way");
}

#[test]
fn pose_writes_the_posed_frame_the_arap_comparison_and_the_drag_gif() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup(tmp.path());
    let out = tmp.path().join("posed.png");
    let gif = tmp.path().join("drag.gif");
    // The arm box spans x 40..52, y 26..34: grab its tip, lift it.
    let run = puppet(
        tmp.path(),
        &[
            "pose",
            "--model",
            s(&model),
            s(&a),
            "--pin",
            "50,30:50,20",
            "-o",
            s(&out),
            "--gif",
            s(&gif),
            "--drag-frames",
            "3",
            "--sprites",
            s(&tmp.path().join("drag.png")),
        ],
    );
    run.assert_ok();
    assert!(run.stdout.contains("pin error"), "{}", run.stdout);
    for f in [
        "posed.png",
        "posed_arap.png",
        "posed_sheet.png",
        "posed.json",
        "drag.gif",
        "drag.png",
        "drag.json",
    ] {
        assert!(tmp.path().join(f).is_file(), "{f} missing");
    }
    let atlas: serde_json::Value = serde_json::from_slice(&std::fs::read(tmp.path().join("drag.json")).unwrap()).unwrap();
    assert_eq!(
        atlas["animations"]["drag"].as_array().unwrap().len(),
        3,
        "one sheet cell per update"
    );
    // The ARAP comparison moved the arm: its render differs from the input frame.
    let arap = puppet::picture::Picture::load(&tmp.path().join("posed_arap.png")).unwrap();
    let input = puppet::picture::Picture::load(&a).unwrap();
    assert!(puppet::metrics::l2(&arap, &input) > 500.0, "the ARAP drag should lift the arm");
}

/// The vertex count of the pose file at `path`.
fn pose_len(path: &Path) -> usize {
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    json["vertices"].as_array().unwrap().len()
}

/// Whether the hat's dark grey is at (x, y) of the PNG at `path`.
fn hat_at(path: &Path, x: u32, y: u32) -> bool {
    let p = puppet::picture::Picture::load(path).unwrap().get(x, y);
    p[3] > 0.5 && p[0] < 0.2
}

#[test]
fn outfits_dress_inbetweens_fits_and_drags_of_a_bare_model() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, b) = setup(tmp.path());
    let outfit = write_hatted_character(&tmp.path().join("outfit"));
    let bare = format::load(&tmp.path().join("built")).unwrap().vertex_count();

    let ib = tmp.path().join("ib");
    let run = puppet(
        tmp.path(),
        &[
            "inbetween",
            "--model",
            s(&model),
            s(&a),
            s(&b),
            "--steps",
            "1",
            "-o",
            s(&ib),
            "--dress",
            s(&outfit),
        ],
    );
    run.assert_ok();
    assert!(run.stdout.contains("outfit: 1 accessories"), "{}", run.stdout);
    assert!(
        pose_len(&ib.join("inbetween/step_001.json")) > bare,
        "the poses are of the dressed puppet"
    );
    // Above the head, where only the hat is.
    assert!(hat_at(&ib.join("inbetween/step_000.png"), 32, 5) && !hat_at(&a, 32, 5));

    let fit = tmp.path().join("fit");
    puppet(
        tmp.path(),
        &[
            "fit",
            "--model",
            s(&model),
            s(&a),
            "-o",
            s(&fit),
            "--one-pass",
            "--dress",
            s(&outfit),
        ],
    )
    .assert_ok();
    assert!(hat_at(&fit.join("a_render.png"), 32, 5));

    let posed = tmp.path().join("posed.png");
    let run = puppet(
        tmp.path(),
        &[
            "pose",
            "--model",
            s(&model),
            s(&a),
            "--pin",
            "50,30:50,20",
            "-o",
            s(&posed),
            "--dress",
            s(&outfit),
        ],
    );
    run.assert_ok();
    assert!(hat_at(&posed, 32, 5) && hat_at(&tmp.path().join("posed_arap.png"), 32, 5));
    assert!(pose_len(&tmp.path().join("posed.json")) > bare);
    // Poses of the model's own puppet exported in the outfit: the hat is a slot of its own;
    // poses already dressed are not poses of the model's puppet.
    let bare_fit = tmp.path().join("bare_fit");
    puppet(tmp.path(), &["fit", "--model", s(&model), s(&a), "--one-pass", "-o", s(&bare_fit)]).assert_ok();
    let spine = tmp.path().join("spine");
    let export = |poses: &Path| {
        puppet(
            tmp.path(),
            &[
                "export",
                "spine",
                "--model",
                s(&model),
                s(poses),
                "-o",
                s(&spine),
                "--dress",
                s(&outfit),
            ],
        )
    };
    export(&bare_fit).assert_ok();
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(spine.join("puppet.json")).unwrap()).unwrap();
    assert!(
        json["slots"].as_array().unwrap().iter().any(|slot| slot["name"] == "hat"),
        "{}",
        json["slots"]
    );
    export(&ib.join("inbetween")).assert_error(&["vertices, but the puppet has"]);

    // What cannot be worn is refused, naming it; nothing is written.
    let out = tmp.path().join("refused");
    puppet(tmp.path(), &["fit", "--model", s(&model), s(&a), "-o", s(&out), "--undress", "hat"]).assert_error(&[
        "--undress",
        "\"hat\"",
        "has none",
    ]);
    puppet(
        tmp.path(),
        &["fit", "--model", s(&model), s(&a), "-o", s(&out), "--undress", "torso"],
    )
    .assert_error(&["--undress", "\"torso\" (a body layer)"]);
    let other = write_layer_character(&tmp.path().join("other"), "");
    std::fs::remove_file(other.join("arm.png")).unwrap();
    let toml = std::fs::read_to_string(other.join("character.toml")).unwrap();
    std::fs::write(
        other.join("character.toml"),
        toml.replace("[[layer]]\nname = \"arm\"\nfile = \"arm.png\"\n", ""),
    )
    .unwrap();
    puppet(
        tmp.path(),
        &["fit", "--model", s(&model), s(&a), "-o", s(&out), "--dress", s(&other)],
    )
    .assert_error(&["--dress", "other", "arm", "does not draw"]);
    // An accessory far from every layer: named, with the fix.
    let floating = write_hatted_character(&tmp.path().join("floating"));
    crate::util::shape(64, 64, [200, 0, 0, 255], |x, y| x < 6.0 && y > 58.0)
        .save(floating.join("hat.png"))
        .unwrap();
    puppet(
        tmp.path(),
        &["fit", "--model", s(&model), s(&a), "-o", s(&out), "--dress", s(&floating)],
    )
    .assert_error(&["--dress", "\"hat\"", "rig.edge"]);
    assert!(!out.exists(), "a refused outfit wrote {}", out.display());
}

#[test]
fn a_rigged_model_drags_the_body_by_its_hat_and_takes_the_hat_off() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup_with(tmp.path(), write_hatted_character(&tmp.path().join("art")));
    assert!(hat_at(&a, 32, 5), "the frames show the hat");
    // A pin on the hat, above the head, pulled right: the ARAP comparison moves the head under it.
    let posed = tmp.path().join("posed.png");
    puppet(
        tmp.path(),
        &["pose", "--model", s(&model), s(&a), "--pin", "32,5:38,5", "-o", s(&posed)],
    )
    .assert_ok();
    let arap = tmp.path().join("posed_arap.png");
    assert!(hat_at(&arap, 37, 5) && !hat_at(&arap, 24, 5), "the hat moved right");
    let head = |path: &Path| puppet::picture::Picture::load(path).unwrap().get(23, 16);
    assert!(head(&a)[3] > 0.5 && head(&arap)[3] < 0.5, "the head moved with its hat");

    // eval scores the rig-placed hat on the fits, on in-betweens and on drags too.
    let seq = tmp.path().join("seq");
    std::fs::create_dir_all(&seq).unwrap();
    std::fs::copy(&a, seq.join("a.png")).unwrap();
    std::fs::copy(&a, seq.join("b.png")).unwrap();
    let run = puppet(tmp.path(), &["eval", "--model", s(&model), s(&seq), "--one-pass"]);
    run.assert_ok();
    for row in ["accessories (worst pose)", "fits", "in-betweens", "drags"] {
        assert!(run.stdout.contains(row), "{row}: {}", run.stdout);
    }

    let ib = tmp.path().join("ib");
    let run = puppet(
        tmp.path(),
        &[
            "inbetween",
            "--model",
            s(&model),
            s(&a),
            s(&a),
            "--steps",
            "1",
            "-o",
            s(&ib),
            "--undress",
            "hat",
        ],
    );
    run.assert_ok();
    assert!(!hat_at(&ib.join("inbetween/step_001.png"), 32, 5), "the hat is off");
    let built = format::load(&tmp.path().join("built")).unwrap();
    assert_eq!(pose_len(&ib.join("inbetween/step_001.json")), built.free_vertices().len());
}

#[test]
fn a_model_trained_without_the_rig_cannot_change_its_accessories() {
    let tmp = tempfile::tempdir().unwrap();
    let art = write_hatted_character(&tmp.path().join("art"));
    let artwork = puppet::puppet::artwork::load(&art, &Default::default()).unwrap();
    let (p, _) = puppet::puppet::build::build(&artwork, &Default::default(), &puppet::progress::Silent).unwrap();
    assert!(p.rig.is_none());
    let config = DeformationNetConfig::new(p.free_vertices().len())
        .with_input_size(64)
        .with_encoder_hidden([32, 16])
        .with_latent(16)
        .with_decoder_hidden([16, 32]);
    let device = puppet::backend::device();
    let model = Model::new(config, p, &device).unwrap();
    let dir = tmp.path().join("model");
    model.save(&dir).unwrap();
    let a = tmp.path().join("a.png");
    puppet::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 64, 64)
        .unwrap()
        .save_png(&a)
        .unwrap();
    puppet(tmp.path(), &["fit", "--model", s(&dir), s(&a), "-o", "out", "--undress", "hat"]).assert_error(&[
        "--undress",
        "model.rig",
        "trained without the rig",
    ]);
}

#[test]
fn correspond_maps_points_and_reports_those_off_the_character() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, b) = setup(tmp.path());
    let points = tmp.path().join("pts.json");
    std::fs::write(&points, "[[32, 40], [1, 1], [46, 30]]").unwrap();
    let out = tmp.path().join("c.json");
    let run = puppet(
        tmp.path(),
        &[
            "correspond",
            "--model",
            s(&model),
            s(&a),
            s(&b),
            "--points",
            s(&points),
            "--vertex-steps",
            "0",
            "-o",
            s(&out),
        ],
    );
    run.assert_ok();
    assert!(run.stdout.contains("2 of 3 points mapped"), "{}", run.stdout);
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(json[1]["to"].is_null());
    assert_eq!(json[2]["layer"], "arm");
    // The untrained model fits both frames with the rest pose (on its manifold: no vertex
    // steps), so points map to themselves.
    let to = json[0]["to"].as_array().unwrap();
    assert!((to[0].as_f64().unwrap() - 32.0).abs() < 1e-3 && (to[1].as_f64().unwrap() - 40.0).abs() < 1e-3);
    assert!(tmp.path().join("c_pairs.png").is_file());
    // Default points: a grid over the character.
    let run = puppet(tmp.path(), &["correspond", "--model", s(&model), s(&a), s(&b), "-o", s(&out)]);
    run.assert_ok();
}

#[test]
fn pins_off_the_character_are_refused_naming_the_pin_and_the_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup(tmp.path());
    let out = tmp.path().join("p.png");
    let run = puppet(
        tmp.path(),
        &[
            "pose",
            "--model",
            s(&model),
            s(&a),
            "--pin",
            "50,30:50,20",
            "--pin",
            "2,2:5,5",
            "-o",
            s(&out),
        ],
    );
    run.assert_error(&["a.png", "pin 2", "not on the character", "px away"]);
    assert!(!out.exists());
}

#[test]
fn a_model_for_a_different_puppet_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup(tmp.path());
    // Replace the model's puppet by another character's (one layer fewer).
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    let mut toml = String::from("name = \"other\"\nroot = \"torso\"\n");
    for (name, img) in crate::util::tiny_layers().into_iter().take(2) {
        img.save(other.join(format!("{name}.png"))).unwrap();
        toml.push_str(&format!("[[layer]]\nname = \"{name}\"\nfile = \"{name}.png\"\n"));
    }
    std::fs::write(other.join("character.toml"), toml).unwrap();
    // The model folder was written by the library, not the CLI: replacing its puppet needs --force.
    puppet(tmp.path(), &["build", s(&other), "-o", s(&model.join("puppet"))]).assert_error(&["refusing to overwrite"]);
    puppet(tmp.path(), &["build", s(&other), "-o", s(&model.join("puppet")), "--force"]).assert_ok();
    let run = puppet(
        tmp.path(),
        &["inbetween", "--model", s(&model), s(&a), s(&a), "-o", s(&tmp.path().join("o"))],
    );
    run.assert_error(&["net.json", "different puppet"]);
}

#[test]
fn frames_of_the_wrong_size_or_without_alpha_and_zero_steps_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (model, a, _) = setup(tmp.path());
    let small = tmp.path().join("small.png");
    image::RgbaImage::from_pixel(32, 48, image::Rgba([0, 0, 0, 0]))
        .save(&small)
        .unwrap();
    let rgb = tmp.path().join("rgb.png");
    image::RgbImage::from_pixel(64, 64, image::Rgb([200, 10, 10])).save(&rgb).unwrap();
    let o = tmp.path().join("o.png");
    puppet(tmp.path(), &["inbetween", "--model", s(&model), s(&a), s(&small), "-o", s(&o)]).assert_error(&["small.png", "32×48", "64×64"]);
    puppet(
        tmp.path(),
        &["pose", "--model", s(&model), s(&rgb), "--pin", "1,1:2,2", "-o", s(&o)],
    )
    .assert_error(&["rgb.png", "opaque everywhere"]);
    puppet(tmp.path(), &["correspond", "--model", s(&model), s(&a), s(&small), "-o", "c.json"]).assert_error(&["small.png", "32×48"]);
    let inbetween_of_a = |timing: &[&str], out: &Path| {
        let args = [&["inbetween", "--model", s(&model), s(&a), s(&a), "-o", s(out)][..], timing].concat();
        puppet(tmp.path(), &args)
    };
    inbetween_of_a(&["--steps", "0"], &o).assert_error(&["--steps", "in-between steps = 0"]);
    inbetween_of_a(&["--spacing", "0.5,0.2"], &o).assert_error(&["--spacing", "spacing value 2"]);
    let spaced = inbetween_of_a(&["--spacing", "0.25,0.75"], &tmp.path().join("spaced"));
    spaced.assert_ok();
    let by_hand = "2 in-betweens (4 frames with the two ends, spaced by hand)";
    assert!(spaced.stdout.contains(by_hand), "{}", spaced.stdout);
    puppet(
        tmp.path(),
        &[
            "pose",
            "--model",
            s(&model),
            s(&a),
            "--pin",
            "50,30:50,20",
            "--steps",
            "0",
            "-o",
            s(&o),
        ],
    )
    .assert_error(&["--steps", "drag steps = 0"]);
    let run = puppet(tmp.path(), &["pose", "--model", s(&model), s(&a), "--pin", "50,30", "-o", s(&o)]);
    assert_eq!(run.code, 2, "a malformed pin is a usage error: {}", run.stderr);
    assert!(run.stderr.contains("is not a pin"), "{}", run.stderr);
    assert!(!o.exists(), "nothing written on error");
}

/// `puppet serve` without a model says what to run first; with a puppet folder it says that is
/// not a model; with a model it prints its address and answers the API over a real socket, and
/// 1,000 malformed requests leave it serving with flat memory.
#[test]
fn serve_finds_its_model_or_says_what_to_run_and_answers_on_its_port() {
    use std::io::{BufRead, Read, Write};
    let tmp = tempfile::tempdir().unwrap();
    let run = puppet(tmp.path(), &["serve"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(run.stderr.contains("run `puppet demo` first"), "{}", run.stderr);
    let (model, a, _) = setup(tmp.path());
    let run = puppet(tmp.path(), &["serve", "--model", s(&tmp.path().join("built"))]);
    assert!(run.stderr.contains("not a trained model"), "{}", run.stderr);
    let run = puppet(tmp.path(), &["serve", "--model", s(&model), "--frames", "nowhere"]);
    assert!(run.code == 1 && run.stderr.contains("--frames"), "{}", run.stderr);
    let run = puppet(tmp.path(), &["serve", "--model", s(&model), "--outfit", "no_such_outfit"]);
    assert!(run.code == 1 && run.stderr.contains("--outfit no_such_outfit"), "{}", run.stderr);
    // The frames beside a.png: a.png and b.png, both 64×64.
    let frames = a.parent().unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_puppet"))
        .args([
            "serve",
            "--model",
            s(&model),
            "--frames",
            s(frames),
            "--port",
            "0",
            "--latent-steps",
            "0",
        ])
        .current_dir(tmp.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let address = line
        .split("http://")
        .nth(1)
        .and_then(|rest| rest.split('/').next())
        .map(str::to_string);
    // One request on its own connection: the whole answer, or None if the server is gone.
    let ask = |method: &str, path: &str, body: &str| -> Option<String> {
        let address = address.as_deref()?;
        let mut stream = std::net::TcpStream::connect(address).ok()?;
        write!(
            stream,
            "{method} {path} HTTP/1.1\r\nHost: {address}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        )
        .ok()?;
        let mut answer = String::new();
        stream.read_to_string(&mut answer).ok()?;
        Some(answer)
    };
    let resident_kb = || {
        std::fs::read_to_string(format!("/proc/{}/status", child.id()))
            .ok()?
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))?
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse::<u64>()
            .ok()
    };
    let answer = ask("GET", "/api/frames", "");
    // 1,000 malformed requests over real sockets (bad JSON, NaN, points off the character, huge
    // counts, unknown fields, unknown sessions and routes): each a 4xx with a message, the server
    // still serving, its memory flat (measured after a first round, so allocator warm-up and
    // lazily built state are not counted as growth).
    let session = ask("POST", "/api/session", r#"{"frame": 0}"#).unwrap_or_default();
    let id = session
        .split(r#""session":""#)
        .nth(1)
        .and_then(|r| r.split('"').next())
        .unwrap_or("none")
        .to_string();
    let malformed: Vec<(&str, &str, String)> = vec![
        ("POST", "/api/drag", "{not json".into()),
        (
            "POST",
            "/api/drag",
            format!(r#"{{"session": "{id}", "pins": [{{"from": [NaN, 1], "to": [1, 1]}}]}}"#),
        ),
        (
            "POST",
            "/api/drag",
            format!(r#"{{"session": "{id}", "pins": [{{"from": [0.5, 0.5], "to": [1, 1]}}]}}"#),
        ),
        (
            "POST",
            "/api/drag",
            format!(r#"{{"session": "{id}", "pins": [{{"from": [1e39, 1], "to": [1, 1]}}]}}"#),
        ),
        (
            "POST",
            "/api/drag",
            format!(r#"{{"session": "{id}", "pins": [], "steps": 100000}}"#),
        ),
        (
            "POST",
            "/api/drag",
            r#"{"session": "nope", "pins": [{"from": [30, 30], "to": [1, 1]}]}"#.into(),
        ),
        ("POST", "/api/session", r#"{"frame": 0, "model": "other"}"#.into()),
        ("POST", "/api/session", r#"{"frame": 99999999}"#.into()),
        ("POST", "/api/inbetween", r#"{"from": 0, "to": 1, "count": 1000000000}"#.into()),
        ("POST", "/api/latent", format!(r#"{{"session": "{id}", "latent": [1, 2, 3]}}"#)),
        ("POST", "/api/export", format!(r#"{{"format": "exe", "session": "{id}"}}"#)),
        ("GET", "/api/texture/0/999.png", String::new()),
        ("GET", "/api/nowhere", String::new()),
    ];
    let round = |rounds: usize| -> Vec<String> {
        let mut wrong = Vec::new();
        for k in 0..rounds {
            let (method, path, body) = &malformed[k % malformed.len()];
            let answer = ask(method, path, body).unwrap_or_default();
            let status = answer.get(9..12).and_then(|s| s.parse::<u16>().ok()).unwrap_or(0);
            if !(400..500).contains(&status) || !answer.contains(r#"{"error":""#) {
                wrong.push(format!("{method} {path} {body:.60}: {answer:.200}"));
            }
        }
        wrong
    };
    let warm_up = round(malformed.len() * 8);
    let before = resident_kb();
    let wrong = round(1000);
    let after = resident_kb();
    let still = ask("GET", "/api/frames", "").unwrap_or_default();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        warm_up.is_empty() && wrong.is_empty(),
        "answers that are not a 4xx with a message: {wrong:#?} {warm_up:#?}"
    );
    assert!(
        still.starts_with("HTTP/1.1 200"),
        "the server still serves after 1,000 bad requests: {still:.200}"
    );
    let (before, after) = (before.unwrap(), after.unwrap());
    println!("server resident memory over 1,000 malformed requests: {before} kB → {after} kB");
    assert!(after <= before + 4096, "memory grew from {before} kB to {after} kB");
    let answer = answer.unwrap_or_else(|| panic!("no answer from the server that said {line:?}"));
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    assert!(
        answer.contains(r#""name":"a.png""#) && answer.contains(r#""name":"b.png""#),
        "{answer}"
    );
}
