//! Placing the limbs a frame hides (issue 19; not in neural-puppet.md). A limb drawn behind other
//! layers — a back arm behind the torso — gets no evidence from the picture: the image loss is
//! flat in its turn for as long as it stays covered, so a fit leaves it wherever the network or
//! the limb search happened to put it, often on the wrong side of the body.
//!
//! What the puppet knows instead is the limb's twin: the other limb hanging from the same layer
//! (or from the twin of its layer) with about its length and area — the front arm for the back
//! arm, the front forearm for the back forearm. In a walk or a run twins swing against each
//! other about a common middle, so the hidden limb's turn is the twin's mirrored: `s − t_twin`,
//! with the sum `s` learned from the training poses that show both. A line with a free slope
//! learned the same way does worse: a limb shows in only part of its swing (a back arm shows
//! when swung back), and a slope fitted on that part extrapolates badly to the part it hides;
//! the mirror's one unknown, the sum, does not depend on which part showed. A pair whose sums
//! spread widely (a waving front arm beside an idle back one) is not mirrored.
//!
//! After a fit, each limb its frame hides whose twin shows is turned to the turn nearest the
//! mirrored one at which the crisp render stays as close to the frame (L2 within a slack): the
//! frame still decides wherever it has a say.

use crate::error::Result;
use crate::picture::Picture;
use crate::puppet::limbs::{circular_mean, wrap, Limb, LimbTurns};
use crate::puppet::visibility::visible_vertices;
use crate::puppet::Puppet;
use crate::render::soft_raster::SoftRasterizer;
use crate::rig::deform::RigMap;

use super::limb_search::{turned, CrispScorer};

/// A limb shows when at least this share of its vertices (its layer's and those hanging from it)
/// is visible.
const SHOWN: f64 = 0.5;

/// A limb is hidden when at most this share of its vertices is visible.
const HIDDEN: f64 = 0.2;

/// Training poses showing both twins needed to learn their sum.
const MIN_POSES: usize = 5;

/// Twins whose sum of turns spreads more than this over the training poses (radians, 15°, the
/// root-mean-square about its mean) do not mirror each other.
const MIRROR_SPREAD: f32 = 0.26;

/// Twins differ in length and in area by at most this factor.
const TWIN_RATIO: f32 = 1.4;

/// The spacing of the turns tried (degrees).
const STEP_DEGREES: f32 = 2.5;

/// How much the crisp L2 may rise as a hidden limb is turned, relative to the fit's, unless asked
/// otherwise.
pub const DEFAULT_SLACK: f64 = 0.005;

/// A limb's twin and the sum of their turns (radians) in the training poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    /// The twin (index into [`crate::puppet::limbs::limbs`]).
    pub twin: usize,
    /// The circular mean of the two turns' sum.
    pub sum: f32,
    /// The root-mean-square of the sums about it.
    pub spread: f32,
}

/// What places a fit's hidden limbs: each limb's mirror, if it has a twin that mirrors it.
#[derive(Clone, Debug, PartialEq)]
pub struct HiddenLimbs {
    turns: LimbTurns,
    mirrors: Vec<Option<Mirror>>,
    /// How much the crisp L2 may rise, relative to the fit's.
    slack: f64,
}

/// The share of each limb's vertices (its layer's and those of every layer hanging from it: all
/// that its turn places) that `pose` (global numbering) shows.
fn shown_shares(turns: &LimbTurns, puppet: &Puppet, pose: &[[f32; 2]]) -> Vec<f64> {
    let visible = visible_vertices(puppet, pose);
    turns
        .limbs()
        .iter()
        .map(|l| l.vertices.iter().filter(|&&v| visible[v]).count() as f64 / l.vertices.len().max(1) as f64)
        .collect()
}

/// Each limb's twin (index into `limbs`), paired parents first: a limb whose parent layer is
/// another's, or the twin of another's, with a length (farthest rest vertex of its own layer from
/// the pivot) and an area within a factor 1.4 of each other; the closest in both, if each is
/// the other's closest.
pub fn twins(puppet: &Puppet, limbs: &[Limb]) -> Vec<Option<usize>> {
    let offsets = puppet.vertex_offsets();
    let rest = puppet.rest_vertices();
    let size = |l: &Limb| -> (f32, f32) {
        let pivot = rest[l.pivot];
        let own = &rest[offsets[l.layer]..offsets[l.layer + 1]];
        let length = own.iter().map(|p| (p[0] - pivot[0]).hypot(p[1] - pivot[1])).fold(0.0, f32::max);
        (length, puppet.layers[l.layer].mesh.area())
    };
    let sizes: Vec<(f32, f32)> = limbs.iter().map(size).collect();
    let mut twin = vec![None; limbs.len()];
    let layer_twin = |twin: &[Option<usize>], layer: usize| -> Option<usize> {
        let k = limbs.iter().position(|l| l.layer == layer)?;
        twin[k].map(|j: usize| limbs[j].layer)
    };
    // The mismatch of two limbs' sizes (0 for equal), if they may be twins.
    let mismatch = |twin: &[Option<usize>], k: usize, j: usize| -> Option<f32> {
        let related = limbs[k].parent == limbs[j].parent || layer_twin(twin, limbs[k].parent) == Some(limbs[j].parent);
        let ratio = |a: f32, b: f32| (a.max(1e-6) / b.max(1e-6)).ln().abs();
        let (length, area) = (ratio(sizes[k].0, sizes[j].0), ratio(sizes[k].1, sizes[j].1));
        (k != j && related && length <= TWIN_RATIO.ln() && area <= TWIN_RATIO.ln()).then_some(length + area)
    };
    for k in 0..limbs.len() {
        if twin[k].is_some() {
            continue;
        }
        let closest = |twin: &[Option<usize>], k: usize| -> Option<usize> {
            (0..limbs.len())
                .filter(|&j| twin[j].is_none())
                .filter_map(|j| mismatch(twin, k, j).map(|m| (m, j)))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map(|(_, j)| j)
        };
        if let Some(j) = closest(&twin, k) {
            if closest(&twin, j) == Some(k) {
                twin[k] = Some(j);
                twin[j] = Some(k);
            }
        }
    }
    twin
}

impl HiddenLimbs {
    /// Learns the twins' sums from `poses` (frame pixels, global numbering) of `puppet`, normally
    /// the network's poses of its training frames; `slack` is how much the crisp L2 may rise,
    /// relative to the fit's, as a hidden limb is turned.
    pub fn learn(puppet: &Puppet, poses: &[Vec<[f32; 2]>], slack: f64) -> Self {
        let turns = LimbTurns::new(puppet);
        let measured: Vec<(Vec<f32>, Vec<f64>)> = poses.iter().map(|p| (turns.of(p), shown_shares(&turns, puppet, p))).collect();
        let mirrors = twins(puppet, turns.limbs())
            .into_iter()
            .enumerate()
            .map(|(k, twin)| {
                let twin = twin?;
                let sums: Vec<f32> = measured
                    .iter()
                    .filter(|(_, shown)| shown[k] >= SHOWN && shown[twin] >= SHOWN)
                    .map(|(t, _)| t[k] + t[twin])
                    .collect();
                if sums.len() < MIN_POSES {
                    return None;
                }
                let sum = circular_mean(sums.iter().copied());
                let spread = (sums.iter().map(|&s| wrap(s - sum).powi(2)).sum::<f32>() / sums.len() as f32).sqrt();
                (spread <= MIRROR_SPREAD).then_some(Mirror { twin, sum, spread })
            })
            .collect();
        HiddenLimbs { turns, mirrors, slack }
    }

    /// Limb `k`'s mirror, if it has a twin that mirrors it.
    pub fn mirror(&self, k: usize) -> Option<Mirror> {
        self.mirrors[k]
    }

    /// Where limb `k` goes if `shown` (each limb's share shown) says it is hidden and its twin
    /// shows: its twin's turn in `turns` (each limb's turn now), mirrored.
    fn target(&self, k: usize, shown: &[f64], turns: &[f32]) -> Option<f32> {
        let mirror = self.mirrors[k].filter(|m| shown[k] <= HIDDEN && shown[m.twin] >= SHOWN)?;
        Some(wrap(mirror.sum - turns[mirror.twin]))
    }

    /// Turns each limb `pose` hides, parents first, to the turn nearest its mirrored twin's at
    /// which the crisp render of `pose` stays within the slack of its L2 to `frame`. With a rig's
    /// `map`, accessories follow. Returns how many limbs moved.
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`].
    pub fn place(
        &self,
        raster: &SoftRasterizer,
        puppet: &Puppet,
        map: Option<&RigMap>,
        frame: &Picture,
        pose: &mut [[f32; 2]],
    ) -> Result<usize> {
        let limbs = self.turns.limbs();
        let mut shown = shown_shares(&self.turns, puppet, pose);
        let scorer = CrispScorer::new(raster, puppet, frame);
        let mut base = scorer.full(pose)?[0];
        let mut moved = 0;
        // Twice over, as a limb placed later can free its parent's turn.
        for (k, limb) in limbs.iter().enumerate().chain(limbs.iter().enumerate()) {
            let now = self.turns.of(pose);
            let Some(target) = self.target(k, &shown, &now) else {
                continue;
            };
            let delta = wrap(target - now[k]);
            if delta.abs().to_degrees() < STEP_DEGREES / 2.0 {
                continue;
            }
            // Turns from the mirrored one back towards the fitted one, nearest the mirrored first:
            // the frame cannot tell hidden turns apart, so the nearest that keeps the render
            // wins, even across a turn that would show.
            let reach = (delta.abs().to_degrees() / STEP_DEGREES).floor() as i32;
            let mut angles = vec![delta];
            for j in 1..=reach {
                let off = (j as f32 * STEP_DEGREES).to_radians();
                if off < delta.abs() {
                    angles.extend([delta + off, delta - off]);
                }
            }
            let tries: Vec<[f32; 2]> = angles.iter().flat_map(|&a| turned(pose, limb, a, map)).collect();
            let scores = scorer.around(pose, base, &tries)?;
            let Some(taken) = scores.iter().position(|&s| s <= base * (1.0 + self.slack)) else {
                continue;
            };
            pose.copy_from_slice(&turned(pose, limb, angles[taken], map));
            base = scores[taken];
            shown = shown_shares(&self.turns, puppet, pose);
            moved += 1;
        }
        Ok(moved)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::puppet::limbs::limbs;
    use crate::render::render_crisp;
    use crate::test_util::{rect_layer, weld};

    /// A torso with two arms hanging from its middle (back arm behind it, front arm in front),
    /// each a long thin bar that turns about the shoulder.
    fn two_armed() -> Puppet {
        let size = (60, 60);
        let colour = |c: [f32; 3]| move |_: f32, _: f32| c;
        let mut puppet = Puppet {
            width: size.0,
            height: size.1,
            layers: vec![
                rect_layer("back arm", size, [27.0, 20.0, 33.0, 50.0], (2, 6), colour([0.9, 0.2, 0.2])),
                rect_layer("torso", size, [21.0, 14.0, 39.0, 56.0], (4, 6), colour([0.2, 0.5, 0.9])),
                rect_layer("front arm", size, [27.0, 20.0, 33.0, 50.0], (2, 6), colour([0.2, 0.8, 0.3])),
            ],
            root: 1,
            joints: Vec::new(),
            rig: None,
        };
        weld(&mut puppet, 1, 0, [30.0, 20.0]);
        weld(&mut puppet, 1, 2, [30.0, 20.0]);
        puppet
    }

    /// The arms turned by `front` and `back` degrees.
    fn posed(puppet: &Puppet, front: f32, back: f32) -> Vec<[f32; 2]> {
        let mut pose = puppet.rest_vertices();
        for limb in limbs(puppet) {
            let degrees = if limb.layer == 2 { front } else { back };
            limb.turn(&mut pose, degrees.to_radians());
        }
        pose
    }

    #[test]
    fn a_hidden_arm_swings_against_the_front_one_as_in_the_training_poses_but_never_into_view() {
        let puppet = two_armed();
        let turns = LimbTurns::new(&puppet);
        let back = turns.limbs().iter().position(|l| l.layer == 0).unwrap();
        // Training poses: the arms swing in antiphase, wide enough that both show.
        let poses: Vec<Vec<[f32; 2]>> = [-80.0f32, -70.0, -60.0, 60.0, 70.0, 80.0]
            .iter()
            .map(|&a| posed(&puppet, a, -a))
            .collect();
        let hidden = HiddenLimbs::learn(&puppet, &poses, DEFAULT_SLACK);
        let front = turns.limbs().iter().position(|l| l.layer == 2).unwrap();
        assert_eq!(twins(&puppet, turns.limbs())[back], Some(front));
        let mirror = hidden.mirror(back).unwrap();
        assert_eq!(mirror.twin, front);
        assert!(
            mirror.sum.abs() < 1e-3 && mirror.spread < 1e-3,
            "the arms swing against each other about rest: {mirror:?}"
        );

        // A frame with the front arm 10° out and the back arm 10° the other way, hidden behind the
        // torso; the fit left the back arm at rest (hidden too, so the frame cannot tell).
        let frame = render_crisp(&puppet, &posed(&puppet, 10.0, -10.0), 60, 60).unwrap();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let mut pose = posed(&puppet, 10.0, 0.0);
        let moved = hidden.place(&raster, &puppet, None, &frame, &mut pose).unwrap();
        assert_eq!(moved, 1);
        let placed = turns.of(&pose)[back].to_degrees();
        assert!((placed + 10.0).abs() < 1e-2, "the back arm placed at {placed}°, −10° mirrored");

        // A frame whose back arm is hidden but turned only −5°: −70° would not be (the torso is
        // only so wide), so the walk stops where the bar would start to show.
        let frame = render_crisp(&puppet, &posed(&puppet, 70.0, -5.0), 60, 60).unwrap();
        let mut pose = posed(&puppet, 70.0, 0.0);
        let before = crate::metrics::l2(&render_crisp(&puppet, &pose, 60, 60).unwrap(), &frame);
        hidden.place(&raster, &puppet, None, &frame, &mut pose).unwrap();
        let after = crate::metrics::l2(&render_crisp(&puppet, &pose, 60, 60).unwrap(), &frame);
        let placed = turns.of(&pose)[back].to_degrees();
        assert!(placed < -2.0 && placed > -20.0, "moved towards −70° but stopped short: {placed}°");
        assert!(after <= before * (1.0 + DEFAULT_SLACK) + 1e-9, "L2 {before} → {after}");

        // Poses in which the arms turn independently teach no mirror.
        let random: Vec<Vec<[f32; 2]>> = [
            (-70.0, 60.0),
            (60.0, 70.0),
            (-65.0, -80.0),
            (80.0, -70.0),
            (65.0, 75.0),
            (-60.0, -65.0),
        ]
        .iter()
        .map(|&(f, b)| posed(&puppet, f, b))
        .collect();
        assert_eq!(HiddenLimbs::learn(&puppet, &random, DEFAULT_SLACK).mirror(back), None);
    }

    #[test]
    fn a_fit_without_vertex_steps_places_hidden_limbs_too() {
        let puppet = two_armed();
        // Untrained, the decoder's last layer is zero: every fit decodes the rest pose.
        let (model, device) = crate::test_util::untrained_model(puppet.clone(), 16);
        // Training poses whose two turns sum to −10°, so from rest the back arm's mirror is −10°,
        // still behind the torso.
        let poses: Vec<Vec<[f32; 2]>> = [-80.0f32, -70.0, -60.0, 60.0, 70.0, 80.0]
            .iter()
            .map(|&a| posed(&puppet, a, -10.0 - a))
            .collect();
        let frame = render_crisp(&puppet, &posed(&puppet, 0.0, -10.0), 60, 60).unwrap();
        let turns = LimbTurns::new(&puppet);
        let back = turns.limbs().iter().position(|l| l.layer == 0).unwrap();
        let back_turn = |options: &crate::fit::FitOptions| {
            let pose = crate::fit::fit(&model, &[&frame], options, &device, &crate::progress::Silent).unwrap();
            turns.of(&pose[0])[back].to_degrees()
        };
        let one_pass = crate::fit::FitOptions::one_pass();
        let placed = crate::fit::FitOptions {
            hidden_limbs: Some(HiddenLimbs::learn(&puppet, &poses, DEFAULT_SLACK)),
            ..one_pass.clone()
        };
        assert!(back_turn(&one_pass).abs() < 0.1, "the network's pass leaves the arm at rest");
        let turned = back_turn(&placed);
        assert!((turned + 10.0).abs() < 0.1, "placed at {turned}°, −10° mirrored");
    }

    #[test]
    fn twins_pair_limbs_of_one_parent_by_size_and_leave_an_odd_one_alone() {
        let size = (80, 80);
        let grey = |_: f32, _: f32| [0.5; 3];
        let mut puppet = Puppet {
            width: size.0,
            height: size.1,
            layers: vec![
                rect_layer("b", size, [30.0, 20.0, 34.0, 44.0], (2, 6), grey),
                rect_layer("d", size, [28.0, 50.0, 38.0, 62.0], (3, 3), grey),
                rect_layer("t", size, [24.0, 14.0, 48.0, 56.0], (4, 6), grey),
                rect_layer("x", size, [44.0, 28.0, 52.0, 36.0], (3, 3), grey),
                rect_layer("c", size, [36.0, 50.0, 46.0, 63.0], (3, 3), grey),
                rect_layer("a", size, [38.0, 20.0, 42.0, 45.0], (2, 6), grey),
            ],
            root: 2,
            joints: Vec::new(),
            rig: None,
        };
        for (layer, at) in [
            (0, [32.0, 20.0]),
            (1, [33.0, 50.0]),
            (3, [44.0, 32.0]),
            (4, [41.0, 50.0]),
            (5, [40.0, 20.0]),
        ] {
            weld(&mut puppet, 2, layer, at);
        }
        let limbs = limbs(&puppet);
        let twin_layers: Vec<(usize, Option<usize>)> = limbs
            .iter()
            .zip(twins(&puppet, &limbs))
            .map(|(l, t)| (l.layer, t.map(|j| limbs[j].layer)))
            .collect();
        for (layer, twin) in [(0, Some(5)), (5, Some(0)), (1, Some(4)), (4, Some(1)), (3, None)] {
            assert!(twin_layers.contains(&(layer, twin)), "layer {layer}: {twin_layers:?}");
        }
    }
}
