//! Retargeting scored on generator characters (issue 57): character A's true poses played by a
//! model of character B, both drawn by `puppet synth` with one motion seed, so that B's own
//! frames of the motion are the answer. Prints, over the frames B's model held out, the mean
//! vertex error (px) and L2 against B's true frames of the default result (pulled onto B's
//! manifold), of the plain turns (`--rigid`), and of B's training frame nearest each true frame
//! (image L2, neural-puppet.md Figure 5's last row).
//!
//! `bench/retarget_synth.sh` draws the pairs, trains their models and runs this both ways:
//!
//! ```sh
//! cargo run --release --example retarget_synth -- A B MODEL_OF_B
//! ```

#![allow(clippy::print_stdout)] // the example reports on stdout

use std::path::PathBuf;

use puppet::edit::retarget::{retarget, Mapping, Motion, RetargetOptions, POSE_FRAME_TIME};
use puppet::metrics::{l2, vertex_error};
use puppet::synth::{true_positions, Truth};
use puppet::train::trainer::SplitRecord;
use puppet::{build, load_artwork, render_crisp, Model, Picture, Silent};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    let [a, b, model_dir] = args.as_slice() else {
        return Err("usage: retarget_synth SEQUENCE_A SEQUENCE_B MODEL_OF_B".into());
    };
    let device = puppet::backend::device();
    let model = Model::load(model_dir, &device)?;
    let source = build(
        &load_artwork(&a.join("template"), &Default::default())?,
        &Default::default(),
        &Silent,
    )?
    .0;
    let (truth_a, truth_b) = (Truth::load(&a.join("truth.json"))?, Truth::load(&b.join("truth.json"))?);
    let poses = |truth: &Truth, puppet| -> puppet::Result<Vec<Vec<[f32; 2]>>> {
        (0..truth.frames.len()).map(|f| true_positions(truth, f, puppet)).collect()
    };
    let (moved, answer) = (poses(&truth_a, &source)?, poses(&truth_b, &model.puppet)?);
    let motion = Motion::from_poses(&source, &moved, a, POSE_FRAME_TIME);
    let mapping = Mapping::new(&motion, &model.puppet, None, &Silent)?;
    let played = retarget(&model, &motion, &mapping, &RetargetOptions::default(), &device, &Silent)?;

    let split = SplitRecord::load(model_dir)?.ok_or("the model has no split.json")?;
    let frame = |name: &str| -> Result<(usize, Picture), Box<dyn std::error::Error>> {
        let f = truth_b
            .frame_named(name)
            .ok_or_else(|| format!("{name}: not a frame of {}", b.display()))?;
        Ok((f, Picture::load(&split.frames.join(name))?))
    };
    let trained = split.train.iter().map(|n| frame(n)).collect::<Result<Vec<_>, _>>()?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let score = |pose: &[[f32; 2]], f: usize, picture: &Picture| -> puppet::Result<[f64; 2]> {
        Ok([
            vertex_error(pose, &answer[f]),
            l2(&render_crisp(&model.puppet, pose, w, h)?, picture),
        ])
    };
    let mut sums = [[0.0f64; 2]; 3];
    for name in &split.test {
        let (f, picture) = frame(name)?;
        let nearest = trained
            .iter()
            .min_by(|x, y| l2(&x.1, &picture).total_cmp(&l2(&y.1, &picture)))
            .ok_or("the model has no training frames")?;
        let rows = [
            score(&played.poses[f], f, &picture)?,
            score(&played.rigid[f], f, &picture)?,
            [vertex_error(&answer[nearest.0], &answer[f]), l2(&nearest.1, &picture)],
        ];
        for (sum, row) in sums.iter_mut().zip(rows) {
            sum[0] += row[0];
            sum[1] += row[1];
        }
    }
    let n = split.test.len().max(1) as f64;
    println!("{}'s motion on {}: {} held-out frames", a.display(), b.display(), split.test.len());
    for (name, sum) in ["default (manifold)", "rigid (--rigid)", "nearest training frame"].iter().zip(sums) {
        println!("{name:24} vertex error {:6.2} px   L2 {:8.1}", sum[0] / n, sum[1] / n);
    }
    Ok(())
}
