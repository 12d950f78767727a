//! The encoder's convolutions as a custom Burn operation over [`ConvGeometry`]'s slice kernels
//! (issue 5: Burn's flex convolution spent most of the encoder's backward in its weight
//! gradient; benches/README.md "backend"). Same parameters and record as `burn::nn::conv::Conv2d`,
//! so saved models load unchanged; a tensor on another backend takes Burn's own convolution.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::ops::FloatTensorOps;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::nn::conv::Conv2d;
use burn::tensor::{Tensor, TensorData};

use super::conv_kernel::ConvGeometry;
use crate::backend::Inner;
use crate::render::burn_op::host;

/// `conv.forward(x)` for a square-kernel convolution with `stride` and `padding` zeros on every
/// side (the ones `conv` was built with), through the slice kernels when `x` and the weights
/// live on the compiled-in backend (differentiable on its autodiff device).
pub fn conv2d(conv: &Conv2d, x: Tensor<4>, stride: usize, padding: usize) -> Tensor<4> {
    let [out_channels, channels, kernel, _] = conv.weight.dims();
    let [batch, _, height, width] = x.dims();
    let geometry = ConvGeometry {
        channels,
        height,
        width,
        out_channels,
        kernel,
        stride,
        padding,
    };
    let weight = conv.weight.val();
    let bias = match &conv.bias {
        Some(b) => b.val(),
        None => Tensor::zeros([out_channels], &weight.device()),
    };
    let shape = [batch, out_channels, geometry.out_height(), geometry.out_width()];
    let output = |values: Vec<f32>| Inner::float_from_data(TensorData::new(values, shape), &Default::default());
    let ad = |t: Tensor<4>| t.try_into_primitive::<Autodiff<Inner>>().ok();
    if let (Some(ax), Some(aw), Some(ab)) = (
        ad(x.clone()),
        ad(weight.clone()),
        bias.clone().try_into_primitive::<Autodiff<Inner>>().ok(),
    ) {
        let (xs, ws, bs) = (
            host::<Inner>(ax.primitive().clone()),
            host::<Inner>(aw.primitive().clone()),
            host::<Inner>(ab.primitive().clone()),
        );
        let y = output(geometry.forward(&xs, &ws, &bs));
        let out = match ConvBackward
            .prepare::<NoCheckpointing>([ax.node(), aw.node(), ab.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => prep.finish(
                Arc::new(Saved {
                    geometry,
                    input: xs,
                    weight: ws,
                }),
                y,
            ),
            OpsKind::UnTracked(prep) => prep.finish(y),
        };
        return Tensor::from_primitive::<Autodiff<Inner>>(out);
    }
    let plain = |t: Tensor<4>| t.try_into_primitive::<Inner>().ok();
    match (plain(x.clone()), plain(weight), bias.try_into_primitive::<Inner>().ok()) {
        (Some(px), Some(pw), Some(pb)) => {
            let y = geometry.forward(&host::<Inner>(px), &host::<Inner>(pw), &host::<Inner>(pb));
            Tensor::from_primitive::<Inner>(output(y))
        }
        _ => conv.forward(x),
    }
}

/// What the backward needs from the forward: the input and the weights on the host.
#[derive(Debug)]
struct Saved {
    geometry: ConvGeometry,
    input: Vec<f32>,
    weight: Vec<f32>,
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
        let g = s.geometry.backward(&s.input, &s.weight, &host::<B>(upstream), input.is_some());
        let batch = s.input.len() / s.geometry.input_len();
        let k = s.geometry.kernel;
        let mut register = |node: Option<burn::backend::autodiff::NodeId>, values: Vec<f32>, shape: Vec<usize>| {
            if let Some(id) = node {
                grads.register::<B>(id, B::float_from_data(TensorData::new(values, shape), &device));
            }
        };
        let geometry = &s.geometry;
        if let Some(dx) = g.input {
            register(
                input.map(|n| n.id),
                dx,
                vec![batch, geometry.channels, geometry.height, geometry.width],
            );
        }
        register(weight.map(|n| n.id), g.weight, vec![geometry.out_channels, geometry.channels, k, k]);
        register(bias.map(|n| n.id), g.bias, vec![geometry.out_channels]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::conv::Conv2dConfig;
    use burn::nn::PaddingConfig2d;
    use burn::tensor::Distribution;

    /// Against Burn's own convolution: same output, and the same gradients for the input, the
    /// weights and the bias through a non-uniform loss.
    #[test]
    fn matches_burns_convolution_and_its_gradients() {
        let device = crate::backend::train_device();
        let config = Conv2dConfig::new([3, 6], [5, 5])
            .with_stride([2, 2])
            .with_padding(PaddingConfig2d::Explicit(2, 2, 2, 2));
        let conv = config.init(&device);
        let x = Tensor::<4>::random([2, 3, 12, 10], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        let ours = conv2d(&conv, x.clone(), 2, 2);
        let burns = conv.forward(x.clone());
        assert_eq!(ours.dims(), burns.dims());
        let weights = Tensor::<4>::random(ours.dims(), Distribution::Uniform(-1.0, 1.0), &device);
        let values = |t: Tensor<4>| t.into_data().try_to_vec::<f32>().unwrap();
        let worst = |a: Vec<f32>, b: Vec<f32>| a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst(values(ours.clone()), values(burns.clone())) < 1e-5);
        let g_ours = (ours * weights.clone()).sum().backward();
        let g_burn = (burns * weights).sum().backward();
        let dx = |g| values(x.grad(g).unwrap());
        assert!(worst(dx(&g_ours), dx(&g_burn)) < 1e-4, "input gradient");
        let dw = |g| values(conv.weight.val().grad(g).unwrap());
        assert!(worst(dw(&g_ours), dw(&g_burn)) < 1e-4, "weight gradient");
        let bias = conv.bias.as_ref().unwrap().val();
        let db = |g| bias.grad(g).unwrap().into_data().try_to_vec::<f32>().unwrap();
        assert!(worst(db(&g_ours), db(&g_burn)) < 1e-4, "bias gradient");
        // Without autodiff: the same values.
        let plain_device = crate::backend::device();
        let plain = config.init(&plain_device);
        let xp = Tensor::<4>::random([2, 3, 12, 10], Distribution::Uniform(-1.0, 1.0), &plain_device);
        assert!(worst(values(conv2d(&plain, xp.clone(), 2, 2)), values(plain.forward(xp))) < 1e-5);
    }
}
