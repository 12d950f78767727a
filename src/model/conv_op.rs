//! Convolutions and transposed convolutions as custom Burn operations over [`ConvGeometry`]'s
//! slice kernels (issue 5: Burn's flex convolution spent most of the encoder's backward in its
//! weight gradient; issue 15: the same for the appearance networks' convolutions and transposed
//! convolutions; benches/README.md "backend" and "appearance"). Same parameters and records as
//! `burn::nn::conv::{Conv2d, ConvTranspose2d}`, so saved models load unchanged; tensors on
//! another backend take Burn's own operations.
//!
//! A transposed convolution is the adjoint of a convolution: its forward pass is that
//! convolution's input gradient, its input gradient that convolution's forward pass, and its
//! weight gradient that convolution's weight gradient with input and upstream swapped — so one
//! geometry and three kernels serve both directions.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::autodiff::NodeId;
use burn::backend::ops::FloatTensorOps;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::nn::conv::{Conv2d, ConvTranspose2d};
use burn::tensor::ops::{ConvOptions, ConvTransposeOptions};
use burn::tensor::{Tensor, TensorData};

use super::conv_kernel::ConvGeometry;
use super::conv_phases::DoubledConv;
use crate::backend::Inner;
use crate::render::burn_op::{host, register_gradient, HostValues};

/// `conv.forward(x)` for a square-kernel convolution with `stride` and `padding` zeros on every
/// side (the ones `conv` was built with).
pub fn conv2d(conv: &Conv2d, x: Tensor<4>, stride: usize, padding: usize) -> Tensor<4> {
    convolve(x, conv.weight.val(), conv.bias.as_ref().map(|b| b.val()), stride, padding)
}

/// `conv.forward(x)` for a square-kernel transposed convolution with `stride` and `padding` (the
/// ones `conv` was built with, no output padding): output side `(side − 1)·stride − 2·padding + K`.
pub fn conv_transpose2d(conv: &ConvTranspose2d, x: Tensor<4>, stride: usize, padding: usize) -> Tensor<4> {
    let [_, _, height, width] = x.dims();
    let kernel = conv.weight.dims()[2];
    let side = |n: usize| (n - 1) * stride + kernel - 2 * padding;
    convolve_transposed(
        x,
        conv.weight.val(),
        conv.bias.as_ref().map(|b| b.val()),
        stride,
        padding,
        [side(height), side(width)],
    )
}

/// `conv.forward` of `x` `[B, C, H, W]` doubled by nearest neighbour (each pixel 2×2), for a
/// stride-1 convolution with `padding` zeros: a U-Net's way up, without the doubled tensor
/// (making it and summing its gradient back were Burn operations on one core). A 3×3 kernel with
/// padding 1 runs as 2×2 convolutions of `x` itself ([`DoubledConv`]).
pub fn conv2d_doubled(conv: &Conv2d, x: Tensor<4>, padding: usize) -> Tensor<4> {
    let (weight, bias) = (conv.weight.val(), conv.bias.as_ref().map(|b| b.val()));
    let geometry = ConvGeometry {
        upsample: 2,
        ..forward_geometry(&x, &weight, 1, padding)
    };
    apply(Direction::Forward, geometry, &x, &weight, bias.as_ref())
        .unwrap_or_else(|| burn::tensor::module::conv2d(double(x), weight, bias, ConvOptions::new([1; 2], [padding; 2], [1, 1], 1)))
}

/// Each pixel of `x` `[B, C, H, W]` repeated 2×2: `[B, C, 2H, 2W]`.
fn double(x: Tensor<4>) -> Tensor<4> {
    let [b, c, h, w] = x.dims();
    x.reshape([b * c * h, 1, w, 1])
        .expand([b * c * h, 2, w, 2])
        .reshape([b, c, 2 * h, 2 * w])
}

/// The convolution of `x` `[B, C, H, W]` with square kernels `weight` `[O, C, K, K]` (and
/// `bias` `[O]`), moved by `stride` over `padding` zeros on every side: Burn's
/// `module::conv2d`, through the slice kernels when every tensor lives on the compiled-in
/// backend (differentiable in each on its autodiff device).
pub fn convolve(x: Tensor<4>, weight: Tensor<4>, bias: Option<Tensor<1>>, stride: usize, padding: usize) -> Tensor<4> {
    let geometry = forward_geometry(&x, &weight, stride, padding);
    apply(Direction::Forward, geometry, &x, &weight, bias.as_ref())
        .unwrap_or_else(|| burn::tensor::module::conv2d(x, weight, bias, ConvOptions::new([stride; 2], [padding; 2], [1, 1], 1)))
}

/// The geometry of the convolution of `x` with `weight` `[O, C, K, K]`.
fn forward_geometry(x: &Tensor<4>, weight: &Tensor<4>, stride: usize, padding: usize) -> ConvGeometry {
    let [out_channels, channels, kernel, _] = weight.dims();
    let [_, _, height, width] = x.dims();
    ConvGeometry {
        channels,
        height,
        width,
        out_channels,
        kernel,
        stride,
        padding,
        upsample: 1,
    }
}

/// The transposed convolution of `x` `[B, I, h, w]` with `weight` `[I, O, K, K]` (Burn's
/// layout; and `bias` `[O]`) to an output of `size` `[H, W]`: the adjoint of the convolution
/// with the same weights, `stride` and `padding` that takes `[B, O, H, W]` to `[B, I, h, w]`.
/// `size` must be one that convolution maps to `h × w` (it picks the output padding).
pub fn convolve_transposed(
    x: Tensor<4>,
    weight: Tensor<4>,
    bias: Option<Tensor<1>>,
    stride: usize,
    padding: usize,
    size: [usize; 2],
) -> Tensor<4> {
    let [inputs, outputs, kernel, _] = weight.dims();
    let geometry = ConvGeometry {
        channels: outputs,
        height: size[0],
        width: size[1],
        out_channels: inputs,
        kernel,
        stride,
        padding,
        upsample: 1,
    };
    let [_, _, h, w] = x.dims();
    debug_assert_eq!([geometry.out_height(), geometry.out_width()], [h, w], "output size {size:?}");
    apply(Direction::Transposed, geometry, &x, &weight, bias.as_ref()).unwrap_or_else(|| {
        let extra = |full: usize, side: usize| full + 2 * padding - (side - 1) * stride - kernel;
        let options = ConvTransposeOptions::new([stride; 2], [padding; 2], [extra(size[0], h), extra(size[1], w)], [1, 1], 1);
        burn::tensor::module::conv_transpose2d(x, weight, bias, options)
    })
}

/// Which way an operation runs over its [`ConvGeometry`].
#[derive(Clone, Copy, Debug)]
enum Direction {
    /// The geometry's convolution: `x` is its input.
    Forward,
    /// Its adjoint, the transposed convolution: `x` has the convolution's output shape.
    Transposed,
}

impl Direction {
    /// The geometry's `[channels, height, width]` on the output side of the operation.
    fn output_shape(self, g: &ConvGeometry) -> [usize; 3] {
        match self {
            Direction::Forward => [g.out_channels, g.out_height(), g.out_width()],
            Direction::Transposed => [g.channels, g.height, g.width],
        }
    }

    /// The operation on host values (bias per output channel).
    fn run(self, g: &ConvGeometry, x: &[f32], weight: &[f32], bias: &[f32]) -> Vec<f32> {
        match self {
            Direction::Forward => match DoubledConv::of(g) {
                Some(doubled) => doubled.forward(x, weight, bias),
                None => g.forward(x, weight, bias),
            },
            Direction::Transposed => {
                let mut y = g.input_gradient(weight, x);
                let plane = g.height * g.width;
                for (values, &b) in y.chunks_exact_mut(plane).zip(bias.iter().cycle()) {
                    values.iter_mut().for_each(|v| *v += b);
                }
                y
            }
        }
    }

    /// The geometry's `[channels, height, width]` on the input side of the operation.
    fn input_shape(self, g: &ConvGeometry) -> [usize; 3] {
        match self {
            Direction::Forward => [g.channels, g.height, g.width],
            Direction::Transposed => [g.out_channels, g.out_height(), g.out_width()],
        }
    }

    /// The gradients of the input (if asked for), the weights and the bias for `upstream`
    /// (output shaped).
    fn gradients(
        self,
        g: &ConvGeometry,
        x: &[f32],
        weight: &[f32],
        upstream: &[f32],
        input: bool,
    ) -> (Option<Vec<f32>>, Vec<f32>, Vec<f32>) {
        match self {
            Direction::Forward => match DoubledConv::of(g) {
                Some(doubled) => doubled.gradients(x, weight, upstream, input),
                None => {
                    let (dw, db) = g.weight_gradient(x, upstream);
                    (input.then(|| g.input_gradient(weight, upstream)), dw, db)
                }
            },
            Direction::Transposed => {
                let (dw, _) = g.weight_gradient(upstream, x);
                let plane = g.height * g.width;
                let mut db = vec![0f32; g.channels];
                for (k, values) in upstream.chunks_exact(plane).enumerate() {
                    db[k % g.channels] += values.iter().sum::<f32>();
                }
                let dx = input.then(|| g.forward(upstream, weight, &vec![0.0; g.out_channels]));
                (dx, dw, db)
            }
        }
    }
}

/// Runs `direction` over `geometry` on the slice kernels, or `None` when the tensors live on
/// another backend.
fn apply(direction: Direction, geometry: ConvGeometry, x: &Tensor<4>, weight: &Tensor<4>, bias: Option<&Tensor<1>>) -> Option<Tensor<4>> {
    let batch = x.dims()[0];
    let [channels, height, width] = direction.output_shape(&geometry);
    let bias_or_zeros = bias.cloned().unwrap_or_else(|| Tensor::zeros([channels], &weight.device()));
    let output = |values: Vec<f32>| Inner::float_from_data(TensorData::new(values, [batch, channels, height, width]), &Default::default());
    let ad = |t: Tensor<4>| t.try_into_primitive::<Autodiff<Inner>>().ok();
    if let (Some(ax), Some(aw), Some(ab)) = (
        ad(x.clone()),
        ad(weight.clone()),
        bias_or_zeros.clone().try_into_primitive::<Autodiff<Inner>>().ok(),
    ) {
        let (xs, ws, bs) = (
            HostValues::new(ax.primitive().clone()),
            HostValues::new(aw.primitive().clone()),
            HostValues::new(ab.primitive().clone()),
        );
        let y = output(direction.run(&geometry, xs.values(), ws.values(), bs.values()));
        let out = match ConvBackward
            .prepare::<NoCheckpointing>([ax.node(), aw.node(), ab.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => prep.finish(
                Arc::new(Saved {
                    direction,
                    geometry,
                    input: xs,
                    weight: ws,
                }),
                y,
            ),
            OpsKind::UnTracked(prep) => prep.finish(y),
        };
        return Some(Tensor::from_primitive::<Autodiff<Inner>>(out));
    }
    let plain = |t: Tensor<4>| t.try_into_primitive::<Inner>().ok();
    match (
        plain(x.clone()),
        plain(weight.clone()),
        bias_or_zeros.try_into_primitive::<Inner>().ok(),
    ) {
        (Some(px), Some(pw), Some(pb)) => {
            let (xs, ws, bs) = (HostValues::new(px), HostValues::new(pw), HostValues::new(pb));
            let y = direction.run(&geometry, xs.values(), ws.values(), bs.values());
            Some(Tensor::from_primitive::<Inner>(output(y)))
        }
        _ => None,
    }
}

/// What the backward needs from the forward: the input and the weights on the host.
#[derive(Debug)]
struct Saved {
    direction: Direction,
    geometry: ConvGeometry,
    input: HostValues,
    weight: HostValues,
}

#[derive(Debug)]
struct ConvBackward;

impl<B: Backend> Backward<B, 3> for ConvBackward {
    type State = Arc<Saved>;

    fn backward(self, ops: Ops<Self::State, 3>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let [input, weight, bias] = ops.parents;
        let upstream = grads.consume::<B>(&ops.node);
        let device = upstream.device();
        let s = &ops.state;
        let (dx, dw, db) = s.direction.gradients(
            &s.geometry,
            s.input.values(),
            s.weight.values(),
            &host::<B>(upstream),
            input.is_some(),
        );
        let mut register = |node: Option<NodeId>, values: Vec<f32>, dims: Vec<usize>| {
            register_gradient::<B>(grads, node, values, dims, &device);
        };
        if let Some(dx) = dx {
            let [c, h, w] = s.direction.input_shape(&s.geometry);
            let batch = s.input.values().len() / (c * h * w);
            register(input.map(|n| n.id), dx, vec![batch, c, h, w]);
        }
        // `[O, C, K, K]` for a convolution; the same numbers are Burn's `[I, O, K, K]` of its
        // transposed convolution.
        let k = s.geometry.kernel;
        register(weight.map(|n| n.id), dw, vec![s.geometry.out_channels, s.geometry.channels, k, k]);
        let bias_len = db.len();
        register(bias.map(|n| n.id), db, vec![bias_len]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::conv::{Conv2dConfig, ConvTranspose2dConfig};
    use burn::nn::PaddingConfig2d;
    use burn::tensor::Distribution;

    fn values(t: Tensor<4>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().unwrap()
    }

    fn worst(a: Vec<f32>, b: Vec<f32>) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max)
    }

    /// Ours and Burn's outputs agree, and so do the gradients of the input, the weights and the
    /// bias through a non-uniform loss.
    fn assert_same(ours: Tensor<4>, burns: Tensor<4>, x: &Tensor<4>, weight: &Tensor<4>, bias: Option<&Tensor<1>>) {
        assert_eq!(ours.dims(), burns.dims());
        let device = ours.device();
        let loss_weights = Tensor::<4>::random(ours.dims(), Distribution::Uniform(-1.0, 1.0), &device);
        assert!(worst(values(ours.clone()), values(burns.clone())) < 1e-5, "output");
        let g_ours = (ours * loss_weights.clone()).sum().backward();
        let g_burn = (burns * loss_weights).sum().backward();
        let dx = |g| values(x.grad(g).unwrap());
        assert!(worst(dx(&g_ours), dx(&g_burn)) < 1e-4, "input gradient");
        let dw = |g| values(weight.grad(g).unwrap());
        assert!(worst(dw(&g_ours), dw(&g_burn)) < 1e-4, "weight gradient");
        if let Some(bias) = bias {
            let db = |g| bias.grad(g).unwrap().into_data().try_to_vec::<f32>().unwrap();
            let (a, b) = (db(&g_ours), db(&g_burn));
            assert!(a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 1e-4), "bias gradient {a:?} {b:?}");
        }
    }

    #[test]
    fn matches_burns_convolution_and_its_gradients() {
        let device = crate::backend::train_device();
        let config = Conv2dConfig::new([3, 6], [5, 5])
            .with_stride([2, 2])
            .with_padding(PaddingConfig2d::Explicit(2, 2, 2, 2));
        let conv = config.init(&device);
        let x = Tensor::<4>::random([2, 3, 12, 10], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        let bias = conv.bias.as_ref().unwrap().val();
        assert_same(
            conv2d(&conv, x.clone(), 2, 2),
            conv.forward(x.clone()),
            &x,
            &conv.weight.val(),
            Some(&bias),
        );
        // Without autodiff: the same values.
        let plain_device = crate::backend::device();
        let plain = config.init(&plain_device);
        let xp = Tensor::<4>::random([2, 3, 12, 10], Distribution::Uniform(-1.0, 1.0), &plain_device);
        assert!(worst(values(conv2d(&plain, xp.clone(), 2, 2)), values(plain.forward(xp))) < 1e-5);
    }

    /// The U-Net's way up: a 3×3 convolution of the doubled input, against Burn's convolution
    /// of the doubled tensor.
    #[test]
    fn a_convolution_of_the_doubled_input_matches_burns_on_the_doubled_tensor() {
        let device = crate::backend::train_device();
        let config = Conv2dConfig::new([3, 4], [3, 3]).with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1));
        let conv = config.init(&device);
        let x = Tensor::<4>::random([2, 3, 5, 4], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        let bias = conv.bias.as_ref().unwrap().val();
        let ours = conv2d_doubled(&conv, x.clone(), 1);
        assert_eq!(ours.dims(), [2, 4, 10, 8]);
        assert_same(ours, conv.forward(double(x.clone())), &x, &conv.weight.val(), Some(&bias));
    }

    /// The generator's up-convolutions (4×4, stride 2, padding 1) and a stride-1 case with an
    /// odd size, against Burn's transposed convolution.
    #[test]
    fn matches_burns_transposed_convolution_and_its_gradients() {
        let device = crate::backend::train_device();
        for (stride, padding, kernel, side) in [(2, 1, 4, [5, 4]), (1, 1, 4, [7, 6]), (2, 2, 5, [3, 4])] {
            let config = ConvTranspose2dConfig::new([6, 3], [kernel, kernel])
                .with_stride([stride, stride])
                .with_padding([padding, padding]);
            let conv = config.init(&device);
            let x = Tensor::<4>::random([2, 6, side[0], side[1]], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
            let bias = conv.bias.as_ref().unwrap().val();
            let ours = conv_transpose2d(&conv, x.clone(), stride, padding);
            assert_same(ours, conv.forward(x.clone()), &x, &conv.weight.val(), Some(&bias));
            let plain_device = crate::backend::device();
            let plain = config.init(&plain_device);
            let xp = Tensor::<4>::random([2, 6, side[0], side[1]], Distribution::Uniform(-1.0, 1.0), &plain_device);
            let ours = conv_transpose2d(&plain, xp.clone(), stride, padding);
            assert!(worst(values(ours), values(plain.forward(xp))) < 1e-5);
        }
    }

    /// With an output padding (a size the plain formula does not give) and no bias.
    #[test]
    fn a_transposed_convolution_reaches_any_size_its_convolution_maps_from() {
        let device = crate::backend::train_device();
        let weight = Tensor::<4>::random([4, 2, 4, 4], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        let x = Tensor::<4>::random([1, 4, 3, 3], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        // A 4×4 stride-2 convolution with padding 1 maps 7 and 6 to 3.
        let ours = convolve_transposed(x.clone(), weight.clone(), None, 2, 1, [7, 6]);
        let options = ConvTransposeOptions::new([2, 2], [1, 1], [1, 0], [1, 1], 1);
        let burns = burn::tensor::module::conv_transpose2d(x.clone(), weight.clone(), None, options);
        assert_eq!(ours.dims(), [1, 2, 7, 6]);
        assert_same(ours, burns, &x, &weight, None);
    }
}
