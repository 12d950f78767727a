//! A global search over limb rotations before the local vertex refinement: a limb whose drawn
//! place does not overlap where the network put it (an arm raised 90° in a pose no training
//! frame showed) gives the image loss no gradient towards it, so descent alone leaves it there.
//! Walking the layer tree from the root, each layer and everything hanging from it is turned
//! about its joint through a fan of angles, and the turn that draws the frame best is kept.
//! Rigid turns about a joint cost nothing in ARAP and keep the joint welded.

use crate::error::Result;
use crate::metrics::l2;
use crate::picture::Picture;
use crate::puppet::limbs::{limbs, Limb};
use crate::puppet::Puppet;
use crate::render::soft_raster::{Background, Params, SoftRasterizer};
use crate::render::straight_picture;
use crate::rig::deform::RigMap;

use super::plausible::JointRanges;

/// Turns tried for each limb, in degrees either way, and how finely.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbSearch {
    /// The widest turn tried, either way (degrees).
    pub max_degrees: f32,
    /// The spacing of the turns tried first (degrees).
    pub coarse_degrees: f32,
    /// The spacing of the turns then tried about the best coarse one, up to a coarse step either
    /// way (degrees); equal to `coarse_degrees` for one exhaustive pass.
    pub step_degrees: f32,
}

impl Default for LimbSearch {
    /// ±120° in 20° steps, then 10° either side of the best: 14 turns per limb instead of the 24
    /// of one pass at 10°, for the same fits (README: 30° coarse steps lost the robot's raised arm
    /// in its held-out fall frame; ±90° left it down, ±180° settled in a worse minimum).
    fn default() -> Self {
        LimbSearch {
            max_degrees: 120.0,
            coarse_degrees: 20.0,
            step_degrees: 10.0,
        }
    }
}

impl LimbSearch {
    /// Improves `pose` (frame pixels, global numbering) towards `frame` by turning limbs, root
    /// first; keeps a turn only if it lowers the L2 (DESIGN.md) of the crisp render. Returns that
    /// L2 before and after. With a rig's `map`, accessories follow every turned pose; with
    /// `ranges`, a turn that leaves a limb further outside its range than it was is not tried.
    ///
    /// # Errors
    /// [`crate::Error::Mismatch`] if `pose` does not fit the puppet, [`crate::Error::Geometry`] if
    /// it is not finite.
    pub fn improve(
        &self,
        raster: &SoftRasterizer,
        puppet: &Puppet,
        map: Option<&RigMap>,
        ranges: Option<&JointRanges>,
        frame: &Picture,
        pose: &mut [[f32; 2]],
    ) -> Result<(f64, f64)> {
        let fan = |centre: f32, step: f32, widest: f32| -> Vec<f32> {
            let n = (widest / step).floor().max(0.0) as i32;
            (-n..=n)
                .map(|k| centre + k as f32 * step)
                .filter(|&a| a != 0.0 && a.abs() <= self.max_degrees)
                .collect()
        };
        let coarse = fan(0.0, self.coarse_degrees.max(self.step_degrees), self.max_degrees);
        let vertices = pose.len();
        let scores = |poses: &[[f32; 2]]| crisp_scores(raster, frame, poses, vertices);
        let start = scores(pose)?[0];
        let mut best = start;
        for (k, limb) in limbs(puppet).into_iter().enumerate() {
            let now = ranges.map(|r| r.turns(pose)[k]);
            let allowed = |degrees: f32| match (ranges, now) {
                (Some(r), Some(now)) => r.excess(k, now + degrees.to_radians()) <= r.excess(k, now),
                _ => true,
            };
            // The best of a fan of turns (degrees) with its score, if any beats `best`.
            let best_of = |angles: &[f32], best: f64| -> Result<Option<(f64, f32)>> {
                let angles: Vec<f32> = angles.iter().copied().filter(|&a| allowed(a)).collect();
                if angles.is_empty() {
                    return Ok(None);
                }
                let angles = angles.as_slice();
                let tries: Vec<[f32; 2]> = angles.iter().flat_map(|&a| turned(pose, &limb, a.to_radians(), map)).collect();
                let found = scores(&tries)?
                    .into_iter()
                    .zip(angles.iter().copied())
                    .min_by(|x, y| x.0.total_cmp(&y.0));
                Ok(found.filter(|&(score, _)| score < best))
            };
            let mut found = best_of(&coarse, best)?;
            if self.coarse_degrees > self.step_degrees {
                let centre = found.map_or(0.0, |(_, a)| a);
                let fine: Vec<f32> = fan(centre, self.step_degrees, self.coarse_degrees - self.step_degrees / 2.0)
                    .into_iter()
                    .filter(|&a| a != centre)
                    .collect();
                found = best_of(&fine, found.map_or(best, |(s, _)| s))?.or(found);
            }
            if let Some((score, angle)) = found {
                best = score;
                let new = turned(pose, &limb, angle.to_radians(), map);
                pose.copy_from_slice(&new);
            }
        }
        Ok((start, best))
    }
}

/// The L2 (DESIGN.md) to `frame` of the crisp render of each pose in `poses` (concatenated, each
/// `vertices` long), rendered in one batch.
///
/// # Errors
/// As [`SoftRasterizer::forward`].
pub(super) fn crisp_scores(raster: &SoftRasterizer, frame: &Picture, poses: &[[f32; 2]], vertices: usize) -> Result<Vec<f64>> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let params = Params {
        sigma: 0.0,
        background: Background::Transparent,
        ..Params::default()
    };
    let flat: Vec<f32> = poses.iter().flatten().copied().collect();
    let frames = raster.forward(&flat, poses.len() / vertices.max(1), w, h, &params)?;
    Ok(frames
        .image
        .chunks_exact(4 * w * h)
        .map(|image| l2(&straight_picture(image, frame.width, frame.height), frame))
        .collect())
}

/// `pose` with `limb` turned by `angle` radians about its pivot, its accessories placed by `map`.
pub(super) fn turned(pose: &[[f32; 2]], limb: &Limb, angle: f32, map: Option<&RigMap>) -> Vec<[f32; 2]> {
    let mut out = pose.to_vec();
    limb.turn(&mut out, angle);
    if let Some(map) = map {
        map.apply(&mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::render_crisp;
    use crate::test_util::hinged_puppet;

    #[test]
    fn a_turned_limb_is_turned_back_and_the_rest_does_not_move() {
        let puppet = hinged_puppet();
        let rest = puppet.rest_vertices();
        let frame = render_crisp(&puppet, &rest, 48, 40).unwrap();
        let limbs = limbs(&puppet);
        assert!(!limbs.is_empty(), "the test puppet has a joint");
        let limb = &limbs[0];
        let mut pose = turned(&rest, limb, 50f32.to_radians(), None);
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let (before, after) = LimbSearch::default()
            .improve(&raster, &puppet, None, None, &frame, &mut pose)
            .unwrap();
        assert!(
            (before
                - l2(
                    &render_crisp(&puppet, &turned(&rest, limb, 50f32.to_radians(), None), 48, 40).unwrap(),
                    &frame
                ))
            .abs()
                < 1e-3 * before,
            "the search's L2 is DESIGN.md's"
        );
        assert!(after < 0.2 * before, "L2 {before} → {after}");
        let worst = pose
            .iter()
            .zip(&rest)
            .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
            .fold(0.0, f32::max);
        assert!(worst < 1e-3, "the limb should be back at rest: {worst} px off");
    }

    #[test]
    fn the_search_tries_no_turn_past_the_plausible_range() {
        let puppet = hinged_puppet();
        let rest = puppet.rest_vertices();
        let limb = &limbs(&puppet)[0];
        let frame = render_crisp(&puppet, &turned(&rest, limb, 60f32.to_radians(), None), 48, 40).unwrap();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let search = |ranges: Option<&JointRanges>| {
            let mut pose = rest.clone();
            search_with(&raster, &puppet, ranges, &frame, &mut pose);
            JointRanges::from_poses(&puppet, &[], 0.0).turns(&pose)[0].to_degrees()
        };
        assert!((search(None) - 60.0).abs() < 1e-3, "free, the search finds the drawn turn");
        // Held to rest ± 25°: the fan's turns of 20° and 30° either side of it, not beyond.
        let held = search(Some(&JointRanges::from_poses(&puppet, std::slice::from_ref(&rest), 25.0)));
        assert!((held - 20.0).abs() < 1e-3, "held to ±25°, the search stops at {held}°");
    }

    fn search_with(raster: &SoftRasterizer, puppet: &Puppet, ranges: Option<&JointRanges>, frame: &Picture, pose: &mut [[f32; 2]]) {
        LimbSearch::default().improve(raster, puppet, None, ranges, frame, pose).unwrap();
    }
}
