//! Placing a character's template on a frame by the prior's correspondences: every few pixels
//! of the rest pose's render, bound to the surface drawn there, lands in the frame by the
//! network; a robust similarity of the root layer's landings puts the body in place, then each limb, root
//! first, turns about its joint by the angle most of its own landings agree on (a limb whose
//! landings agree on none keeps its parent's turn), and the rig places the accessories. This is
//! the rigid start the fit's latent-free stages (limb search, vertex steps, hidden limbs) refine;
//! its parameters are the limb turns those stages search, so joints stay joined.

use burn::tensor::Device;

use super::{landings, Landing};
use crate::error::{Error, Result};
use crate::geom::similarity::{Moments, Similarity};
use crate::parts::learn::TrainedNet;
use crate::picture::Picture;
use crate::posing::truth::{surface_points, LayerCoverage, SurfacePoint};
use crate::puppet::limbs::{limbs, wrap};
use crate::puppet::Puppet;
use crate::render::render_crisp;
use crate::rig::deform::RigMap;
use crate::rng::Rng;

/// Rest pixels sampled along the larger side of the frame (every `side / SAMPLES` pixels).
const SAMPLES: f32 = 64.0;
/// Landings farther than this share of the frame's larger side from where a transform puts
/// their point disagree with it.
const INLIER_SHARE: f32 = 0.04;
/// Two-point similarity guesses tried for the whole figure.
const GUESSES: usize = 300;
/// The fewest landings on the root layer that place the figure by themselves.
const MIN_ROOT_LANDINGS: usize = 8;
/// How closely (radians) a limb's landings must agree on its turn to count together.
const TURN_TOLERANCE: f32 = 0.2;
/// The least share of a limb's landings that must agree on its turn for the limb to take it.
const LEAST_AGREEMENT: f32 = 0.25;

/// What [`place`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Every template vertex in frame pixels (global numbering).
    pub vertices: Vec<[f32; 2]>,
    /// The share of the sampled rest points whose landing agrees with the placement.
    pub agreement: f32,
    /// The limbs (by layer) whose landings agreed on no turn: left at their parent's.
    pub unplaced: Vec<usize>,
}

/// Places `puppet`'s template on `frame` by `net`'s correspondences from its rest render.
///
/// # Errors
/// [`Error::Mismatch`] for a frame of another size than the puppet's; [`Error::Geometry`] for a
/// puppet whose rest pose draws nothing; as [`render_crisp`] for a puppet that cannot be drawn.
pub fn place(net: &TrainedNet, puppet: &Puppet, frame: &Picture, device: &Device) -> Result<Placement> {
    RestPose::new(puppet)?.place(net, frame, device)
}

/// What [`place`] needs of a puppet's rest pose, prepared once for all the frames of a fit:
/// its render, and the sampled points of its surface.
pub struct RestPose<'a> {
    puppet: &'a Puppet,
    picture: Picture,
    bound: Vec<SurfacePoint>,
    points: Vec<[f32; 2]>,
}

impl<'a> RestPose<'a> {
    /// The rest pose of `puppet`.
    ///
    /// # Errors
    /// [`Error::Geometry`] for a puppet whose rest pose draws nothing; as [`render_crisp`] for
    /// a puppet that cannot be drawn.
    pub fn new(puppet: &'a Puppet) -> Result<Self> {
        let rest = puppet.rest_vertices();
        let picture = render_crisp(puppet, &rest, puppet.width, puppet.height)?;
        let bound = rest_samples(puppet)?;
        if bound.is_empty() {
            return Err(Error::geometry(
                "the puppet",
                "draws nothing in its rest pose (every layer transparent) for the prior to match",
            ));
        }
        let points = bound.iter().map(|b| b.on(&rest)).collect();
        Ok(RestPose {
            puppet,
            picture,
            bound,
            points,
        })
    }

    /// [`place`] on `frame`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] for a frame of another size than the puppet's.
    pub fn place(&self, net: &TrainedNet, frame: &Picture, device: &Device) -> Result<Placement> {
        let (w, h) = (self.puppet.width, self.puppet.height);
        if (frame.width, frame.height) != (w, h) {
            return Err(Error::mismatch(
                "the frame's size",
                format!("{}×{}", frame.width, frame.height),
                format!("{w}×{h}, the puppet's"),
            ));
        }
        let landed: Vec<(SurfacePoint, Landing)> = self
            .bound
            .iter()
            .zip(landings(net, &self.picture, frame, &self.points, device))
            .filter_map(|(&b, l)| Some((b, l?)))
            .collect();
        Ok(place_by(self.puppet, &landed))
    }
}

/// Points of the rest pose's surface every `side / SAMPLES` pixels: where the front layer is
/// drawn at a pixel's centre.
///
/// # Errors
/// As [`LayerCoverage::new`] and its labels (a puppet that cannot be drawn).
pub fn rest_samples(puppet: &Puppet) -> Result<Vec<SurfacePoint>> {
    let (w, h) = (puppet.width, puppet.height);
    let rest = puppet.rest_vertices();
    let labels = LayerCoverage::new(puppet)?.labels(&rest, w, h)?;
    let surface = surface_points(puppet, &rest, &labels, w, h);
    let step = (w.max(h) as f32 / SAMPLES).max(1.0) as usize;
    let mut bound = Vec::new();
    for y in (step / 2..h as usize).step_by(step) {
        for x in (step / 2..w as usize).step_by(step) {
            bound.extend(surface[y * w as usize + x]);
        }
    }
    Ok(bound)
}

/// The placement of `puppet` that rest points `landed` where their landings say ([`place`]).
pub fn place_by(puppet: &Puppet, landed: &[(SurfacePoint, Landing)]) -> Placement {
    let tolerance = INLIER_SHARE * puppet.width.max(puppet.height) as f32;
    let mut pose = puppet.rest_vertices();
    // The figure moves as its root layer does; the limbs then turn from there. A puppet whose
    // root layer shows too little to say is moved by all its landings.
    let root: Vec<(SurfacePoint, Landing)> = landed
        .iter()
        .filter(|(b, _)| usize::from(b.layer) == puppet.root)
        .copied()
        .collect();
    let figure = if root.len() >= MIN_ROOT_LANDINGS { &root } else { landed };
    if let Some(figure) = robust_similarity(figure, &pose, tolerance) {
        for p in &mut pose {
            *p = figure.apply(*p);
        }
    }
    let mut unplaced = Vec::new();
    for limb in limbs(puppet) {
        let pivot = pose[limb.pivot];
        let turns: Vec<f32> = landed
            .iter()
            .filter(|(b, _)| usize::from(b.layer) == limb.layer)
            .filter_map(|(b, l)| {
                let p = b.on(&pose);
                let (from, to) = ([p[0] - pivot[0], p[1] - pivot[1]], [l.at[0] - pivot[0], l.at[1] - pivot[1]]);
                // Points at the pivot say nothing about the turn.
                (from[0].hypot(from[1]) > tolerance / 2.0).then(|| wrap(to[1].atan2(to[0]) - from[1].atan2(from[0])))
            })
            .collect();
        match agreed_turn(&turns) {
            Some(turn) => limb.turn(&mut pose, turn),
            None => unplaced.push(limb.layer),
        }
    }
    if let Some(rig) = &puppet.rig {
        RigMap::new(puppet, rig).apply(&mut pose);
    }
    let agreeing = landed.iter().filter(|(b, l)| distance(b.on(&pose), l.at) <= tolerance).count();
    Placement {
        agreement: agreeing as f32 / landed.len().max(1) as f32,
        vertices: pose,
        unplaced,
    }
}

/// The similarity most landings agree with, refitted to them by least squares: RANSAC over
/// two-point guesses, each landing counted by its similarity (a confident match counts more).
/// `None` for fewer than two landings or no guess any agree with.
fn robust_similarity(landed: &[(SurfacePoint, Landing)], pose: &[[f32; 2]], tolerance: f32) -> Option<Similarity> {
    if landed.len() < 2 {
        return None;
    }
    let pairs: Vec<([f32; 2], [f32; 2], f32)> = landed.iter().map(|(b, l)| (b.on(pose), l.at, l.similarity.max(0.0))).collect();
    let agreeing = |s: Similarity| pairs.iter().filter(move |(p, q, _)| distance(s.apply(*p), *q) <= tolerance);
    // Seeded: a frame is always placed the same way.
    let mut rng = Rng::new(0x91ace);
    let mut best: Option<(f32, Similarity)> = None;
    for _ in 0..GUESSES {
        let (i, j) = (rng.below(pairs.len()), rng.below(pairs.len()));
        let Some(guess) = Similarity::fit(&[pairs[i].0, pairs[j].0], &[pairs[i].1, pairs[j].1]) else {
            continue;
        };
        // A guess that shrinks or grows the figure past what a drawing does is no guess.
        if !(0.5..=2.0).contains(&guess.scale()) {
            continue;
        }
        let support: f32 = agreeing(guess).map(|(_, _, c)| c).sum();
        if best.as_ref().is_none_or(|(s, _)| support > *s) {
            best = Some((support, guess));
        }
    }
    let (_, guess) = best?;
    let mut moments = Moments::default();
    for (p, q, _) in agreeing(guess) {
        moments.add(*p, *q);
    }
    moments.fit().or(Some(guess))
}

/// The turn at least [`LEAST_AGREEMENT`] of `turns` agree on within [`TURN_TOLERANCE`] (their
/// circular mean about the most agreed-on one), or `None`.
fn agreed_turn(turns: &[f32]) -> Option<f32> {
    let near = |a: f32, b: f32| wrap(a - b).abs() <= TURN_TOLERANCE;
    let (centre, count) = turns
        .iter()
        .map(|&t| (t, turns.iter().filter(|&&u| near(t, u)).count()))
        .max_by_key(|&(_, n)| n)?;
    if (count as f32) < LEAST_AGREEMENT * turns.len() as f32 || count < 3 {
        return None;
    }
    let offsets = turns.iter().filter(|&&u| near(centre, u)).map(|&u| wrap(u - centre));
    Some(wrap(centre + crate::puppet::limbs::circular_mean(offsets)))
}

fn distance(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::posing::{EngineSettings, PoseEngine};
    use crate::test_util::{hinged_puppet, weld};

    /// The landings a perfect network gives: each rest point at its place in `pose`, and a few
    /// wrong ones (`wrong` of every 10) thrown far.
    fn landed(puppet: &Puppet, pose: &[[f32; 2]], wrong: usize) -> Vec<(SurfacePoint, Landing)> {
        rest_samples(puppet)
            .unwrap()
            .into_iter()
            .enumerate()
            .map(|(k, b)| {
                let at = if k % 10 < wrong { [2.0, 38.0] } else { b.on(pose) };
                (b, Landing { at, similarity: 1.0 })
            })
            .collect()
    }

    #[test]
    fn exact_landings_of_turned_limbs_put_every_vertex_back_even_with_some_wrong() {
        let mut puppet = hinged_puppet();
        weld(&mut puppet, 1, 2, [24.0, 14.0]);
        let settings = EngineSettings {
            drags: 0,
            squash: 0.0,
            ..EngineSettings::default()
        };
        let engine = PoseEngine::new(&puppet, settings).unwrap();
        for seed in 0..4 {
            let truth = engine.vertices(seed);
            for wrong in [0, 3] {
                let placed = place_by(&puppet, &landed(&puppet, &truth, wrong));
                let worst = placed
                    .vertices
                    .iter()
                    .zip(&truth)
                    .map(|(p, t)| distance(*p, *t))
                    .fold(0.0, f32::max);
                assert!(worst < 0.05, "seed {seed}, {wrong}/10 wrong: a vertex {worst} px off");
                assert!(placed.unplaced.is_empty());
                assert!(
                    placed.agreement >= 1.0 - wrong as f32 / 10.0 - 0.02,
                    "agreement {}",
                    placed.agreement
                );
            }
        }
    }

    #[test]
    fn a_limb_whose_landings_agree_on_nothing_keeps_its_parents_turn() {
        let mut puppet = hinged_puppet();
        weld(&mut puppet, 1, 2, [24.0, 14.0]);
        let rest = puppet.rest_vertices();
        let arm = puppet.layer_index("arm_front").unwrap();
        let mut rng = Rng::new(3);
        let scattered: Vec<(SurfacePoint, Landing)> = landed(&puppet, &rest, 0)
            .into_iter()
            .map(|(b, l)| {
                let at = if usize::from(b.layer) == arm {
                    [rng.range(0.0, 48.0), rng.range(0.0, 40.0)]
                } else {
                    l.at
                };
                (b, Landing { at, similarity: 1.0 })
            })
            .collect();
        let placed = place_by(&puppet, &scattered);
        assert_eq!(placed.unplaced, vec![arm]);
        let worst = placed.vertices.iter().zip(&rest).map(|(p, t)| distance(*p, *t)).fold(0.0, f32::max);
        assert!(worst < 0.05, "the arm left the rest pose by {worst} px");
    }

    #[test]
    fn no_landings_leave_the_rest_pose() {
        let puppet = hinged_puppet();
        let placed = place_by(&puppet, &[]);
        assert_eq!(placed.vertices, puppet.rest_vertices());
        assert_eq!(placed.agreement, 0.0);
    }
}
