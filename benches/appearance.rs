//! Training speed of the appearance stage (neural-puppet.md §3.3): one whole step of
//! `puppet::appearance::train` — what `Run::step` does with one critic step — at batch 9 (the
//! Kenney robot's nine training frames), 128² RGBA input, unconditioned critic:
//!
//! 1. the U-Net generator's forward pass (dropout on, as in training);
//! 2. the WGAN-GP critic loss (`critic_loss(WganGp, …, penalty_weight = 10)`: real and fake
//!    scores, the exact input-gradient chain at x̂ between them), its backward, and the fused
//!    Adam step (`puppet::train::optim::adam`, β = (0.5, 0.999), ε = 1e-8) on the critic;
//! 3. the generator loss (`generator_loss(WganGp, …, l1_weight = 100)`) through the updated,
//!    `no_grad` critic, its backward, and the Adam step on the generator.
//!
//! The losses are not read back (the trainer reads five scalars a step: microseconds). Inputs
//! are uniform noise in [0, 1]: the time does not depend on the pixels. Sizes: `small`
//! (`AppearanceNetConfig::new(128)` defaults: base 16, max 64 channels) and `full` (pix2pix's
//! base 64, max 512: 41.8 M generator and 2.77 M critic weights). Ids
//! `appearance/step/<size>/batch=9`, throughput in images; each size's parameter counts are
//! printed first (`params` lines). With `APPEARANCE_CPU_REPORT=1` each size then prints wall and
//! process CPU time per step and images/s over a few steps (`cpu-report` lines, which
//! `bench/appearance_torch.py` reads; they run even when a filter leaves the size out). The PyTorch peer is `bench/appearance_torch.py`;
//! results: benches/README.md "appearance".
//!
//! ```sh
//! APPEARANCE_CPU_REPORT=1 cargo bench --bench appearance
//! cargo bench --bench appearance -- small
//! ```

// Benchmarks print their figures, and criterion's macros write undocumented functions.
#![allow(missing_docs, clippy::print_stdout)]

use std::time::Duration;

use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::{Distribution, Tensor};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use puppet::model::appearance::{AppearanceNetConfig, Critic, Generator};
use puppet::objective::adversarial::{critic_loss, generator_loss, AdversarialLoss, Batch};
use puppet::train::optim::{adam, AdamSettings};

// The binary's allocator and its setting (src/allocator.rs), so a step costs what it costs in
// `puppet appearance`.
#[path = "../src/allocator.rs"]
mod allocator;
#[path = "support/cpu_report.rs"]
mod cpu_report;

/// The Kenney robot's training frames, all in one batch (as the appearance trainer does).
const BATCH: usize = 9;
/// The working size of a model trained at 128².
const SIZE: usize = 128;
/// pix2pix's learning rate (the appearance config's default).
const LEARNING_RATE: f64 = 2e-4;
/// γ2, the gradient penalty's weight (WGAN-GP's).
const PENALTY_WEIGHT: f64 = 10.0;
/// γ1, the L1 weight (pix2pix's).
const L1_WEIGHT: f64 = 100.0;

/// The networks, their optimisers and one batch of inputs.
struct Step {
    generator: Generator,
    critic: Critic,
    generator_optimizer: ModuleOptimizer,
    critic_optimizer: ModuleOptimizer,
    renders: Tensor<4>,
    frames: Tensor<4>,
    mix: Tensor<4>,
}

impl Step {
    fn new(config: &AppearanceNetConfig) -> Self {
        let device = puppet::backend::train_device();
        device.seed(7);
        let settings = AdamSettings::new().with_beta_1(0.5).with_beta_2(0.999).with_epsilon(1e-8);
        let image = || Tensor::random([BATCH, 4, SIZE, SIZE], Distribution::Uniform(0.0, 1.0), &device);
        Step {
            generator: config.init_generator(&device),
            critic: config.init_critic(&device),
            generator_optimizer: adam(&settings),
            critic_optimizer: adam(&settings),
            renders: image(),
            frames: image(),
            mix: Tensor::random([BATCH, 1, 1, 1], Distribution::Uniform(0.0, 1.0), &device),
        }
    }

    /// One critic step and one generator step, as `Run::step` with `critic_steps = 1`. The
    /// networks are moved into the optimisers (`take`), so the fused Adam updates in place.
    fn run(&mut self) {
        let loss = AdversarialLoss::WganGp;
        let pair = Batch {
            real: self.frames.clone(),
            fake: self.generator.forward(self.renders.clone()),
            render: None,
        };
        let terms = critic_loss(loss, &self.critic, &pair, self.mix.clone(), PENALTY_WEIGHT);
        let grads = GradientsParams::from_grads(terms.total.backward(), &self.critic);
        self.critic = self.critic_optimizer.step(LEARNING_RATE, self.critic.take(), grads);
        let terms = generator_loss(loss, &self.critic.clone().no_grad(), &pair, L1_WEIGHT);
        let grads = GradientsParams::from_grads(terms.total.backward(), &self.generator);
        self.generator = self.generator_optimizer.step(LEARNING_RATE, self.generator.take(), grads);
    }
}

/// The two sizes: the appearance config's default and pix2pix's.
fn sizes() -> [(&'static str, AppearanceNetConfig); 2] {
    [
        ("small", AppearanceNetConfig::new(SIZE)),
        ("full", AppearanceNetConfig::new(SIZE).with_base_channels(64).with_max_channels(512)),
    ]
}

/// Prints wall and CPU time per step and images/s over `n` steps, after one warm-up step.
fn report_cpu(id: &str, n: usize, step: &mut Step) {
    let (wall, cpu) = cpu_report::measure(n, 1, || step.run());
    println!(
        "cpu-report {id}: wall {:.1} ms, cpu {:.1} ms per step of {BATCH} ({:.2} images/s, {:.0} % CPU)",
        wall * 1e3,
        cpu * 1e3,
        BATCH as f64 / wall,
        100.0 * cpu / wall
    );
}

fn training_step(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let mut group = c.benchmark_group("appearance");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(10))
        .throughput(Throughput::Elements(BATCH as u64));
    for (name, config) in sizes() {
        let id = format!("step/{name}/batch={BATCH}");
        let mut step = Step::new(&config);
        println!(
            "params appearance/{name}: generator {}, critic {}",
            step.generator.num_params(),
            step.critic.num_params()
        );
        if std::env::var_os("APPEARANCE_CPU_REPORT").is_some() {
            report_cpu(&format!("appearance/{id}"), if name == "full" { 3 } else { 10 }, &mut step);
        }
        group.bench_function(id, |b| b.iter(|| step.run()));
    }
    group.finish();
}

criterion_group!(benches, training_step);
criterion_main!(benches);
