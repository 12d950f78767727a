//! Where editing a frame the network was never shown starts (the prior in the editor). Drags
//! move a latent (neural-puppet.md eq. 7–9), and the prior's zero-shot fit of a frame is
//! vertices; so that fit is pulled onto the learned manifold as a retargeted pose is — the
//! encoder's latent of its render, then drag steps with the body's vertices pinned to it — and
//! the latent steps of a fit follow. The frame is then edited from whichever of that latent and
//! the network's own latent fit decodes to a pose that renders closer to it.

use burn::tensor::{Device, Tensor};

use super::pose::{body_pins, PoseEditor, PoseOptions};
use crate::error::Result;
use crate::fit::{fit_latents, refine_latents, FitOptions};
use crate::metrics::l2;
use crate::model::Model;
use crate::picture::Picture;
use crate::prior::{fit_untrained, Start, TrainedNet};
use crate::progress::Silent;
use crate::render::render_crisp;

/// Drag steps that pull the prior's fit onto the manifold by default: more than a retargeted
/// frame's 3, as a frame is pulled once and from the encoder's reading of a pose it may not
/// know (docs/results.md "The prior in the editor" measured 3, 10 and 30).
pub const PULL_STEPS: usize = 30;

/// Which start [`starting_latent`] kept, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartChoice {
    /// The start kept.
    pub start: Start,
    /// The crisp L2 to the frame of the network's latent fit's pose.
    pub network_l2: f64,
    /// The crisp L2 to the frame of the pose of the prior's fit pulled onto the manifold.
    pub prior_l2: f64,
}

/// The latent to edit `frame` from (module doc): the network's latent fit (`options`' latent
/// steps) or the prior's zero-shot fit (`zero_shot`'s latent-free stages) pulled onto `model`'s
/// manifold by `pull`'s drag steps and refined by `options`' latent steps, whichever decodes
/// closer to the frame. Returns the latent `[1, Z]` kept.
///
/// # Errors
/// As [`fit_latents`], [`fit_untrained`] (a frame of another size), [`render_crisp`] and
/// [`PoseEditor::drag`] (`pull` out of range).
pub fn starting_latent(
    prior: &TrainedNet,
    model: &Model,
    frame: &Picture,
    options: &FitOptions,
    zero_shot: &FitOptions,
    pull: &PoseOptions,
    device: &Device,
) -> Result<(Tensor<2>, StartChoice)> {
    let (w, h) = (model.puppet.width, model.puppet.height);
    let network = fit_latents(model, &[frame], options, device)?;
    let fitted = fit_untrained(prior, model, &[frame], zero_shot, device, &Silent)?.concat();
    let drawn = render_crisp(&model.puppet, &fitted, w, h)?;
    let mut editor = PoseEditor::at(model, model.encode(&[&drawn], device)?, device)?;
    let pins = body_pins(&model.puppet);
    editor.pin_vertices(&pins)?;
    let targets: Vec<[f32; 2]> = pins.iter().map(|&v| fitted[v]).collect();
    editor.drag(&targets, pull)?;
    let pulled = refine_latents(model, &[frame], editor.latent().clone(), options, device)?;
    let score = |z: &Tensor<2>| -> Result<f64> {
        let pose = model.to_frame_vertices(model.decode(z.clone(), device)).concat();
        Ok(l2(&render_crisp(&model.puppet, &pose, w, h)?, frame))
    };
    let (network_l2, prior_l2) = (score(&network)?, score(&pulled)?);
    let (latent, start) = if prior_l2 < network_l2 {
        (pulled, Start::Prior)
    } else {
        (network, Start::Network)
    };
    Ok((
        latent,
        StartChoice {
            start,
            network_l2,
            prior_l2,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::test_support::small_model;
    use crate::error::Error;

    #[test]
    fn the_network_start_is_the_plain_latent_fit_and_a_frame_of_another_size_is_refused() {
        let (model, device) = small_model(0.3);
        let prior = crate::prior::shipped(&device).unwrap();
        let raised: Vec<[f32; 2]> = model.puppet.rest_vertices().iter().map(|v| [v[0], v[1] - 3.0]).collect();
        let frame = render_crisp(&model.puppet, &raised, 48, 40).unwrap();
        let options = FitOptions {
            latent_steps: 4,
            vertex_steps: 0,
            ..FitOptions::default()
        };
        let zero_shot = FitOptions {
            vertex_steps: 5,
            ..options.clone()
        };
        let pull = PoseOptions {
            steps: 3,
            ..PoseOptions::default()
        };
        let (latent, choice) = starting_latent(&prior, &model, &frame, &options, &zero_shot, &pull, &device).unwrap();
        let plain = fit_latents(&model, &[&frame], &options, &device).unwrap();
        let drawn = |z: Tensor<2>| {
            let pose = model.to_frame_vertices(model.decode(z, &device)).concat();
            l2(&render_crisp(&model.puppet, &pose, 48, 40).unwrap(), &frame)
        };
        assert!((drawn(plain) - choice.network_l2).abs() < 1e-6 * choice.network_l2.max(1.0));
        assert_eq!(drawn(latent), choice.network_l2.min(choice.prior_l2));
        assert_eq!(choice.start == Start::Prior, choice.prior_l2 < choice.network_l2);

        let wide = Picture::filled(50, 40, [0.0; 4]);
        let refused = starting_latent(&prior, &model, &wide, &options, &zero_shot, &pull, &device);
        assert!(matches!(refused, Err(Error::Mismatch { .. })), "{refused:?}");
    }
}
