//! The appearance stage's networks (neural-puppet.md §3.3, eq. 5–6): a U-Net generator that
//! redraws the rendered puppet as the artist would have drawn it, and a PatchGAN critic that
//! scores patches of a frame. The paper says only "pix2pix"; the shapes are pix2pix's
//! (Isola et al. 2017): 4×4 stride-2 convolutions, LeakyReLU 0.2 going down, ReLU and transposed
//! convolutions coming up, skips by concatenation, dropout in the decoder blocks just outside the
//! innermost one, tanh out; a 70×70 PatchGAN of five convolutions.
//!
//! Departures:
//! - The critic has no normalisation layers. WGAN-GP forbids batch norm there (the penalty is
//!   per sample), and without normalisation the critic's input gradient is an exact linear chain
//!   ([`Critic::input_gradient`]) that first-order autodiff can differentiate in the weights.
//! - The generator normalises per instance where pix2pix puts batch norm (pix2pix trains with
//!   batch 1, where its batch norm is an instance norm; our batches hold every training frame,
//!   and the statistics must not depend on which frames share a batch). Without any
//!   normalisation it collapsed on the Kenney robot within 20 steps to transparent output with a
//!   saturated tanh. Its convolutions carry biases.
//! - RGBA, premultiplied, in and out (pix2pix: RGB), at the model's working size S.
//!
//! Shapes: generator `[B, 4, S, S] → [B, 4, S, S]` in [0, 1]; critic `[B, 4, S, S]` (or
//! `[B, 8, S, S]` conditioned on the render) → one score per patch `[B, 1, h, w]`.

use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig, ConvTranspose2d, ConvTranspose2dConfig};
use burn::nn::{Dropout, DropoutConfig, Initializer, InstanceNorm, InstanceNormConfig, PaddingConfig2d};
use burn::tensor::activation::{leaky_relu, relu, tanh};
use burn::tensor::{Device, Tensor};

use super::conv_op::{conv2d, conv_transpose2d, convolve, convolve_transposed};

/// Every convolution's kernel side (pix2pix).
const KERNEL: usize = 4;
/// Every convolution's zero padding (pix2pix).
const PADDING: usize = 1;
/// The generator's stride, down and up.
const STRIDE: usize = 2;
/// LeakyReLU's negative slope (pix2pix, both networks).
pub const SLOPE: f64 = 0.2;
/// The most downsamplings of the generator (pix2pix's U-Net at 256²: eight, down to 1×1).
const MAX_DEPTH: usize = 8;
/// pix2pix puts dropout in `depth − 5` decoder blocks above the innermost one.
const UNDROPPED: usize = 5;
/// The critic's strided convolutions (the 70×70 PatchGAN: three), then two of stride 1.
const CRITIC_STRIDED: usize = 3;

/// Hyper-parameters of the appearance networks; saved with the stage (the constructor and the
/// record of a run).
#[derive(Config, Debug, PartialEq)]
pub struct AppearanceNetConfig {
    /// Working size S (the deformation model's: the generator redraws its render in the
    /// letterboxed square).
    pub input_size: usize,
    /// Channels of the first convolution of each network; doubled per level up to
    /// `max_channels` (pix2pix: 64 and 512; the `small` size: 16 and 64).
    #[config(default = 16)]
    pub base_channels: usize,
    /// The channel ceiling.
    #[config(default = 64)]
    pub max_channels: usize,
    /// Whether the critic sees the render beside the frame (pix2pix's critic does; the paper's
    /// eq. 6, as written, does not).
    #[config(default = false)]
    pub conditioned: bool,
    /// Dropout probability in the generator's inner decoder blocks (pix2pix: 0.5).
    #[config(default = 0.5)]
    pub dropout: f64,
    /// Ours: the generator draws a correction added to the render, clamped to [0, 1], so an
    /// untrained generator returns its input (pix2pix draws the whole frame through tanh).
    #[config(default = true)]
    pub residual: bool,
}

/// The U-Net generator G of eq. 5.
#[derive(Module, Debug)]
pub struct Generator {
    downs: Vec<Conv2d>,
    /// After `downs[i]` for `0 < i < depth − 1` (at `i − 1`): not the outermost, not the
    /// innermost (pix2pix).
    down_norms: Vec<InstanceNorm>,
    /// `ups[i]` takes level `i + 1` to level `i`; `ups[0]` draws the output.
    ups: Vec<ConvTranspose2d>,
    /// After `ups[i]` for `i > 0` (at `i − 1`).
    up_norms: Vec<InstanceNorm>,
    dropout: Dropout,
    /// Decoder blocks `ups[i]` with `i >= dropout_from` (and below the innermost) drop out.
    dropout_from: usize,
    /// Whether the output is a correction to the input (see [`AppearanceNetConfig::residual`]).
    residual: bool,
}

/// The PatchGAN critic D of eq. 6 (no normalisation, so [`Critic::input_gradient`] is exact).
#[derive(Module, Debug)]
pub struct Critic {
    convs: Vec<Conv2d>,
}

impl AppearanceNetConfig {
    /// The generator's downsamplings: halvings of S while it stays even, at most eight
    /// (seven at 128², as pix2pix's `unet_128`).
    pub fn depth(&self) -> usize {
        let mut size = self.input_size;
        let mut depth = 0;
        while size.is_multiple_of(2) && size > 1 && depth < MAX_DEPTH {
            size /= 2;
            depth += 1;
        }
        depth
    }

    fn channels(&self, level: usize) -> usize {
        (self.base_channels << level.min(16)).min(self.max_channels)
    }

    /// The critic's input channels: the frame, and the render beside it when conditioned.
    pub fn critic_inputs(&self) -> usize {
        if self.conditioned {
            8
        } else {
            4
        }
    }

    /// A fresh generator (pix2pix's N(0, 0.02) weights).
    ///
    /// # Panics
    /// If S is odd or smaller than 2 (a caller bug: the model's working size is a multiple of 8).
    pub fn init_generator(&self, device: &Device) -> Generator {
        let depth = self.depth();
        assert!(depth >= 1, "input size {} cannot be halved", self.input_size);
        let downs = (0..depth)
            .map(|i| {
                let input = if i == 0 { 4 } else { self.channels(i - 1) };
                conv(input, self.channels(i), STRIDE, device)
            })
            .collect();
        let ups = (0..depth)
            .map(|i| {
                let input = if i == depth - 1 { self.channels(i) } else { 2 * self.channels(i) };
                let output = if i == 0 { 4 } else { self.channels(i - 1) };
                ConvTranspose2dConfig::new([input, output], [KERNEL, KERNEL])
                    .with_stride([STRIDE, STRIDE])
                    .with_padding([PADDING, PADDING])
                    .with_initializer(normal())
                    .init(device)
            })
            .collect();
        Generator {
            downs,
            down_norms: (1..depth.saturating_sub(1))
                .map(|i| InstanceNormConfig::new(self.channels(i)).init(device))
                .collect(),
            ups,
            up_norms: (1..depth)
                .map(|i| InstanceNormConfig::new(self.channels(i - 1)).init(device))
                .collect(),
            dropout: DropoutConfig::new(self.dropout).init(),
            dropout_from: (depth - 1).saturating_sub(depth.saturating_sub(UNDROPPED)),
            residual: self.residual,
        }
    }

    /// A fresh critic.
    pub fn init_critic(&self, device: &Device) -> Critic {
        let mut convs = Vec::new();
        let mut input = self.critic_inputs();
        for i in 0..=CRITIC_STRIDED {
            convs.push(conv(input, self.channels(i), critic_stride(i), device));
            input = self.channels(i);
        }
        convs.push(conv(input, 1, critic_stride(CRITIC_STRIDED + 1), device));
        Critic { convs }
    }
}

/// The stride of the critic's convolution `k`.
fn critic_stride(k: usize) -> usize {
    if k < CRITIC_STRIDED {
        2
    } else {
        1
    }
}

fn normal() -> Initializer {
    Initializer::Normal { mean: 0.0, std: 0.02 }
}

fn conv(input: usize, output: usize, stride: usize, device: &Device) -> Conv2d {
    Conv2dConfig::new([input, output], [KERNEL, KERNEL])
        .with_stride([stride, stride])
        .with_padding(PaddingConfig2d::Explicit(PADDING, PADDING, PADDING, PADDING))
        .with_initializer(normal())
        .init(device)
}

impl Generator {
    /// Moves the network out, leaving one without layers in its place, so an optimiser can take
    /// the only reference to each weight and update it in place (see `DeformationNet::take`).
    pub fn take(&mut self) -> Generator {
        let empty = Generator {
            downs: Vec::new(),
            down_norms: Vec::new(),
            ups: Vec::new(),
            up_norms: Vec::new(),
            dropout: self.dropout.clone(),
            dropout_from: self.dropout_from,
            residual: self.residual,
        };
        std::mem::replace(self, empty)
    }

    /// Redraws renders `[B, 4, S, S]` (premultiplied RGBA in [0, 1]) as frames of the same shape.
    pub fn forward(&self, render: Tensor<4>) -> Tensor<4> {
        let depth = self.downs.len();
        let mut skips = Vec::with_capacity(depth);
        let mut h = render.clone();
        for (i, down) in self.downs.iter().enumerate() {
            if i > 0 {
                h = leaky_relu(h, SLOPE);
            }
            h = conv2d(down, h, STRIDE, PADDING);
            if i > 0 && i + 1 < depth {
                h = self.down_norms[i - 1].forward(h);
            }
            skips.push(h.clone());
        }
        for i in (0..depth).rev() {
            h = conv_transpose2d(&self.ups[i], relu(h), STRIDE, PADDING);
            if i > 0 {
                h = self.up_norms[i - 1].forward(h);
                if i >= self.dropout_from && i < depth - 1 {
                    h = self.dropout.forward(h);
                }
                h = Tensor::cat(vec![skips[i - 1].clone(), h], 1);
            }
        }
        if self.residual {
            (render + tanh(h)).clamp(0.0, 1.0)
        } else {
            (tanh(h) + 1.0) * 0.5
        }
    }
}

impl Critic {
    /// Moves the network out (as [`Generator::take`]).
    pub fn take(&mut self) -> Critic {
        std::mem::replace(self, Critic { convs: Vec::new() })
    }

    /// One score per patch, `[B, 1, h, w]`, of `frames` (with `render` beside them when the
    /// critic is conditioned).
    pub fn forward(&self, frames: Tensor<4>, render: Option<Tensor<4>>) -> Tensor<4> {
        self.layers(input(frames, render), false).0
    }

    /// The forward pass, with each hidden layer's pre-activation; with `detached` weights the
    /// result is a constant.
    fn layers(&self, x: Tensor<4>, detached: bool) -> (Tensor<4>, Vec<Tensor<4>>) {
        let mut pre = Vec::with_capacity(self.convs.len() - 1);
        let mut h = x;
        for (k, conv) in self.convs.iter().enumerate() {
            let stride = critic_stride(k);
            let weight = conv.weight.val();
            let bias = conv.bias.as_ref().map(|b| b.val());
            let (weight, bias) = if detached {
                (weight.detach(), bias.map(Tensor::detach))
            } else {
                (weight, bias)
            };
            h = convolve(h, weight, bias, stride, PADDING);
            if k + 1 < self.convs.len() {
                pre.push(h.clone());
                h = leaky_relu(h, SLOPE);
            }
        }
        (h, pre)
    }

    /// ∇ₓ Σ D(x): the gradient of the sum of patch scores with respect to the frames, exactly,
    /// as a tensor that is differentiable in the critic's weights with first-order autodiff
    /// (Burn has no double backward). For convolutions and LeakyReLU only, the input gradient is
    /// a linear chain: ones at the output, back through each layer as a transposed convolution
    /// with that layer's (tracked) weight, times each LeakyReLU's slope mask (1 or 0.2, read from
    /// an untracked forward; it is piecewise constant, so its derivative is zero almost
    /// everywhere). Costs about two critic passes. With a render, the gradient is the frame
    /// channels' part.
    pub fn input_gradient(&self, frames: Tensor<4>, render: Option<Tensor<4>>) -> Tensor<4> {
        let frame_channels = frames.dims()[1];
        let x = input(frames, render).detach();
        let (scores, pre) = self.layers(x.clone(), true);
        let mut sizes: Vec<[usize; 2]> = vec![[x.dims()[2], x.dims()[3]]];
        sizes.extend(pre.iter().map(|p| [p.dims()[2], p.dims()[3]]));
        let mut g = Tensor::ones(scores.dims(), &scores.device());
        for k in (0..self.convs.len()).rev() {
            let stride = critic_stride(k);
            g = convolve_transposed(g, self.convs[k].weight.val(), None, stride, PADDING, sizes[k]);
            if k > 0 {
                g = g * slope_mask(pre[k - 1].clone());
            }
        }
        let [batch, _, height, width] = g.dims();
        g.slice([0..batch, 0..frame_channels, 0..height, 0..width])
    }
}

#[cfg(test)]
impl Critic {
    /// Convolution `k`'s weight (for gradient checks).
    pub(crate) fn convs_weight(&self, k: usize) -> Tensor<4> {
        self.convs[k].weight.val()
    }

    /// This critic with convolution `k`'s weight replaced.
    pub(crate) fn with_convs_weight(mut self, k: usize, weight: Tensor<4>) -> Self {
        self.convs[k].weight = burn::module::Param::from_tensor(weight);
        self
    }

    /// This critic with convolution `k`'s bias replaced (it has one).
    pub(crate) fn with_convs_bias(mut self, k: usize, bias: Tensor<1>) -> Self {
        self.convs[k].bias = Some(burn::module::Param::from_tensor(bias));
        self
    }
}

/// The critic's input: the frames, and the render beside them.
fn input(frames: Tensor<4>, render: Option<Tensor<4>>) -> Tensor<4> {
    match render {
        Some(r) => Tensor::cat(vec![frames, r], 1),
        None => frames,
    }
}

/// LeakyReLU's derivative at `pre`: 1 where positive, [`SLOPE`] elsewhere, as a constant.
fn slope_mask(pre: Tensor<4>) -> Tensor<4> {
    pre.detach().greater_elem(0.0).float() * (1.0 - SLOPE) + SLOPE
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::{Distribution, TensorData};

    fn values(t: Tensor<4>) -> Vec<f32> {
        t.into_data().convert::<f32>().try_to_vec::<f32>().unwrap()
    }

    #[test]
    fn full_size_has_pix2pix_parameter_counts() {
        let device = crate::backend::device();
        let config = AppearanceNetConfig::new(128).with_base_channels(64).with_max_channels(512);
        assert_eq!(config.depth(), 7);
        let g = config.init_generator(&device).num_params();
        let d = config.init_critic(&device).num_params();
        // pix2pix unet_128: 41.8 M (RGB, batch norm); PatchGAN 2.77 M. Ours: RGBA and biases.
        assert!((41_700_000..41_900_000).contains(&g), "generator {g}");
        assert!((2_760_000..2_780_000).contains(&d), "critic {d}");
    }

    #[test]
    fn shapes_follow_the_working_size() {
        let device = crate::backend::device();
        for size in [64, 96] {
            let config = AppearanceNetConfig::new(size).with_conditioned(true);
            let x = Tensor::<4>::random([2, 4, size, size], Distribution::Uniform(0.0, 1.0), &device);
            let y = config.init_generator(&device).forward(x.clone());
            assert_eq!(y.dims(), [2, 4, size, size]);
            let v = values(y);
            assert!(v.iter().all(|v| (0.0..=1.0).contains(v)));
            let critic = config.init_critic(&device);
            let scores = critic.forward(x.clone(), Some(x.clone()));
            assert_eq!(scores.dims(), [2, 1, size / 8 - 2, size / 8 - 2]);
            assert_eq!(critic.input_gradient(x.clone(), Some(x)).dims(), [2, 4, size, size]);
        }
    }

    #[test]
    fn the_input_gradient_chain_is_autodiffs_input_gradient() {
        let device = crate::backend::train_device();
        device.seed(5);
        for conditioned in [false, true] {
            let config = AppearanceNetConfig::new(32)
                .with_base_channels(3)
                .with_max_channels(5)
                .with_conditioned(conditioned);
            let critic = config.init_critic(&device);
            let x = Tensor::<4>::random([2, 4, 32, 32], Distribution::Normal(0.0, 1.0), &device).require_grad();
            let render = conditioned.then(|| Tensor::<4>::random([2, 4, 32, 32], Distribution::Normal(0.0, 1.0), &device));
            let grads = critic.forward(x.clone(), render.clone()).sum().backward();
            let autodiff = values(x.grad(&grads).unwrap());
            let chain = values(critic.input_gradient(x.clone().detach(), render));
            let scale = autodiff.iter().fold(0f32, |m, v| m.max(v.abs()));
            assert!(scale > 0.0);
            for (a, c) in autodiff.iter().zip(&chain) {
                assert!((a - c).abs() <= 1e-5 * scale, "autodiff {a} vs chain {c}");
            }
        }
    }

    #[test]
    fn a_tiny_generator_reproduces_its_input_shape_and_is_deterministic_without_autodiff() {
        let device = crate::backend::device();
        let g = AppearanceNetConfig::new(16).init_generator(&device);
        let x = Tensor::<4>::from_data(TensorData::new(vec![0.5f32; 4 * 16 * 16], [1, 4, 16, 16]), &device);
        assert_eq!(values(g.forward(x.clone())), values(g.forward(x)), "dropout is off at inference");
    }
}
