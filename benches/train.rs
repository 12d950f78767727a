//! Criterion benchmark of one whole training step (neural-puppet.md §3.2): encode a batch of 16
//! frames at 128², decode the vertices, soft-rasterize them, eq. 4's losses (ARAP as a custom
//! op), backward, Adam — on the bundled synthetic walker (data/synth/walk-7, 16 frames).
//!
//! Id: `train/step/batch=16` (throughput in images). The network-alone step and the PyTorch
//! peer are in benches/backend.rs and bench/train_torch.py; results: benches/README.md.

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
use puppet::train::trainer::{load_or_build_puppet, Trainer};
use puppet::train::TrainConfig;

fn step(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/synth/walk-7");
    let puppet = load_or_build_puppet(&data.join("template"), &ImageLimits::default(), &Silent).expect("the bundled template builds");
    let frames = Frames::load(&data, &FrameCheck::default()).expect("the bundled frames load");
    let config: TrainConfig = toml::from_str("puppet = \"\"\nframes = \"\"\noutput = \"\"").expect("defaults");
    let device = puppet::backend::train_device();
    let model = Model::new(DeformationNetConfig::new(puppet.vertex_count()), puppet, &device).expect("model");
    let pictures: Vec<_> = frames.frames.iter().collect();
    let mut trainer = Trainer::new(&config, model, &pictures, &[], &device).expect("trainer");
    let mut n = 0;
    let mut group = c.benchmark_group("train");
    group.sample_size(10).throughput(Throughput::Elements(config.train.batch as u64));
    group.bench_function("step/batch=16", |b| {
        b.iter(|| {
            trainer.step(n).expect("a step");
            n += 1;
        })
    });
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
