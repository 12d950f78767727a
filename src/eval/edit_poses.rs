//! The poses a user makes from fitted frames, for scoring a dressed puppet's accessories beyond
//! the fits themselves (issue 14: occlusion kept "over every held-out fit, in-between and
//! drag"): in-betweens of consecutive frames, and seeded drags of body points.

use burn::tensor::{Device, Tensor};

use crate::edit::inbetween::Interpolator;
use crate::edit::pin::Pin;
use crate::edit::pose::{PoseEditor, PoseOptions};
use crate::error::Result;
use crate::fit::FitOptions;
use crate::model::Model;
use crate::picture::Picture;
use crate::puppet::LayerKind;
use crate::rng::Rng;

/// Where the in-betweens of each pair of consecutive frames are taken.
pub const INBETWEEN_T: [f32; 3] = [0.25, 0.5, 0.75];

/// Frames of each drag (the pins move along a straight line to their targets).
pub const DRAG_FRAMES: usize = 4;

/// How far each pin is dragged, as a fraction of the larger frame side.
pub const DRAG_REACH: f32 = 0.08;

/// In-betweens of every pair of consecutive fitted frames at t = ¼, ½, ¾, on the default path
/// through their fits (frame pixels): `latents` `[N, Z]` and `fits` as
/// [`crate::fit::fit_with_latents`] returns them.
pub fn inbetween_poses(model: &Model, latents: &Tensor<2>, fits: &[Vec<[f32; 2]>], device: &Device) -> Vec<Vec<[f32; 2]>> {
    let mut out = Vec::new();
    for k in 1..fits.len() {
        let interpolator = Interpolator::between(model, latents.clone().narrow(0, k - 1, 1), latents.clone().narrow(0, k, 1), device)
            .with_keys([fits[k - 1].clone(), fits[k].clone()]);
        out.extend(interpolator.keyed_poses(model, &INBETWEEN_T, device));
    }
    out
}

/// For each frame, a drag of two pins on two body layers other than the root (picked with
/// `seed`), each moved [`DRAG_REACH`] of the frame in a random direction over [`DRAG_FRAMES`]
/// frames (default drag options): every frame of every drag (frame pixels).
///
/// # Errors
/// As [`PoseEditor::new`] and [`PoseEditor::drag_along`].
pub fn drag_poses(model: &Model, frames: &[&Picture], fit: &FitOptions, device: &Device, seed: u64) -> Result<Vec<Vec<[f32; 2]>>> {
    let puppet = &model.puppet;
    let offsets = puppet.vertex_offsets();
    let body: Vec<usize> = (0..puppet.layers.len())
        .filter(|&l| puppet.layers[l].kind == LayerKind::Body && l != puppet.root && !puppet.layers[l].mesh.vertices.is_empty())
        .collect();
    if body.is_empty() {
        return Ok(Vec::new());
    }
    let reach = DRAG_REACH * puppet.width.max(puppet.height) as f32;
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    for frame in frames {
        let mut editor = PoseEditor::new(model, frame, fit, device)?;
        let pins: Vec<Pin> = (0..2.min(body.len()))
            .map(|_| {
                let layer = body[rng.below(body.len())];
                let count = puppet.layers[layer].mesh.vertices.len();
                let from = editor.fitted()[offsets[layer] + rng.below(count)];
                let angle = rng.range(0.0, std::f32::consts::TAU);
                Pin {
                    from,
                    to: [from[0] + reach * angle.cos(), from[1] + reach * angle.sin()],
                }
            })
            .collect();
        let sources: Vec<[f32; 2]> = pins.iter().map(|p| p.from).collect();
        editor.set_pins(&sources)?;
        out.extend(
            editor
                .drag_along(&pins, DRAG_FRAMES, &PoseOptions::default())?
                .into_iter()
                .map(|(d, _)| d.vertices),
        );
    }
    Ok(out)
}
