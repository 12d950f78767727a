//! Speed of the part finder (issue 16, `puppet parts`): SLIC superpixels of one 128² pose
//! (`parts/slic/128`, the kernel `bench/slic_skimage.py` compares with scikit-image's SLIC on
//! the same poses), the generator's exact correspondences between every ordered pair of a
//! 10-pose sheet (`parts/true_flows/10x128`), and the whole finder on that sheet — superpixels
//! of every pose, merging, refinement, labelling every pose, hinges and order, the parts bent
//! into every pose by ARAP (`parts/find/10x128`), and that bending alone (`parts/deform/10x128`);
//! and the built-in correspondence network's correspondences between
//! every ordered pair of that sheet (`parts/network_flows/10x128`: features of the 10 poses,
//! then the nearest feature of every foreground pixel in each other pose). The sheet is
//! synthetic seed 9000's generator at 10 poses. And one training step of the network
//! (`parts/train_step/4x2x128`: 4 pairs of 128² poses, InfoNCE both ways, Adam), the step
//! `bench/parts_net_torch.py` times in PyTorch, and making one step's pairs
//! (`parts/training_pairs/4x128`: the generator's characters in two poses each, with their exact
//! correspondences). And the prior placing the Kenney robot's template on one of its frames
//! (`parts/prior_place/96x128`, the pass `puppet fit --puppet` starts each frame with).
//! Results: benches/README.md "parts".
//!
//! ```sh
//! cargo bench --bench parts
//! ```

// Criterion's macros write undocumented functions.
#![allow(missing_docs)]

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use puppet::parts::deform::{deform_parts, BendOptions};
use puppet::parts::learn::{CorrespondenceTrainer, LearnConfig, PairSource, TrainedNet};
use puppet::parts::matching::network_correspondences;
use puppet::parts::superpixels::slic;
use puppet::parts::{find_parts, PartsOptions};
use puppet::progress::Silent;
use puppet::synth::sheet_flow::{true_correspondences, GeneratedSheet, SyntheticPairs};

// The binary's allocator and its setting (src/allocator.rs), so a call costs what it costs in
// `puppet parts`.
#[path = "../src/allocator.rs"]
mod allocator;

fn parts(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let sheet = GeneratedSheet::new(9000, 10, 128, false).expect("the generator runs");
    let (poses, labels, truth) = (&sheet.poses, &sheet.labels, &sheet.sequence.truth);
    let options = PartsOptions::default();
    c.bench_function("parts/slic/128", |b| {
        b.iter(|| slic(&poses[0], options.superpixels, options.compactness))
    });
    c.bench_function("parts/true_flows/10x128", |b| {
        b.iter(|| true_correspondences(truth, labels).expect("flows"))
    });
    let flows = true_correspondences(truth, labels).expect("flows");
    c.bench_function("parts/find/10x128", |b| {
        b.iter(|| find_parts(poses.clone(), &flows, &options).expect("parts"))
    });
    let found = find_parts(poses.clone(), &flows, &options).expect("parts");
    c.bench_function("parts/deform/10x128", |b| {
        b.iter(|| deform_parts(poses, &found.segmentation, &flows, &BendOptions::default()).expect("meshes"))
    });
    let device = puppet::backend::device();
    let net = TrainedNet::shipped(&device).expect("the built-in network");
    let mut group = c.benchmark_group("parts");
    group.sample_size(10);
    group.bench_function("network_flows/10x128", |b| {
        b.iter(|| network_correspondences(&net.net, net.size, poses, &device, &Silent).expect("flows"))
    });
    // One training step of the network as configs/parts-net.toml trains it (batch 4 pairs).
    let config = LearnConfig::default();
    let source = SyntheticPairs {
        first_seed: 1_000_000,
        size: 128,
        varied: config.varied,
    };
    let mut first = 0;
    group.bench_function("training_pairs/4x128", |b| {
        b.iter(|| {
            let batch: Vec<_> = (0..config.batch as u64).map(|k| source.pair(first + k).expect("a pair")).collect();
            first += config.batch as u64;
            batch
        })
    });
    let pairs: Vec<_> = (0..config.batch as u64).map(|k| source.pair(k).expect("a pair")).collect();
    let mut trainer = CorrespondenceTrainer::new(&config, &puppet::backend::train_device());
    let mut step = 0;
    group.bench_function("train_step/4x2x128", |b| {
        b.iter(|| {
            trainer.step(step, &pairs).expect("a step");
            step += 1;
        })
    });
    // The prior (the same network, shipped weights) placing the Kenney robot's template on one
    // of its drawn frames: the rest render, both images' features, the matches and the turns.
    let artwork = puppet::load_artwork(Path::new("data/kenney/robot"), &puppet::ImportOptions::default()).expect("the robot's artwork");
    let (robot, _) = puppet::build(&artwork, &puppet::BuildOptions::default(), &Silent).expect("the robot builds");
    let frame = puppet::Picture::load(Path::new("data/kenney/robot/frames/robot_walk0.png")).expect("a frame");
    let prior = puppet::prior::shipped(&device).expect("the built-in prior");
    group.bench_function("prior_place/96x128", |b| {
        b.iter(|| puppet::prior::place::place(&prior, &robot, &frame, &device).expect("a placement"))
    });
    group.finish();
}

criterion_group!(benches, parts);
criterion_main!(benches);
