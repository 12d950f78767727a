//! The whole pipeline from a program, on the bundled Kenney robot: build its puppet from the
//! artwork, train a (short) deformation network on its drawn frames, fit two of them, make the
//! in-betweens from one to the other, and export them as a Spine skeleton.
//!
//! `cargo run --release --example pipeline -- [OUTPUT] [STEPS]` (default `out/example`, 200
//! steps; run it again and training continues where it stopped). `cargo test --release` runs it
//! on a few steps.

// A program a user runs: it says what it did.
#![allow(clippy::print_stdout)]

use std::path::{Path, PathBuf};

use puppet::{
    BuildOptions, FitOptions, Frames, ImportOptions, InbetweenPath, Model, Outputs, PoseAnimation, Silent, TrainConfig, TrainOptions,
    Waypoints,
};

fn main() -> puppet::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = args.next().map_or_else(|| PathBuf::from("out/example"), PathBuf::from);
    let steps = args.next().and_then(|s| s.parse().ok()).unwrap_or(200);
    run(&out, steps)?;
    println!("wrote {}", out.display());
    Ok(())
}

/// Every step of the pipeline, writing into `out`.
fn run(out: &Path, steps: u64) -> puppet::Result<()> {
    let robot = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/kenney/robot");

    // 1. Artwork → puppet: a triangle mesh per layer, hinge joints where layers overlap.
    let artwork = puppet::load_artwork(&robot, &ImportOptions::default())?;
    let (built, report) = puppet::build(&artwork, &BuildOptions::default(), &Silent)?;
    let rest = puppet::render_crisp(&built, &built.rest_vertices(), built.width, built.height)?;
    rest.save_png(&out.join("rest.png"))?;
    println!("built {} layers, {} joints", built.layers.len(), report.sites.len());

    // 2. Train the deformation network on the drawn frames (the config of `puppet train`
    // without a config file, shortened). The model folder holds everything `fit` needs.
    let mut config = TrainConfig::with_paths(
        TrainConfig::DEFAULT_SETTINGS,
        Path::new("configs/train.toml"),
        &robot,
        &robot.join("frames"),
        &out.join("model"),
    )?;
    config.model.input_size = 32;
    config.train.steps = steps;
    config.train.checkpoint_every = steps;
    config.train.eval_every = steps;
    let resume = puppet::train::checkpoint::latest(&config.output)?.is_some();
    let summary = puppet::train(
        &config,
        &TrainOptions {
            resume,
            ..TrainOptions::default()
        },
        &Silent,
    )?;
    println!("trained {} steps", summary.steps);

    // 3. Fit two drawn frames: the network's one pass, then search on the latent.
    let device = puppet::backend::device();
    let model = Model::load(&config.output, &device)?;
    let frames = Frames::load(&robot.join("frames"), &puppet::fit::frame::frame_check(&model))?;
    let (a, b) = (&frames.frames[0], &frames.frames[1]);
    let fit_options = FitOptions {
        latent_steps: 10,
        ..FitOptions::one_pass()
    };
    let fits = puppet::fit(&model, &[a, b], &fit_options, &device, &Silent)?;
    for (k, pose) in fits.iter().enumerate() {
        puppet::render_crisp(&model.puppet, pose, built.width, built.height)?.save_png(&out.join(format!("fit_{k}.png")))?;
    }

    // 4. In-betweens along the learned manifold, through the training frames' poses.
    let waypoints = Waypoints::of_frames(&model, &frames.frames.iter().collect::<Vec<_>>(), &device)?;
    let t = [0.0, 0.25, 0.5, 0.75, 1.0];
    let between = puppet::inbetween(&model, a, b, &t, &fit_options, &waypoints, InbetweenPath::default(), &device)?;
    for (k, pose) in between.path.iter().enumerate() {
        puppet::render_crisp(&model.puppet, pose, built.width, built.height)?.save_png(&out.join(format!("inbetween_{k}.png")))?;
    }

    // 5. The in-betweens as a Spine 4.2 skeleton: JSON, atlas and texture page.
    let animation = PoseAnimation {
        name: "inbetween".into(),
        poses: between.path,
    };
    let skeleton = puppet::spine_skeleton(&model.puppet, &[animation], &[], "robot", 1.0 / 12.0)?;
    let written = puppet::export::spine::write(&skeleton, &out.join("spine"), "robot", &Outputs::new(false))?;
    println!("exported {} files to Spine", written.len());
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_pipeline_runs_on_the_robot_and_writes_each_stage() {
        let dir = tempfile::tempdir().unwrap();
        super::run(dir.path(), 2).unwrap();
        for file in [
            "rest.png",
            "fit_1.png",
            "inbetween_4.png",
            "model/weights.bpk",
            "spine/robot.json",
            "spine/robot.atlas",
        ] {
            assert!(dir.path().join(file).is_file(), "{file}");
        }
        // Run again: training resumes at its end, and every output is replaced as puppet's own.
        super::run(dir.path(), 2).unwrap();
    }
}
