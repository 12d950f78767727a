//! Training speed of the deformation network alone (issue 5's speed goal; neural-puppet.md §3.2):
//! one step of `puppet::model::deformation::DeformationNet` — encode, decode, add the rest
//! vertices, an MSE loss against target vertices, backward, optimiser update — at batch 16,
//! 128² input, V = 600 vertices (the first FC layer is 32768 → 1024: 33.5 M of the 36.6 M
//! weights). `bench/train_torch.py` runs the same network in PyTorch; benches/README.md has both.
//!
//! Ids `backend/train_step/<backend>/<optimizer>/batch=16/px=128`. With `BACKEND_CPU_REPORT=1`
//! it first prints wall and process CPU time per step (the machine is shared: CPU time per step
//! does not depend on other jobs, and CPU / wall says how many cores the step kept busy).
//! `BACKEND_PX=64` changes the input size (the `ndarray` backend takes minutes at 128²).
//!
//! ```sh
//! BACKEND_CPU_REPORT=1 cargo bench --bench backend
//! BACKEND_CPU_REPORT=1 cargo bench --bench backend --no-default-features --features flex  # system allocator
//! BACKEND_PX=64 cargo bench --bench backend --no-default-features --features ndarray
//! ```

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Distribution, Tensor};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use puppet::model::deformation::{rest_tensor, DeformationNet, DeformationNetConfig};
use puppet::train::optim::{adam, AdamSettings};

// The binary's allocator and its setting (src/allocator.rs); `--no-default-features --features
// flex` measures without both, `BACKEND_PURGE=1` with mimalloc's default purging.
#[path = "../src/allocator.rs"]
mod allocator;
#[path = "support/cpu_report.rs"]
mod cpu_report;

const BATCH: usize = 16;
const VERTICES: usize = 600;
const LEARNING_RATE: f64 = 1e-4;

/// The input size: `BACKEND_PX` or 128.
fn input_size() -> usize {
    std::env::var("BACKEND_PX").ok().and_then(|s| s.parse().ok()).unwrap_or(128)
}

/// One network-alone training step's inputs and state.
struct Step {
    net: Option<DeformationNet>,
    optim: burn::optim::ModuleOptimizer,
    images: Tensor<4>,
    rest: Tensor<2>,
    target: Tensor<3>,
}

impl Step {
    fn new(optim: burn::optim::ModuleOptimizer, size: usize) -> Self {
        let device = puppet::backend::train_device();
        let net = DeformationNetConfig::new(VERTICES).with_input_size(size).init(&device);
        let rest: Vec<[f32; 2]> = (0..VERTICES).map(|i| [(i % 40) as f32 * 3.0, (i / 40) as f32 * 8.0]).collect();
        Step {
            net: Some(net),
            optim,
            images: Tensor::random([BATCH, 4, size, size], Distribution::Uniform(0.0, 1.0), &device),
            rest: rest_tensor(&rest, &device),
            target: Tensor::random([BATCH, VERTICES, 2], Distribution::Uniform(0.0, 120.0), &device),
        }
    }

    /// Forward, MSE on the vertices, backward, update. The network is moved into the optimiser
    /// (not cloned), as a training loop would, so an in-place optimiser can reuse its buffers.
    fn run(&mut self) {
        let net = self.net.take().expect("put back at the end of every step");
        let v = net.vertices(net.encode(self.images.clone()), &self.rest);
        let loss = (v - self.target.clone()).powf_scalar(2.0).mean();
        let grads = GradientsParams::from_grads(loss.backward(), &net);
        self.net = Some(self.optim.step(LEARNING_RATE, net, grads));
    }
}

/// The optimisers compared: Burn's Adam with PyTorch's epsilon, and ours
/// (`puppet::train::optim::adam`, one in-place pass per weight tensor). `BACKEND_OPTIM` picks one.
fn optimizers() -> Vec<(&'static str, burn::optim::ModuleOptimizer)> {
    let all = vec![
        ("burn_adam", AdamConfig::new().with_epsilon(1e-8).init()),
        ("fused_adam", adam(&AdamSettings::new())),
    ];
    match std::env::var("BACKEND_OPTIM") {
        Ok(only) => all.into_iter().filter(|(name, _)| *name == only).collect(),
        Err(_) => all,
    }
}

/// Prints wall and CPU time per step and images/s, over `n` steps after two warm-up steps.
fn report_cpu(name: &str, n: usize, step: &mut Step) {
    let (wall, cpu) = cpu_report::measure(n, 2, || step.run());
    println!(
        "cpu-report {name}: wall {:.1} ms, cpu {:.1} ms per step of {BATCH} ({:.1} images/s, {:.0} % CPU)",
        wall * 1e3,
        cpu * 1e3,
        BATCH as f64 / wall,
        100.0 * cpu / wall
    );
}

fn training_step(c: &mut Criterion) {
    if std::env::var_os("BACKEND_PURGE").is_none() {
        allocator::keep_freed_memory();
    }
    let size = input_size();
    let mut group = c.benchmark_group("backend");
    group.sample_size(10);
    group.throughput(Throughput::Elements(BATCH as u64));
    for (name, optim) in optimizers() {
        let id = format!("train_step/{}/{name}/batch={BATCH}/px={size}", puppet::backend::name());
        let mut step = Step::new(optim, size);
        if std::env::var_os("BACKEND_CPU_REPORT").is_some() {
            report_cpu(&id, 10, &mut step);
        }
        group.bench_function(id, |b| b.iter(|| step.run()));
    }
    group.finish();
}

criterion_group!(benches, training_step);
criterion_main!(benches);
