//! The ARAP energy (neural-puppet.md §3.2 eq. 2) as a differentiable Burn operation, so it can
//! regularise the network's predicted vertices during training and the latent search of §4.2.
//!
//! Forward and gradient both come from [`ArapEnergy::energy_and_gradient`] (best-fit rotations
//! in closed form; by the envelope theorem the rotations' own dependence on the vertices drops
//! out of the gradient), computed once in the forward pass and scaled by `dL/dE_b` in backward.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::ops::FloatTensorOps;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::tensor::{Tensor, TensorData};

use crate::backend::Inner;
use crate::error::{Error, Result};
use crate::geom::arap::ArapEnergy;
use crate::render::burn_op::host;

/// Per-item ARAP energies `[B]` of vertex positions `[B, V, 2]` (in the rest mesh's units
/// squared). Differentiable w.r.t. `vertices` on an autodiff device.
///
/// # Errors
/// [`Error::Mismatch`] if the shape is not `[B, V, 2]` for this mesh, [`Error::Backend`] if the
/// tensor is not on the compiled-in backend.
pub fn arap_loss(vertices: Tensor<3>, energy: &Arc<ArapEnergy<f32>>) -> Result<Tensor<1>> {
    let [batch, v, two] = vertices.dims();
    if v != energy.vertex_count() || two != 2 {
        return Err(Error::mismatch(
            "arap: the vertex tensor",
            format!("[{batch}, {v}, {two}]"),
            format!("[B, {}, 2]", energy.vertex_count()),
        ));
    }
    let evaluate = |values: Vec<f32>| -> Result<(Vec<f32>, Vec<f32>)> {
        let mut gradient = vec![0f32; values.len()];
        let energies = energy.energy_and_gradient(&values, &mut gradient)?;
        Ok((energies, gradient))
    };
    let energies_tensor = |e: Vec<f32>| Inner::float_from_data(TensorData::new(e, [batch]), &Default::default());
    if let Ok(ad) = vertices.clone().try_into_primitive::<Autodiff<Inner>>() {
        let out = match ArapBackward.prepare::<NoCheckpointing>([ad.node()]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => {
                let (energies, gradient) = evaluate(host::<Inner>(ad.primitive().clone()))?;
                prep.finish(Arc::new(Saved { batch, gradient }), energies_tensor(energies))
            }
            OpsKind::UnTracked(prep) => {
                let (energies, _) = evaluate(host::<Inner>(ad.into_primitive()))?;
                prep.finish(energies_tensor(energies))
            }
        };
        Ok(Tensor::from_primitive::<Autodiff<Inner>>(out))
    } else if let Ok(plain) = vertices.try_into_primitive::<Inner>() {
        let (energies, _) = evaluate(host::<Inner>(plain))?;
        Ok(Tensor::from_primitive::<Inner>(energies_tensor(energies)))
    } else {
        Err(Error::backend(
            "arap",
            "the vertex tensor is not on the compiled-in backend (crate::backend::device)",
        ))
    }
}

/// The forward pass's gradients ∂E_b/∂v, `[B, V, 2]` flattened.
#[derive(Debug)]
struct Saved {
    batch: usize,
    gradient: Vec<f32>,
}

#[derive(Debug)]
struct ArapBackward;

impl<B: Backend> Backward<B, 1> for ArapBackward {
    type State = Arc<Saved>;

    fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let [parent] = ops.parents;
        let grad = grads.consume::<B>(&ops.node);
        let Some(parent) = parent else { return };
        let device = grad.device();
        let upstream = host::<B>(grad);
        let s = &ops.state;
        let stride = s.gradient.len() / s.batch;
        let dv: Vec<f32> = s.gradient.iter().enumerate().map(|(i, g)| g * upstream[i / stride]).collect();
        let data = TensorData::new(dv, [s.batch, stride / 2, 2]);
        grads.register::<B>(parent.id, B::float_from_data(data, &device));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{jittered, layered_puppet};

    #[test]
    fn burn_gradient_matches_central_differences_of_the_energy() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let triangles = crate::objective::regularised_triangles(&puppet);
        let energy = Arc::new(ArapEnergy::<f32>::new(&rest, &triangles).unwrap());
        let e64 = ArapEnergy::<f64>::new(&rest.iter().map(|p| [p[0] as f64, p[1] as f64]).collect::<Vec<_>>(), &triangles).unwrap();
        let nv = rest.len();
        let verts: Vec<f32> = [3u64, 4].iter().flat_map(|&s| jittered(&rest, s, 0.8)).map(|x| x as f32).collect();
        let weights = [0.7f32, -1.3];

        let device = crate::backend::train_device();
        let v = Tensor::<3>::from_data(TensorData::new(verts.clone(), [2, nv, 2]), &device).require_grad();
        let w = Tensor::<1>::from_data(TensorData::new(weights.to_vec(), [2]), &device);
        let e = arap_loss(v.clone(), &energy).unwrap();
        let got: Vec<f32> = v.grad(&(e * w).sum().backward()).unwrap().into_data().try_to_vec::<f32>().unwrap();

        let as64 = |b: usize, x: &[f32]| -> Vec<[f64; 2]> {
            (0..nv)
                .map(|i| [x[(b * nv + i) * 2] as f64, x[(b * nv + i) * 2 + 1] as f64])
                .collect()
        };
        let h = 1e-4;
        let mut worst = 0f64;
        for b in 0..2 {
            for k in (0..2 * nv).step_by(7) {
                let mut plus = verts.clone();
                let mut minus = verts.clone();
                plus[b * 2 * nv + k] += h as f32;
                minus[b * 2 * nv + k] -= h as f32;
                let dp = plus[b * 2 * nv + k] as f64 - minus[b * 2 * nv + k] as f64;
                let fd = (e64.energy(&as64(b, &plus)) - e64.energy(&as64(b, &minus))) / dp * weights[b] as f64;
                worst = worst.max((fd - got[b * 2 * nv + k] as f64).abs() / (1.0 + fd.abs()));
            }
        }
        assert!(worst < 2e-3, "relative error {worst}");
        let plain = arap_loss(
            Tensor::from_data(TensorData::new(verts, [2, nv, 2]), &crate::backend::device()),
            &energy,
        )
        .unwrap();
        assert_eq!(plain.dims(), [2]);
    }
}
