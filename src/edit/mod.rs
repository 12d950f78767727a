//! What users do with a trained puppet (neural-puppet.md §4.1–4.3): in-betweens by latent
//! interpolation ([`mod@inbetween`]), poses dragged into place by optimising the latent under pins
//! ([`pose`], eq. 7–9, with the direct vertex-space ARAP drag of Figure 6 right beside it in
//! [`mod@arap_drag`]), and frame-to-frame correspondences through the fitted template
//! ([`mod@correspond`], scored by [`crate::eval::pck_pairs`] on synthetic ground truth). Points are
//! tied to the mesh by barycentric coordinates ([`mod@bind`]).

pub mod arap_drag;
pub mod bind;
pub mod correspond;
pub mod inbetween;
pub mod pin_overlay;
pub mod pose;

pub use arap_drag::arap_drag;
pub use bind::{bind, Binding};
pub use correspond::{correspond, Correspondence};
pub use inbetween::{inbetween, nearest_frame, Inbetweens, Interpolator};
pub use pose::{Pin, PoseEditor, PoseOptions};

/// Helpers shared by this module's unit tests.
#[cfg(test)]
pub(crate) mod test_support {
    use burn::module::{Module, ModuleMapper, Param};
    use burn::tensor::{Distribution, Tensor};

    use crate::model::deformation::DeformationNet;

    /// Replaces every all-zero weight tensor (the decoder's last layer, which starts at zero so
    /// an untrained net predicts the rest pose) by uniform noise in `[-scale, scale]`, so that
    /// poses depend on the latent.
    pub fn randomise_last_layer(net: DeformationNet, scale: f64) -> DeformationNet {
        struct Noise(f64);
        impl ModuleMapper for Noise {
            fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
                let scale = self.0;
                param.map(|t| {
                    let zero = t.clone().abs().max().into_scalar::<f32>() == 0.0;
                    if zero {
                        Tensor::random(t.shape(), Distribution::Uniform(-scale, scale), &t.device())
                    } else {
                        t
                    }
                })
            }
        }
        net.map(&mut Noise(scale))
    }
}
