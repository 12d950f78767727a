//! A global search over limb rotations before the local vertex refinement: a limb whose drawn
//! place does not overlap where the network put it (an arm raised 90° in a pose no training
//! frame showed) gives the image loss no gradient towards it, so descent alone leaves it there.
//! Walking the layer tree from the root, each layer and everything hanging from it is turned
//! about its joint through a fan of angles, and the turn that draws the frame best is kept.
//! Rigid turns about a joint cost nothing in ARAP and keep the joint welded.

use crate::error::Result;
use crate::metrics::{l2, l2_squared};
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
    /// ±120° in 20° steps, then 10° either side of the best: 14 turns per limb instead of the 24 of
    /// one pass at 10°, for the same fits (coarser steps or narrower and wider ranges fitted worse:
    /// docs/results.md "The coarse-then-fine limb search").
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
        let scorer = CrispScorer::new(raster, puppet, frame);
        let start = scorer.full(pose)?[0];
        let mut best = start;
        for (k, limb) in limbs(puppet).into_iter().enumerate() {
            let now = ranges.map(|r| r.turns(pose)[k]);
            let allowed = |degrees: f32| match (ranges, now) {
                (Some(r), Some(now)) => r.excess(k, now + degrees.to_radians()) <= r.excess(k, now),
                _ => true,
            };
            // The best of a fan of turns (degrees) with its score, if any beats `beat`.
            let current = best;
            let best_of = |angles: &[f32], beat: f64| -> Result<Option<(f64, f32)>> {
                let angles: Vec<f32> = angles.iter().copied().filter(|&a| allowed(a)).collect();
                if angles.is_empty() {
                    return Ok(None);
                }
                let angles = angles.as_slice();
                let tries: Vec<[f32; 2]> = angles.iter().flat_map(|&a| turned(pose, &limb, a.to_radians(), map)).collect();
                let found = scorer
                    .around(pose, current, &tries)?
                    .into_iter()
                    .zip(angles.iter().copied())
                    .min_by(|x, y| x.0.total_cmp(&y.0));
                Ok(found.filter(|&(score, _)| score < beat))
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

/// Scores poses of a puppet by the L2 (DESIGN.md) of their crisp renders to a frame.
pub(super) struct CrispScorer<'a> {
    raster: &'a SoftRasterizer,
    frame: &'a Picture,
    /// Where each layer's vertices start in the global numbering, and the total last.
    offsets: Vec<usize>,
}

impl<'a> CrispScorer<'a> {
    /// Scores poses of `puppet` (rendered by `raster`) against `frame`.
    pub(super) fn new(raster: &'a SoftRasterizer, puppet: &Puppet, frame: &'a Picture) -> Self {
        CrispScorer {
            raster,
            frame,
            offsets: puppet.vertex_offsets(),
        }
    }

    /// The L2 of each pose in `poses` (concatenated, global numbering), rendered in one batch.
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`].
    pub(super) fn full(&self, poses: &[[f32; 2]]) -> Result<Vec<f64>> {
        let (w, h) = (self.frame.width, self.frame.height);
        Ok(self
            .render(poses, [0, 0, w, h])?
            .into_iter()
            .map(|render| l2(&render, self.frame))
            .collect())
    }

    /// The L2 of each pose in `candidates` (concatenated) that differs from `base`, whose L2 is
    /// `base_l2`, only in some layers. Only the window those layers cover in any of the poses is
    /// rendered (with every layer): pixels elsewhere are the base's, and the L2 is a sum over
    /// pixels. A limb covers a small part of the frame, so a search over its turns renders few
    /// pixels.
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`].
    pub(super) fn around(&self, base: &[[f32; 2]], base_l2: f64, candidates: &[[f32; 2]]) -> Result<Vec<f64>> {
        let n = base.len().max(1);
        let count = candidates.len() / n;
        // The layers some candidate moves, and the box their vertices span in any pose.
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for w in self.offsets.windows(2) {
            let range = w[0]..w[1];
            let moved = candidates.chunks_exact(n).any(|c| c[range.clone()] != base[range.clone()]);
            if moved {
                for p in candidates
                    .chunks_exact(n)
                    .flat_map(|c| &c[range.clone()])
                    .chain(&base[range.clone()])
                {
                    for a in 0..2 {
                        (lo[a], hi[a]) = (lo[a].min(p[a]), hi[a].max(p[a]));
                    }
                }
            }
        }
        // Two pixels of margin for the edges' antialiasing.
        let (w, h) = (self.frame.width, self.frame.height);
        let clamp = |v: f32, size: u32| v.clamp(0.0, size as f32) as u32;
        let (x0, y0) = (clamp((lo[0] - 2.0).floor(), w), clamp((lo[1] - 2.0).floor(), h));
        let (x1, y1) = (clamp((hi[0] + 2.0).ceil(), w), clamp((hi[1] + 2.0).ceil(), h));
        if x1 <= x0 || y1 <= y0 {
            return Ok(vec![base_l2; count]);
        }
        let window = [x0, y0, x1 - x0, y1 - y0];
        let target = self.frame.crop(x0, y0, x1 - x0, y1 - y0);
        let mut poses = base.to_vec();
        poses.extend_from_slice(candidates);
        let sums: Vec<f64> = self
            .render(&poses, window)?
            .iter()
            .map(|render| l2_squared(render, &target))
            .collect();
        Ok(sums[1..]
            .iter()
            .map(|s| (base_l2 * base_l2 - sums[0] + s).max(0.0).sqrt())
            .collect())
    }

    /// The crisp renders of `poses` (concatenated) inside `window` (`[x0, y0, width, height]` of
    /// the frame), in one batch.
    fn render(&self, poses: &[[f32; 2]], window: [u32; 4]) -> Result<Vec<Picture>> {
        let [x0, y0, w, h] = window;
        let params = Params {
            sigma: 0.0,
            background: Background::Transparent,
            ..Params::default()
        };
        let flat: Vec<f32> = poses.iter().flat_map(|p| [p[0] - x0 as f32, p[1] - y0 as f32]).collect();
        let count = poses.len() / self.offsets.last().copied().unwrap_or(0).max(1);
        let frames = self.raster.forward(&flat, count, w as usize, h as usize, &params)?;
        Ok(frames
            .image
            .chunks_exact(4 * (w * h) as usize)
            .map(|image| straight_picture(image, w, h))
            .collect())
    }
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
        let worst = crate::test_util::largest_distance(&pose, &rest);
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
        let free = search(None);
        assert!((free - 60.0).abs() < 1e-3, "free, the search finds the drawn turn, not {free}°");
        // Held to rest ± 25°: the fan's turns of 20° and 30° either side of it, not beyond.
        let held = search(Some(&JointRanges::from_poses(&puppet, std::slice::from_ref(&rest), 25.0)));
        assert!((held - 20.0).abs() < 1e-3, "held to ±25°, the search stops at {held}°");
    }

    #[test]
    fn scores_rendered_in_the_window_of_what_moves_equal_those_of_whole_frames() {
        let puppet = hinged_puppet();
        let rest = puppet.rest_vertices();
        let limb = &limbs(&puppet)[0];
        let frame = render_crisp(&puppet, &turned(&rest, limb, 0.4, None), 48, 40).unwrap();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let scorer = CrispScorer::new(&raster, &puppet, &frame);
        let base = turned(&rest, limb, -0.3, None);
        let base_l2 = scorer.full(&base).unwrap()[0];
        let candidates: Vec<[f32; 2]> = [-1.0f32, 0.1, 0.3, 0.7, 2.5]
            .iter()
            .flat_map(|&a| turned(&base, limb, a, None))
            .collect();
        let whole = scorer.full(&candidates).unwrap();
        let windowed = scorer.around(&base, base_l2, &candidates).unwrap();
        for (a, b) in whole.iter().zip(&windowed) {
            assert!((a - b).abs() <= 1e-6 * a.max(1.0), "whole frame {a}, window {b}");
        }
        assert!(whole.iter().any(|&s| (s - base_l2).abs() > 1.0), "the turns change the score");
        // Nothing moved: the base's score, nothing rendered.
        assert_eq!(scorer.around(&base, base_l2, &base).unwrap(), vec![base_l2]);
    }

    fn search_with(raster: &SoftRasterizer, puppet: &Puppet, ranges: Option<&JointRanges>, frame: &Picture, pose: &mut [[f32; 2]]) {
        LimbSearch::default().improve(raster, puppet, None, ranges, frame, pose).unwrap();
    }
}
