//! Criterion benchmark of one whole training step (neural-puppet.md §3.2): encode a batch of 16
//! frames at 128², decode the vertices, soft-rasterize them, eq. 4's losses (ARAP as a custom
//! op), backward, Adam — on the bundled synthetic walker (data/synth/walk-7, 16 frames).
//!
//! Id: `train/step/batch=16` (throughput in images). The network-alone step and the PyTorch
//! peer are in benches/backend.rs and bench/train_torch.py; results: benches/README.md.
//!
//! The cost of the accessory rig inside the step (issue 14): the Kenney male adventurer, whose
//! hair is an accessory, trained with the rig placing the hair (`train/kenney/rig`) and with the
//! network moving it like a body part (`train/kenney/no-rig`), all 13 frames a step.

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::path::Path;

// The binary's allocator and setting, so a step costs what it costs in `puppet train`.
#[path = "../src/allocator.rs"]
mod allocator;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use puppet::model::deformation::DeformationNetConfig;
use puppet::model::Model;
use puppet::picture::ImageLimits;
use puppet::progress::Silent;
use puppet::puppet::sequence::{FrameCheck, Frames};
use puppet::train::harness::Run;
use puppet::train::trainer::{load_or_build_puppet, Trainer};
use puppet::train::TrainConfig;

/// A trainer with default settings for the artwork `template` and the frames `frames`, with or
/// without the accessory rig; and its batch size.
fn trainer(template: &Path, frames: &Path, rig: bool) -> (Trainer, usize) {
    let puppet = load_or_build_puppet(template, &ImageLimits::default(), rig, &Silent).expect("the bundled template builds");
    let frames = Frames::load(frames, &FrameCheck::default()).expect("the bundled frames load");
    let config: TrainConfig = toml::from_str("puppet = \"\"\nframes = \"\"\noutput = \"\"").expect("defaults");
    let device = puppet::backend::train_device();
    let model = Model::new(DeformationNetConfig::new(puppet.free_vertices().len()), puppet, &device).expect("model");
    let pictures: Vec<_> = frames.frames.iter().collect();
    let batch = config.train.batch.min(pictures.len());
    (Trainer::new(&config, model, &pictures, &[], &device).expect("trainer"), batch)
}

fn run(c: &mut Criterion, group: &str, id: &str, (mut trainer, batch): (Trainer, usize)) {
    let mut n = 0;
    let mut group = c.benchmark_group(group);
    group.sample_size(10).throughput(Throughput::Elements(batch as u64));
    group.bench_function(id, |b| {
        b.iter(|| {
            trainer.step(n).expect("a step");
            n += 1;
        })
    });
    group.finish();
}

fn step(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/synth/walk-7");
    run(c, "train", "step/batch=16", trainer(&data.join("template"), &data, true));
}

fn rig(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let kenney = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/kenney/male_adventurer");
    for (id, rig) in [("rig", true), ("no-rig", false)] {
        run(c, "train/kenney", id, trainer(&kenney, &kenney.join("frames"), rig));
    }
}

criterion_group!(benches, step, rig);
criterion_main!(benches);
