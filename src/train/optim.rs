//! A fused Adam for training the deformation network (neural-puppet.md §3.2 trains with Adam;
//! Kingma & Ba 2015, "Adam: A Method for Stochastic Optimization", Algorithm 1).
//!
//! Burn's `Adam` builds each update from ~13 tensor operations, each reading its inputs and
//! writing a fresh buffer; on our network (36.6 M weights, 33.5 M of them in the first FC layer)
//! that was ~220 ms of a ~585 ms step (../shared/notes/burn-cpu.md). [`FusedAdam`] streams each
//! weight tensor once: for every element it reads the gradient and updates the weight and both
//! moments in place, in parallel over chunks with rayon. It computes exactly Burn's formula
//! (same operations in the same order, in the tensor's own precision):
//!
//! ```text
//! g ← g + λ·θ                                  (weight decay λ, 0 by default)
//! m ← β1·m + (1−β1)·g
//! v ← β2·v + (1−β2)·g²
//! θ ← θ − lr · (m · √(1−β2ᵗ)/(1−β1ᵗ)) / (√v + ε·√(1−β2ᵗ))
//! ```
//!
//! which is PyTorch's `θ ← θ − lr/(1−β1ᵗ) · m / (√v/√(1−β2ᵗ) + ε)` rearranged, with one
//! difference: moments below the smallest normal float are stored as zero. A weight whose
//! gradient stays zero (an input pixel no frame ever covers) has its m shrink by β1 every step
//! and reach the subnormal range after ~700 steps; from then on every update of it took a
//! microcode assist, and the whole training step became twice as slow. The dropped values change
//! the weight by less than 1e-30. Its state is
//! Burn's own [`AdamState`], so checkpoints (`ModuleOptimizer::into_bytes` / `from_bytes`) have
//! Burn's Adam layout and either optimiser can resume from the other's.
//!
//! The weight, its moments and its gradient are read and written through [`TensorData`]: on the
//! `flex` backend a tensor nobody else holds converts to and from `TensorData` without a copy,
//! so the update touches each of the four buffers once (a shared weight is copied once first).

use burn::optim::{AdamState, AdaptiveMomentumState, LearningRate, ModuleOptimizer, Optimizer};
use burn::tensor::{DType, Device, Tensor, TensorData};
use num_traits::Float;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Adam's step size at `step` of a run of `steps`: `start` throughout, or, with an `end`, falling
/// from `start` at the first step to `end` at the last along a half cosine (Loshchilov & Hutter
/// 2017, "SGDR", without restarts). A function of the step alone, so a resumed run takes the
/// same steps as an uninterrupted one.
pub fn learning_rate_at(start: f64, end: Option<f64>, step: u64, steps: u64) -> f64 {
    let Some(end) = end else { return start };
    end + (start - end) * 0.5 * (1.0 + (std::f64::consts::PI * run_progress(step, steps)).cos())
}

/// How far `step` is through a run of `steps`: 0 at the first step, 1 at the last (and for a
/// run of one step).
pub fn run_progress(step: u64, steps: u64) -> f64 {
    if steps > 1 {
        (step as f64 / (steps - 1) as f64).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Adam's hyper-parameters except the learning rate, which is given at every step
/// (`ModuleOptimizer::step(lr, module, grads)`): the `[train.adam]` table of a training config.
/// Defaults are PyTorch's (ε = 1e-8, not Burn's 1e-5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdamSettings {
    /// Decay of the first moment β1.
    pub beta_1: f32,
    /// Decay of the second moment β2.
    pub beta_2: f32,
    /// ε added to √v̂ (PyTorch's placement; Burn's formula scales it by √(1−β2ᵗ) to match).
    pub epsilon: f32,
    /// L2 weight decay λ added to the gradient as λ·θ (PyTorch's `Adam(weight_decay=λ)`).
    pub weight_decay: f32,
}

impl Default for AdamSettings {
    fn default() -> Self {
        AdamSettings {
            beta_1: 0.9,
            beta_2: 0.999,
            epsilon: 1e-8,
            weight_decay: 0.0,
        }
    }
}

impl AdamSettings {
    /// PyTorch's defaults.
    pub fn new() -> Self {
        Self::default()
    }

    /// With β1 = `beta_1`.
    pub fn with_beta_1(self, beta_1: f32) -> Self {
        AdamSettings { beta_1, ..self }
    }

    /// With β2 = `beta_2`.
    pub fn with_beta_2(self, beta_2: f32) -> Self {
        AdamSettings { beta_2, ..self }
    }

    /// With ε = `epsilon`.
    pub fn with_epsilon(self, epsilon: f32) -> Self {
        AdamSettings { epsilon, ..self }
    }

    /// With weight decay λ = `weight_decay`.
    pub fn with_weight_decay(self, weight_decay: f32) -> Self {
        AdamSettings { weight_decay, ..self }
    }

    /// Checks that the settings describe a working Adam.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the setting if a β is outside [0, 1), ε is not positive, or λ is
    /// negative or not finite.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, value: f32, expected: &str| Err(Error::setting(format!("adam.{name}"), value, expected));
        for (name, beta) in [("beta_1", self.beta_1), ("beta_2", self.beta_2)] {
            if !(0.0..1.0).contains(&beta) {
                return bad(name, beta, "expected 0 ≤ β < 1");
            }
        }
        if !(self.epsilon > 0.0 && self.epsilon.is_finite()) {
            return bad("epsilon", self.epsilon, "expected a positive number");
        }
        if !(self.weight_decay >= 0.0 && self.weight_decay.is_finite()) {
            return bad("weight_decay", self.weight_decay, "expected λ ≥ 0");
        }
        Ok(())
    }
}

/// The fused Adam over a whole module: a drop-in for `AdamConfig::init()`. Use it as
/// `optim.step(lr, model, GradientsParams::from_grads(loss.backward(), &model))`; checkpoint it
/// with `into_bytes` / `from_bytes`.
pub fn adam(settings: &AdamSettings) -> ModuleOptimizer {
    ModuleOptimizer::from(FusedAdam {
        settings: settings.clone(),
    })
}

/// An optimiser's state as bytes for a checkpoint in `dir`.
///
/// # Errors
/// [`Error::Format`] naming `dir` if Burn cannot encode it.
pub fn optimizer_bytes(optimizer: &ModuleOptimizer, dir: &std::path::Path) -> Result<Vec<u8>> {
    optimizer
        .into_bytes()
        .map(|b| b.to_vec())
        .map_err(|e| Error::format(dir, format!("cannot encode optimiser state: {e:?}")))
}

/// `optimizer` with the state `bytes` read from `path`.
///
/// # Errors
/// [`Error::Format`] naming `path` if the bytes are not such a state.
pub fn optimizer_from_bytes(optimizer: &ModuleOptimizer, bytes: Vec<u8>, path: &std::path::Path) -> Result<ModuleOptimizer> {
    optimizer
        .clone()
        .from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes))
        .map_err(|e| Error::format(path, format!("cannot read optimiser state: {e:?}")))
}

/// Adam for one weight tensor at a time (Burn's per-tensor [`Optimizer`]); see the module doc.
#[derive(Clone, Debug)]
pub struct FusedAdam {
    settings: AdamSettings,
}

impl FusedAdam {
    /// Adam with these settings.
    pub fn new(settings: AdamSettings) -> Self {
        FusedAdam { settings }
    }
}

impl Optimizer for FusedAdam {
    type State<const D: usize> = AdamState<D>;

    fn step<const D: usize>(
        &self,
        lr: LearningRate,
        tensor: Tensor<D>,
        grad: Tensor<D>,
        state: Option<Self::State<D>>,
    ) -> (Tensor<D>, Option<Self::State<D>>) {
        let device = tensor.device();
        let dtype = tensor.dtype();
        let (time, moments) = match state {
            Some(s) => (s.momentum.time + 1, Some((s.momentum.moment_1, s.momentum.moment_2))),
            None => (1, None),
        };
        let mut theta = tensor.into_data();
        let g = grad.into_data();
        let (mut m, mut v) = match moments {
            Some((m, v)) => (m.into_data(), v.into_data()),
            None => (
                TensorData::zeros::<f32, _>(theta.shape().clone()),
                TensorData::zeros::<f32, _>(theta.shape().clone()),
            ),
        };
        update_data(&mut theta, &mut m, &mut v, g, &Coefficients::new(&self.settings, lr, time));
        let back = |d: TensorData| Tensor::<D>::from_data(d, (&device, dtype));
        let state = AdamState::new(AdaptiveMomentumState::new(time, back(m), back(v)));
        (back(theta), Some(state))
    }

    fn to_device<const D: usize>(mut state: Self::State<D>, device: &Device) -> Self::State<D> {
        state.momentum = state.momentum.to_device(device);
        state
    }
}

/// Adam over a flat vector of unknowns in plain slices (fitting's latents and vertices): the
/// update [`FusedAdam`] applies to each weight tensor, with its moments kept here.
#[derive(Clone, Debug)]
pub struct FlatAdam {
    settings: AdamSettings,
    m: Vec<f32>,
    v: Vec<f32>,
    time: usize,
}

impl FlatAdam {
    /// Adam with `settings` over `n` unknowns, its moments zero.
    pub fn new(settings: AdamSettings, n: usize) -> Self {
        FlatAdam {
            settings,
            m: vec![0.0; n],
            v: vec![0.0; n],
            time: 0,
        }
    }

    /// One step of size `lr` on the unknowns `x` down their gradient `g`.
    ///
    /// # Panics
    /// If `x` or `g` is not as long as the `n` it was made for (a caller's bug).
    pub fn step(&mut self, x: &mut [f32], g: &[f32], lr: f64) {
        assert!(
            x.len() == self.m.len() && g.len() == self.m.len(),
            "FlatAdam: slices of another length"
        );
        self.time += 1;
        let k = Coefficients::new(&self.settings, lr, self.time);
        adam_update(x, &mut self.m, &mut self.v, g, &k);
    }
}

/// The per-step scalars of the update, in Burn's f32 arithmetic (`AdaptiveMomentum::transform`).
#[derive(Clone, Copy, Debug)]
struct Coefficients {
    beta_1: f32,
    beta_2: f32,
    one_minus_beta_1: f32,
    one_minus_beta_2: f32,
    /// √(1−β2ᵗ)/(1−β1ᵗ).
    combined: f32,
    /// ε·√(1−β2ᵗ).
    epsilon_hat: f32,
    lr: f64,
    weight_decay: f32,
}

impl Coefficients {
    fn new(s: &AdamSettings, lr: LearningRate, time: usize) -> Self {
        // Burn computes these in f32 with `powi(time as i32)`; so do we, to get the same bits.
        let t = time.min(i32::MAX as usize) as i32;
        let bias_correction_2_sqrt = (1.0 - s.beta_2.powi(t)).sqrt();
        Coefficients {
            beta_1: s.beta_1,
            beta_2: s.beta_2,
            one_minus_beta_1: 1.0 - s.beta_1,
            one_minus_beta_2: 1.0 - s.beta_2,
            combined: bias_correction_2_sqrt / (1.0 - s.beta_1.powi(t)),
            epsilon_hat: s.epsilon * bias_correction_2_sqrt,
            lr,
            weight_decay: s.weight_decay,
        }
    }

    /// The coefficients in the tensor's element type.
    fn cast<F: Float>(&self) -> [F; 8] {
        let c = |x: f32| F::from(x).expect("f32 converts to f32 and f64");
        [
            c(self.beta_1),
            c(self.beta_2),
            c(self.one_minus_beta_1),
            c(self.one_minus_beta_2),
            c(self.combined),
            c(self.epsilon_hat),
            F::from(self.lr).expect("f64 converts to f32 and f64"),
            c(self.weight_decay),
        ]
    }
}

/// Runs [`adam_update`] on the four buffers in the weight's precision: f32 and f64 in place,
/// anything else (f16, bf16) through f32 and back.
fn update_data(theta: &mut TensorData, m: &mut TensorData, v: &mut TensorData, g: TensorData, k: &Coefficients) {
    let dtype = theta.dtype();
    match dtype {
        DType::F64 => {
            let g = g.convert::<f64>();
            adam_update::<f64>(
                slice_mut(theta),
                slice_mut(to_dtype(m, dtype)),
                slice_mut(to_dtype(v, dtype)),
                slice(&g),
                k,
            );
        }
        DType::F32 => {
            let g = g.convert::<f32>();
            adam_update::<f32>(
                slice_mut(theta),
                slice_mut(to_dtype(m, dtype)),
                slice_mut(to_dtype(v, dtype)),
                slice(&g),
                k,
            );
        }
        _ => {
            let (g, mut t32) = (g.convert::<f32>(), theta.clone().convert::<f32>());
            let f32 = DType::F32;
            adam_update::<f32>(
                slice_mut(&mut t32),
                slice_mut(to_dtype(m, f32)),
                slice_mut(to_dtype(v, f32)),
                slice(&g),
                k,
            );
            *theta = t32.convert_dtype(dtype);
        }
    }
}

/// Converts `d` in place to `dtype` if it is not already (a state saved in another precision).
fn to_dtype(d: &mut TensorData, dtype: DType) -> &mut TensorData {
    if d.dtype() != dtype {
        *d = std::mem::replace(d, TensorData::new(Vec::<f32>::new(), [0])).convert_dtype(dtype);
    }
    d
}

fn slice_mut<F: burn::tensor::Element>(d: &mut TensorData) -> &mut [F] {
    d.as_mut_slice::<F>()
        .expect("dtype checked by update_data; TensorData buffers are element-aligned")
}

fn slice<F: burn::tensor::Element>(d: &TensorData) -> &[F] {
    d.as_slice::<F>()
        .expect("dtype checked by update_data; TensorData buffers are element-aligned")
}

/// Elements per rayon task: large enough that task overhead is negligible (64 KiB of f32 per
/// buffer), small enough that the 33.5 M-element FC weight splits into ~500 tasks for the cores.
const CHUNK: usize = 1 << 14;

/// One Adam step over flat buffers, in place: weight `theta`, first and second moments `m`, `v`,
/// gradient `g`, all of one length; coefficients from [`Coefficients`]. Elementwise, so the
/// chunking changes nothing in the result.
fn adam_update<F: Float + Send + Sync>(theta: &mut [F], m: &mut [F], v: &mut [F], g: &[F], k: &Coefficients) {
    debug_assert!(m.len() == theta.len() && v.len() == theta.len() && g.len() == theta.len());
    let k = k.cast::<F>();
    let run = |theta: &mut [F], m: &mut [F], v: &mut [F], g: &[F]| {
        let [beta_1, beta_2, one_minus_beta_1, one_minus_beta_2, combined, epsilon_hat, lr, weight_decay] = k;
        let decay = weight_decay != F::zero();
        let normal = |x: F| if x.abs() < F::min_positive_value() { F::zero() } else { x };
        for (((p, m), v), &g) in theta.iter_mut().zip(m.iter_mut()).zip(v.iter_mut()).zip(g) {
            // The order of operations is Burn's (adam.rs, decay.rs), so the results are its bits.
            let g = if decay { *p * weight_decay + g } else { g };
            *m = normal(*m * beta_1 + g * one_minus_beta_1);
            *v = normal(*v * beta_2 + g * g * one_minus_beta_2);
            let update = *m * combined / (v.sqrt() + epsilon_hat);
            *p = *p - update * lr;
        }
    };
    if theta.len() <= CHUNK {
        run(theta, m, v, g);
    } else {
        theta
            .par_chunks_mut(CHUNK)
            .zip(m.par_chunks_mut(CHUNK))
            .zip(v.par_chunks_mut(CHUNK))
            .zip(g.par_chunks(CHUNK))
            .for_each(|(((t, m), v), g)| run(t, m, v, g));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::Rng;
    use burn::module::Module;
    use burn::nn::{Linear, LinearConfig};
    use burn::optim::{AdamConfig, GradientsParams};
    use burn::tensor::activation::relu;

    /// Two layers, so the update of one changes the gradient of the other on the next step.
    #[derive(Module, Debug)]
    struct Small {
        a: Linear,
        b: Linear,
    }

    impl Small {
        fn new(device: &Device) -> Self {
            Small {
                a: LinearConfig::new(6, 5).init(device),
                b: LinearConfig::new(5, 3).init(device),
            }
        }

        fn loss(&self, x: &Tensor<2>, y: &Tensor<2>) -> Tensor<1> {
            (self.b.forward(relu(self.a.forward(x.clone()))) - y.clone())
                .powf_scalar(2.0)
                .mean()
        }

        fn values(&self) -> Vec<f32> {
            [&self.a, &self.b]
                .iter()
                .flat_map(|l| {
                    let mut w = l.weight.val().into_data().try_to_vec::<f32>().unwrap();
                    w.extend(l.bias.as_ref().unwrap().val().into_data().try_to_vec::<f32>().unwrap());
                    w
                })
                .collect()
        }
    }

    fn batch(seed: u64, device: &Device) -> (Tensor<2>, Tensor<2>) {
        let mut rng = Rng::new(seed);
        let mut t = |n: usize, shape: [usize; 2]| {
            let v: Vec<f32> = (0..n).map(|_| rng.uniform(-1.0, 1.0) as f32).collect();
            Tensor::<2>::from_data(TensorData::new(v, shape), device)
        };
        (t(4 * 6, [4, 6]), t(4 * 3, [4, 3]))
    }

    /// `steps` optimiser steps on seeded batches, starting from `net`.
    fn train(mut net: Small, optim: &mut ModuleOptimizer, seeds: std::ops::Range<u64>, lr: f64) -> Small {
        let device = crate::backend::train_device();
        for seed in seeds {
            let (x, y) = batch(seed, &device);
            let grads = GradientsParams::from_grads(net.loss(&x, &y).backward(), &net);
            net = optim.step(lr, net, grads);
        }
        net
    }

    fn max_difference(a: &[f32], b: &[f32]) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
    }

    #[test]
    fn fused_adam_follows_burns_adam_over_several_steps() {
        let device = crate::backend::train_device();
        for weight_decay in [0.0, 0.1] {
            let start = Small::new(&device);
            let before = start.values();
            let settings = AdamSettings::new().with_weight_decay(weight_decay);
            let mut burn_config = AdamConfig::new().with_epsilon(1e-8);
            if weight_decay > 0.0 {
                burn_config = burn_config.with_weight_decay(Some(burn::optim::decay::WeightDecayConfig::new(weight_decay)));
            }
            let theirs = train(start.clone(), &mut burn_config.init(), 0..10, 0.01).values();
            let ours = train(start, &mut adam(&settings), 0..10, 0.01).values();
            // Ten steps of lr 0.01 move each weight by up to 0.1, so the comparison is not vacuous.
            assert!(max_difference(&ours, &before) > 0.05, "the weights hardly moved");
            // Same f32 operations in the same order as Burn's Adam: on flex the trajectories agree
            // to the last bit (measured: difference 0). A backend whose kernels round differently
            // (fused multiply-add, approximate sqrt) may differ by a few ulps of weights of size
            // ≤ 1 per step, ~1e-7, so 1e-6 after ten steps.
            let d = max_difference(&ours, &theirs);
            assert!(d <= 1e-6, "weight decay {weight_decay}: fused and Burn's Adam differ by {d}");
        }
    }

    #[test]
    fn checkpoint_round_trip_gives_identical_next_steps() {
        let device = crate::backend::train_device();
        let settings = AdamSettings::new();
        let mut optim = adam(&settings);
        let net = train(Small::new(&device), &mut optim, 0..3, 0.01);
        let bytes = optim.into_bytes().unwrap();
        let mut restored = adam(&settings).from_bytes(bytes).unwrap();
        let a = train(net.clone(), &mut optim, 3..6, 0.01).values();
        let b = train(net.clone(), &mut restored, 3..6, 0.01).values();
        assert_eq!(a, b);
        // A fresh optimiser (no moments) takes different steps: the state did carry over.
        let c = train(net, &mut adam(&settings), 3..6, 0.01).values();
        assert!(max_difference(&a, &c) > 1e-4);
    }

    #[test]
    fn resumes_from_a_burn_adam_checkpoint() {
        let device = crate::backend::train_device();
        let mut burn_adam = AdamConfig::new().with_epsilon(1e-8).init();
        let net = train(Small::new(&device), &mut burn_adam, 0..3, 0.01);
        let mut fused = adam(&AdamSettings::new()).from_bytes(burn_adam.into_bytes().unwrap()).unwrap();
        let theirs = train(net.clone(), &mut burn_adam, 3..6, 0.01).values();
        let ours = train(net, &mut fused, 3..6, 0.01).values();
        let d = max_difference(&ours, &theirs);
        assert!(d <= 1e-6, "fused Adam resumed from Burn's checkpoint differs by {d}");
    }

    /// The textbook (PyTorch) form of Algorithm 1, in f64, one element at a time.
    fn reference_step(theta: &mut [f64], m: &mut [f64], v: &mut [f64], g: &[f64], s: &AdamSettings, lr: f64, t: i32) {
        let (b1, b2, eps, wd) = (s.beta_1 as f64, s.beta_2 as f64, s.epsilon as f64, s.weight_decay as f64);
        for i in 0..theta.len() {
            let g = g[i] + wd * theta[i];
            m[i] = b1 * m[i] + (1.0 - b1) * g;
            v[i] = b2 * v[i] + (1.0 - b2) * g * g;
            let (m_hat, v_hat) = (m[i] / (1.0 - b1.powi(t)), v[i] / (1.0 - b2.powi(t)));
            theta[i] -= lr * m_hat / (v_hat.sqrt() + eps);
        }
    }

    #[test]
    fn kernel_matches_the_textbook_update_in_f64() {
        // β and ε are f32 settings (as in Burn) and the reference uses the same values widened,
        // so the two differ by f64 rounding of two algebraically equal forms (~1e-16) plus the
        // f32 rounding of the per-step coefficients √(1−β2ᵗ)/(1−β1ᵗ) and ε·√(1−β2ᵗ), which Burn
        // computes in f32 and so do we. The tolerance is derived from the latter, measured here.
        let s = AdamSettings::new().with_weight_decay(0.01);
        let lr = 0.01;
        let mut rng = Rng::new(7);
        let n = 1000;
        let mut theta: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut reference = theta.clone();
        let (mut m, mut v, mut m_ref, mut v_ref) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut tolerance = 0.0;
        for t in 1..=20 {
            // Gradients over six orders of magnitude, and some exact zeros.
            let g: Vec<f64> = (0..n)
                .map(|i| {
                    if i % 17 == 0 {
                        0.0
                    } else {
                        rng.uniform(-1.0, 1.0) * 10f64.powi((i % 7) as i32 - 4)
                    }
                })
                .collect();
            let k = Coefficients::new(&s, lr, t);
            adam_update(&mut theta, &mut m, &mut v, &g, &k);
            reference_step(&mut reference, &mut m_ref, &mut v_ref, &g, &s, lr, t as i32);
            // |update| = lr·|m̂|/(√v̂ + ε) ≤ lr·(1−β1)/√(1−β2) ≈ 3.2·lr (Kingma & Ba §2.1); a relative
            // error e in a coefficient moves it by at most that times e.
            let (b1, b2) = (s.beta_1 as f64, s.beta_2 as f64);
            let bc2 = (1.0 - b2.powi(t as i32)).sqrt();
            let e_combined = (k.combined as f64 / (bc2 / (1.0 - b1.powi(t as i32))) - 1.0).abs();
            let e_epsilon = (k.epsilon_hat as f64 / (s.epsilon as f64 * bc2) - 1.0).abs();
            tolerance += 3.2 * lr * (e_combined + e_epsilon + 1e-12);
        }
        assert!(tolerance < 1e-5, "the f32 coefficients alone are off by {tolerance}");
        for i in 0..n {
            let d = (theta[i] - reference[i]).abs();
            assert!(
                d <= tolerance,
                "element {i}: {} vs reference {} (differ by {d} > {tolerance})",
                theta[i],
                reference[i]
            );
            // The moments see the weights only through λ·θ (λ = 0.01), so they differ by ~λ·d.
            assert!((m[i] - m_ref[i]).abs() <= 0.01 * tolerance + 1e-15, "first moment {i}");
            assert!((v[i] - v_ref[i]).abs() <= 0.01 * tolerance + 1e-15, "second moment {i}");
        }
    }

    #[test]
    fn parallel_chunks_give_the_serial_result() {
        let mut rng = Rng::new(11);
        let n = 3 * CHUNK + 7;
        let mut r = |n| (0..n).map(|_| rng.uniform(-1.0, 1.0) as f32).collect::<Vec<f32>>();
        let (theta0, m0, g) = (r(n), r(n), r(n));
        let v0: Vec<f32> = r(n).iter().map(|x| x * x).collect();
        let k = Coefficients::new(&AdamSettings::new(), 1e-3, 5);
        let (mut theta, mut m, mut v) = (theta0.clone(), m0.clone(), v0.clone());
        adam_update(&mut theta, &mut m, &mut v, &g, &k);
        let (mut theta_s, mut m_s, mut v_s) = (theta0, m0, v0);
        for i in 0..n {
            adam_update(&mut theta_s[i..=i], &mut m_s[i..=i], &mut v_s[i..=i], &g[i..=i], &k);
        }
        assert_eq!((theta, m, v), (theta_s, m_s, v_s));
    }

    #[test]
    fn moments_of_a_weight_without_gradient_flush_to_zero_not_subnormal() {
        let k = Coefficients::new(&AdamSettings::new(), 1e-4, 1);
        let (mut theta, mut m, mut v) = (vec![0.5f32], vec![1e-8f32], vec![1e-12f32]);
        let mut shrinking = Vec::new();
        for _ in 0..2000 {
            adam_update(&mut theta, &mut m, &mut v, &[0.0], &k);
            shrinking.push(m[0]);
        }
        assert!(shrinking.iter().all(|x| *x == 0.0 || x.is_normal()), "a moment went subnormal");
        assert_eq!(m[0], 0.0, "m never reached zero: {}", m[0]);
        assert!(shrinking[..600].iter().all(|x| *x > 0.0), "flushed too early");
    }

    #[test]
    fn rejects_settings_that_are_not_adam() {
        for (s, word) in [
            (AdamSettings::new().with_beta_1(1.0), "beta_1"),
            (AdamSettings::new().with_beta_2(-0.1), "beta_2"),
            (AdamSettings::new().with_epsilon(0.0), "epsilon"),
            (AdamSettings::new().with_weight_decay(f32::NAN), "weight_decay"),
        ] {
            let e = s.validate().unwrap_err().to_string();
            assert!(e.contains(word), "{e}");
        }
        AdamSettings::new().validate().unwrap();
    }
}
