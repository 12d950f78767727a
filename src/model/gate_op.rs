//! The correspondence network's gated activation as one custom Burn operation over
//! [`Gate`]'s slice kernels. Burn composes it (instance norm, affine, LeakyReLU, sigmoid,
//! product) from a dozen elementwise tensor operations, each into a fresh buffer and most on one
//! core, and its backward from as many again (benches/README.md "parts"). Same parameters as
//! `burn::nn::InstanceNorm`, so saved networks load unchanged; tensors on another backend, and a
//! norm without an affine, take Burn's own operations.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::ops::FloatTensorOps;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::nn::InstanceNorm;
use burn::tensor::activation::{leaky_relu, sigmoid};
use burn::tensor::{Tensor, TensorData};

use super::gate_kernel::{Gate, PlaneStats};
use crate::backend::Inner;
use crate::render::burn_op::{host, register_gradient, HostValues};

/// `leaky_relu(norm(features), slope) · sigmoid(gates)` for a block output `h` `[B, 2C, H, W]`
/// whose first `C` channels are features and last `C` gates: `[B, C, H, W]`.
pub fn gated_norm(h: Tensor<4>, norm: &InstanceNorm, slope: f64) -> Tensor<4> {
    if let (Some(scale), Some(shift)) = (&norm.gamma, &norm.beta) {
        let [batch, doubled, height, width] = h.dims();
        let gate = Gate {
            batch,
            channels: doubled / 2,
            pixels: height * width,
            epsilon: norm.epsilon,
            slope: slope as f32,
        };
        if let Some(y) = apply(gate, [height, width], &h, &scale.val(), &shift.val()) {
            return y;
        }
    }
    composed(h, norm, slope)
}

/// The activation from Burn's own operations.
fn composed(h: Tensor<4>, norm: &InstanceNorm, slope: f64) -> Tensor<4> {
    let [features, gates] = h.chunk(2, 1).try_into().expect("an even channel count");
    leaky_relu(norm.forward(features), slope) * sigmoid(gates)
}

/// Runs the kernels, or `None` when the tensors live on another backend.
fn apply(gate: Gate, [height, width]: [usize; 2], h: &Tensor<4>, scale: &Tensor<1>, shift: &Tensor<1>) -> Option<Tensor<4>> {
    let output = |values: Vec<f32>| {
        Inner::float_from_data(
            TensorData::new(values, [gate.batch, gate.channels, height, width]),
            &Default::default(),
        )
    };
    let ad = |t: Tensor<1>| t.try_into_primitive::<Autodiff<Inner>>().ok();
    if let (Ok(ah), Some(ascale), Some(ashift)) = (
        h.clone().try_into_primitive::<Autodiff<Inner>>(),
        ad(scale.clone()),
        ad(shift.clone()),
    ) {
        let (hs, scales, shifts) = (
            HostValues::new(ah.primitive().clone()),
            HostValues::new(ascale.primitive().clone()),
            HostValues::new(ashift.primitive().clone()),
        );
        let (y, stats) = gate.forward(hs.values(), scales.values(), shifts.values());
        let out = match GateBackward
            .prepare::<NoCheckpointing>([ah.node(), ascale.node(), ashift.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => prep.finish(
                Arc::new(Saved {
                    gate,
                    dims: [gate.batch, 2 * gate.channels, height, width],
                    input: hs,
                    scale: scales,
                    shift: shifts,
                    stats,
                }),
                output(y),
            ),
            OpsKind::UnTracked(prep) => prep.finish(output(y)),
        };
        return Some(Tensor::from_primitive::<Autodiff<Inner>>(out));
    }
    let plain = |t: Tensor<1>| t.try_into_primitive::<Inner>().ok();
    match (h.clone().try_into_primitive::<Inner>(), plain(scale.clone()), plain(shift.clone())) {
        (Ok(ph), Some(pscale), Some(pshift)) => {
            let (hs, scales, shifts) = (HostValues::new(ph), HostValues::new(pscale), HostValues::new(pshift));
            let (y, _) = gate.forward(hs.values(), scales.values(), shifts.values());
            Some(Tensor::from_primitive::<Inner>(output(y)))
        }
        _ => None,
    }
}

/// What the backward needs from the forward.
#[derive(Debug)]
struct Saved {
    gate: Gate,
    /// The input's shape.
    dims: [usize; 4],
    input: HostValues,
    scale: HostValues,
    shift: HostValues,
    stats: Vec<PlaneStats>,
}

#[derive(Debug)]
struct GateBackward;

impl<B: Backend> Backward<B, 3> for GateBackward {
    type State = Arc<Saved>;

    fn backward(self, ops: Ops<Self::State, 3>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let [input, scale, shift] = ops.parents;
        let upstream = grads.consume::<B>(&ops.node);
        let device = upstream.device();
        let s = &ops.state;
        let g = s
            .gate
            .backward(s.input.values(), s.scale.values(), s.shift.values(), &s.stats, &host::<B>(upstream));
        let channels = s.gate.channels;
        register_gradient::<B>(grads, input.map(|n| n.id), g.input, s.dims.to_vec(), &device);
        register_gradient::<B>(grads, scale.map(|n| n.id), g.scale, vec![channels], &device);
        register_gradient::<B>(grads, shift.map(|n| n.id), g.shift, vec![channels], &device);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::InstanceNormConfig;
    use burn::tensor::Distribution;

    fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().unwrap()
    }

    fn worst(a: Vec<f32>, b: Vec<f32>) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max)
    }

    /// The kernels and Burn's composition agree on the output and on the gradients of the input,
    /// the scales and the shifts through a non-uniform loss; and without autodiff.
    #[test]
    fn matches_burns_composition_and_its_gradients() {
        let device = crate::backend::train_device();
        let mut norm = InstanceNormConfig::new(3).init(&device);
        // Scales and shifts away from their initial ones and zeros.
        let affine =
            |values: [f32; 3]| burn::module::Param::from_tensor(Tensor::<1>::from_data(TensorData::new(values.to_vec(), [3]), &device));
        norm.gamma = Some(affine([0.7, 1.4, -0.5]));
        norm.beta = Some(affine([0.2, -0.3, 0.05]));
        let h = Tensor::<4>::random([2, 6, 5, 7], Distribution::Uniform(-2.0, 2.0), &device).require_grad();
        let ours = gated_norm(h.clone(), &norm, 0.2);
        let burns = composed(h.clone(), &norm, 0.2);
        assert_eq!(ours.dims(), [2, 3, 5, 7]);
        assert!(worst(values(ours.clone()), values(burns.clone())) < 1e-5, "output");
        let weights = Tensor::<4>::random(ours.dims(), Distribution::Uniform(-1.0, 1.0), &device);
        let g_ours = (ours * weights.clone()).sum().backward();
        let g_burn = (burns * weights).sum().backward();
        assert!(
            worst(values(h.grad(&g_ours).unwrap()), values(h.grad(&g_burn).unwrap())) < 1e-4,
            "input gradient"
        );
        for (name, param) in [("scale", norm.gamma.as_ref().unwrap()), ("shift", norm.beta.as_ref().unwrap())] {
            let grad = |g| values(param.val().grad(g).unwrap());
            assert!(worst(grad(&g_ours), grad(&g_burn)) < 1e-4, "{name} gradient");
        }

        let plain_device = crate::backend::device();
        let plain = InstanceNormConfig::new(3).init(&plain_device);
        let hp = Tensor::<4>::random([1, 6, 4, 4], Distribution::Uniform(-2.0, 2.0), &plain_device);
        assert!(worst(values(gated_norm(hp.clone(), &plain, 0.2)), values(composed(hp, &plain, 0.2))) < 1e-5);
    }
}
