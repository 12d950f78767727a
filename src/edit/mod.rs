//! What users do with a trained puppet (neural-puppet.md §4.1–4.3): in-betweens by latent
//! interpolation ([`mod@inbetween`], along the training frames where they lie between the keyframes:
//! [`manifold_path`]), poses dragged into place by optimising the latent under pins
//! ([`pose`], eq. 7–9, with the direct vertex-space ARAP drag of Figure 6 right beside it in
//! [`mod@arap_drag`]; the training frames' principal latent directions as sliders in
//! [`directions`]), in-betweens timed as animators time them ([`timing`]), and frame-to-frame correspondences through the fitted template
//! ([`mod@correspond`], scored by [`crate::eval::pck_pairs`] on synthetic ground truth), and
//! another figure's motion played by the puppet ([`mod@retarget`]: a BVH skeleton's or another
//! puppet's poses), and the poses worth drawing next ([`mod@suggest`]). Points are tied to the mesh by barycentric coordinates ([`mod@bind`]).

pub mod arap_drag;
pub mod bind;
pub mod correspond;
pub mod directions;
pub mod inbetween;
pub mod manifold_path;
pub mod pin;
pub mod pin_overlay;
pub mod pose;
pub mod prior_start;
pub mod retarget;
pub mod suggest;
pub mod timing;

pub use arap_drag::arap_drag;
pub use bind::{bind, Binding};
pub use correspond::{correspond, Correspondence};
pub use directions::LatentDirections;
pub use inbetween::{inbetween, nearest_frame, InbetweenPath, Inbetweens, Interpolator};
pub use pin::Pin;
pub use pose::{PoseEditor, PoseOptions};
pub use retarget::{retarget, Motion, Retargeted};
pub use timing::{eased_t, spacing_t, Easing};

/// Helpers shared by this module's unit tests (and the web editor's).
#[cfg(test)]
pub(crate) mod test_support {
    use burn::module::{Module, ModuleMapper, Param};
    use burn::tensor::{Device, Distribution, Tensor};

    use crate::model::deformation::{DeformationNet, DeformationNetConfig};
    use crate::model::Model;
    use crate::test_util::layered_puppet;

    /// A small model of the tiny layered character (48 × 40 frames) whose decoder's last layer
    /// is random in `[-scale, scale]` ([`randomise_last_layer`]), so a drag can move it.
    pub fn small_model(scale: f64) -> (Model, Device) {
        let device = crate::backend::device();
        // Seeded: with fresh random weights the fit sometimes missed the pin's point or a latent
        // shift moved it under 0.5 px (1 run in ~10 failed).
        device.seed(7);
        let puppet = layered_puppet();
        let config = DeformationNetConfig::new(puppet.vertex_count())
            .with_input_size(48)
            .with_encoder_hidden([32, 16])
            .with_latent(16)
            .with_decoder_hidden([32, 32]);
        let mut model = Model::new(config, puppet, &device).expect("the tiny character makes a model");
        model.net = randomise_last_layer(model.net, scale);
        (model, device)
    }

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
