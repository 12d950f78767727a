//! Which Burn CPU backend trains fastest (DESIGN.md: choose the backend in src/backend.rs by
//! measurement). One training step of the paper's encoder-decoder (neural-puppet.md §3.2: three
//! convolutions k5 s2 p2, three FC layers to a 512-d latent, three FC layers to 2·V + 2 outputs)
//! with an MSE loss and Adam, batch 16 at 64² (128² takes minutes per sample on `ndarray`).
//!
//! Run once per backend feature:
//! `cargo bench --bench backend` (flex),
//! `cargo bench --bench backend --no-default-features --features ndarray`,
//! `cargo bench --bench backend --no-default-features --features cpu`.

use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{Linear, LinearConfig, PaddingConfig2d};
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::activation::relu;
use burn::tensor::{Distribution, Tensor};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

const BATCH: usize = 16;
const SIZE: usize = 64;
const VERTICES: usize = 600;

#[derive(Module, Debug)]
struct Net {
    convs: Vec<Conv2d>,
    fcs: Vec<Linear>,
}

impl Net {
    fn new(device: &burn::tensor::Device) -> Self {
        let conv = |i, o| {
            Conv2dConfig::new([i, o], [5, 5])
                .with_stride([2, 2])
                .with_padding(PaddingConfig2d::Explicit(2, 2, 2, 2))
                .init(device)
        };
        let flat = 128 * (SIZE / 8) * (SIZE / 8);
        let dims = [flat, 1024, 512, 512, 512, 1024, 2 * VERTICES + 2];
        Net {
            convs: vec![conv(4, 32), conv(32, 64), conv(64, 128)],
            fcs: dims.windows(2).map(|d| LinearConfig::new(d[0], d[1]).init(device)).collect(),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let mut x = x;
        for c in &self.convs {
            x = relu(c.forward(x));
        }
        let mut h: Tensor<2> = x.flatten(1, 3);
        let last = self.fcs.len() - 1;
        for (i, fc) in self.fcs.iter().enumerate() {
            h = fc.forward(h);
            if i != last {
                h = relu(h);
            }
        }
        h
    }
}

fn training_step(c: &mut Criterion) {
    let device = puppet::backend::train_device();
    let mut net = Net::new(&device);
    let mut adam = AdamConfig::new().with_epsilon(1e-8).init();
    let images = Tensor::<4>::random([BATCH, 4, SIZE, SIZE], Distribution::Uniform(0.0, 1.0), &device);
    let target = Tensor::<2>::random([BATCH, 2 * VERTICES + 2], Distribution::Uniform(-1.0, 1.0), &device);
    let mut group = c.benchmark_group("backend");
    group.sample_size(10);
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function(format!("train_step/{}/batch={BATCH}/px={SIZE}", puppet::backend::name()), |b| {
        b.iter(|| {
            let loss = (net.forward(images.clone()) - target.clone()).powf_scalar(2.0).mean();
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = adam.step(1e-4, net.clone(), grads);
        })
    });
    group.finish();
}

criterion_group!(benches, training_step);
criterion_main!(benches);
