//! "Draw this next" (issue 57 item 1): which pose, drawn by the artist and added to the training
//! frames, would teach the model most.
//!
//! Candidates are poses the puppet can take near what was drawn ([`candidate_poses`]): drawn
//! poses with a few limbs turned elsewhere inside the turn ranges the drawn frames show,
//! widened; in-betweens of each pair of drawn frames (their latents' midpoint); and steps along
//! the drawn frames' principal latent directions. Accessories are placed by the rig.
//!
//! Each is scored by [`Criterion::Misread`], the network's self-consistency: the rest art moved
//! into the pose (the crisp render, what a drawing of the pose looks like before the artist
//! bends and squashes it) is read back by the network in one pass, and the score is the mean
//! distance of the body's vertices from where the network puts them. A pose the network reads
//! back well is one it has in effect learned; one it misreads is where a drawing teaches most.
//! [`Criterion::Coverage`], the default, sums the misread of the candidates around a pose,
//! nearer ones counting more, beyond what the drawn poses teach already: a drawing teaches its
//! neighbourhood. [`Criterion::Typical`] counts the candidates around a pose not yet taught,
//! misread or not: the most typical of the poses still to draw. [`Criterion::Distance`], the turn-space
//! distance from the nearest drawn pose (farthest first), is the baseline the others are
//! measured against (docs/results.md "Suggest").
//!
//! [`pick`] takes the best-scored candidates greedily, each at least a set turn-space distance
//! from the drawn poses and from those already taken, so n suggestions are n poses different
//! from each other and from what was drawn.

use burn::tensor::{Device, Tensor, TensorData};
use rayon::prelude::*;

use super::directions::LatentDirections;
use crate::error::{Error, Result};
use crate::fit::plausible::JointRanges;
use crate::model::Model;
use crate::picture::Picture;
use crate::puppet::limbs::{wrap, LimbTurns};
use crate::puppet::Puppet;
use crate::render::preview::trace_over;
use crate::render::render_crisp;
use crate::rng::Rng;

/// What makes a candidate worth drawing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// The network misreads its own render of the pose (module doc).
    Misread,
    /// The pose is far, in limb turns, from every drawn pose (farthest first).
    Distance,
    /// The candidates near the pose in turn space are misread, weighted by nearness
    /// ([`COVERAGE_DEGREES`]) beyond what the drawn poses already teach ([`coverage`]): a
    /// drawing teaches its neighbourhood, so a pose among many misread ones is worth more than
    /// a misread outlier. The default: it gains most (docs/results.md "Suggest").
    Coverage,
    /// As [`Criterion::Coverage`] with every candidate's misread counted as 1: how many of the
    /// poses around the pose, nearer ones counting more, no drawn pose teaches yet. The most
    /// typical of the poses still to draw, however well the network reads them: made for a
    /// pool of poses the artist plans to need, where the crowded poses are the ones asked for
    /// most (docs/suggest.md).
    Typical,
}

/// The width of [`Criterion::Coverage`]'s neighbourhood: a candidate `d` degrees away (turn
/// distance) counts `exp(−d² / 2w²)` of its misread.
pub const COVERAGE_DEGREES: f32 = 20.0;

/// How [`suggest`] searches.
#[derive(Clone, Debug, PartialEq)]
pub struct SuggestOptions {
    /// Suggestions wanted.
    pub count: usize,
    /// Candidates made by turning limbs of drawn poses.
    pub turned: usize,
    /// Degrees the drawn frames' turn ranges are widened by on each side.
    pub margin_degrees: f32,
    /// The least turn-space distance between two suggestions (degrees, [`turn_distance`]).
    pub separation_degrees: f32,
    /// What the candidates are ranked by.
    pub criterion: Criterion,
    /// Seeds the turned candidates.
    pub seed: u64,
}

impl Default for SuggestOptions {
    fn default() -> Self {
        SuggestOptions {
            count: 3,
            turned: 96,
            margin_degrees: 25.0,
            separation_degrees: 12.0,
            criterion: Criterion::Coverage,
            seed: 1,
        }
    }
}

impl SuggestOptions {
    /// Checks the counts and angles.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the option.
    pub fn validate(&self) -> Result<()> {
        if self.count == 0 {
            return Err(Error::setting("count", 0, "at least 1"));
        }
        for (name, value) in [("margin", self.margin_degrees), ("separation", self.separation_degrees)] {
            if !(0.0..=180.0).contains(&value) {
                return Err(Error::setting(name, value, "degrees from 0 to 180"));
            }
        }
        Ok(())
    }
}

/// Where a candidate pose came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum Origin {
    /// Drawn frame `frame`'s pose with the named limbs turned.
    Turned {
        /// The drawn frame (index into the training frames).
        frame: usize,
        /// The layers whose limbs were turned.
        limbs: Vec<String>,
    },
    /// Halfway between drawn frames `a` and `b` in latent space.
    Inbetween {
        /// One drawn frame.
        a: usize,
        /// The other.
        b: usize,
    },
    /// `steps` standard deviations along the drawn frames' principal latent direction `index`.
    Direction {
        /// The direction, largest spread first.
        index: usize,
        /// Signed distance along it, in standard deviations.
        steps: f32,
    },
    /// The `index`th pose the caller gave (`puppet suggest --pool`).
    Given {
        /// Its place in the pool.
        index: usize,
    },
}

impl std::fmt::Display for Origin {
    /// Where the pose came from in words, drawn frames counted from 1: "drawn frame 2 with
    /// arm_l turned", "halfway between drawn frames 1 and 3".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::Turned { frame, limbs } => write!(f, "drawn frame {} with {} turned", frame + 1, limbs.join(", ")),
            Origin::Inbetween { a, b } => write!(f, "halfway between drawn frames {} and {}", a + 1, b + 1),
            Origin::Direction { index, steps } => write!(f, "{steps:+} σ along the drawn frames' direction {}", index + 1),
            Origin::Given { index } => write!(f, "pose {} of the pool", index + 1),
        }
    }
}

/// A candidate pose and its scores.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Every vertex, frame pixels, global numbering.
    pub pose: Vec<[f32; 2]>,
    /// How it was made.
    pub origin: Origin,
    /// Mean distance (frame pixels) of the body's vertices from where the network reads them
    /// in the pose's render.
    pub misread: f32,
    /// Turn-space distance from the nearest drawn pose (degrees, [`turn_distance`]).
    pub distance: f32,
    /// The misread of the candidates around it, weighted by nearness ([`Criterion::Coverage`]).
    pub coverage: f32,
    /// The candidates around it not yet taught, weighted by nearness ([`Criterion::Typical`]).
    pub typical: f32,
}

impl Candidate {
    /// Its score under `criterion`: higher is more worth drawing.
    pub fn score(&self, criterion: Criterion) -> f32 {
        match criterion {
            Criterion::Misread => self.misread,
            Criterion::Distance => self.distance,
            Criterion::Coverage => self.coverage,
            Criterion::Typical => self.typical,
        }
    }
}

/// The root-mean-square difference of two poses' limb turns (each relative to its parent
/// layer, as [`LimbTurns::of`] measures them), degrees; 0 for a puppet without limbs.
pub fn turn_distance(a: &[f32], b: &[f32]) -> f32 {
    if a.is_empty() {
        return 0.0;
    }
    let sum: f32 = a.iter().zip(b).map(|(x, y)| wrap(x - y).powi(2)).sum();
    (sum / a.len() as f32).sqrt().to_degrees()
}

/// What the model makes of its drawn frames: their one-pass poses and latents.
pub struct Drawn {
    /// Per frame, the network's pose (frame pixels, global numbering).
    pub poses: Vec<Vec<[f32; 2]>>,
    /// Per frame, its latent (rows).
    pub latents: Vec<Vec<f32>>,
}

impl Drawn {
    /// Reads `frames` (the drawn frames, the model's size) with `model` in one pass each.
    ///
    /// # Errors
    /// [`Error::Setting`] for no frame; as [`Model::encode`].
    pub fn read(model: &Model, frames: &[&Picture], device: &Device) -> Result<Self> {
        if frames.is_empty() {
            return Err(Error::setting("drawn frames", 0, "at least one"));
        }
        let z = model.encode(frames, device)?;
        let [n, dim] = z.dims();
        let values: Vec<f32> = z
            .clone()
            .into_data()
            .try_to_vec::<f32>()
            .map_err(|e| Error::geometry("latents", format!("{e:?}")))?;
        Ok(Drawn {
            poses: model.to_frame_vertices(model.decode(z, device)),
            latents: (0..n).map(|i| values[i * dim..(i + 1) * dim].to_vec()).collect(),
        })
    }
}

/// The candidates of the module doc for `model`, whose drawn frames are `drawn`.
///
/// # Errors
/// As [`LatentDirections::of`].
pub fn candidate_poses(model: &Model, drawn: &Drawn, options: &SuggestOptions, device: &Device) -> Result<Vec<(Vec<[f32; 2]>, Origin)>> {
    let puppet = &model.puppet;
    let measure = LimbTurns::new(puppet);
    let ranges = JointRanges::from_poses(puppet, &drawn.poses, options.margin_degrees);
    let rig = model.expansion.rig_map();
    let mut out = Vec::new();
    let mut rng = Rng::new(options.seed);
    let limbs = measure.limbs();
    if !limbs.is_empty() {
        for _ in 0..options.turned {
            let frame = rng.below(drawn.poses.len());
            let mut pose = drawn.poses[frame].clone();
            // One to three limbs turned: near what was drawn, new in a joint or two.
            let turned = 1 + rng.below(3.min(limbs.len()));
            let mut chosen: Vec<usize> = Vec::new();
            while chosen.len() < turned {
                let k = rng.below(limbs.len());
                if !chosen.contains(&k) {
                    chosen.push(k);
                }
            }
            // A parent's limb before its children's, so each turns about its pivot as moved.
            chosen.sort_unstable();
            for &k in &chosen {
                let (centre, half) = ranges.range(k);
                let target = centre + rng.range(-half, half);
                let now = measure.of(&pose)[k];
                limbs[k].turn(&mut pose, wrap(target - now));
            }
            if let Some(rig) = rig {
                rig.apply(&mut pose);
            }
            let names = chosen.iter().map(|&k| puppet.layers[limbs[k].layer].name.clone()).collect();
            out.push((pose, Origin::Turned { frame, limbs: names }));
        }
    }
    let mut latents = Vec::new();
    let mut origins = Vec::new();
    let n = drawn.latents.len();
    for a in 0..n {
        for b in a + 1..n {
            latents.push(
                drawn.latents[a]
                    .iter()
                    .zip(&drawn.latents[b])
                    .map(|(x, y)| 0.5 * (x + y))
                    .collect::<Vec<f32>>(),
            );
            origins.push(Origin::Inbetween { a, b });
        }
    }
    let directions = LatentDirections::of(&drawn.latents, DIRECTIONS)?;
    for (index, (direction, sigma)) in directions.directions.iter().zip(&directions.sigma).enumerate() {
        for steps in [-DIRECTION_STEPS, DIRECTION_STEPS] {
            latents.push(directions.mean.iter().zip(direction).map(|(m, d)| m + steps * sigma * d).collect());
            origins.push(Origin::Direction { index, steps });
        }
    }
    if !latents.is_empty() {
        let dim = latents[0].len();
        let z = Tensor::<2>::from_data(TensorData::new(latents.concat(), [latents.len(), dim]), device);
        out.extend(model.to_frame_vertices(model.decode(z, device)).into_iter().zip(origins));
    }
    Ok(out)
}

/// Principal latent directions candidates are made along.
const DIRECTIONS: usize = 4;

/// How far along each direction, in standard deviations of the drawn frames (±1 spans what
/// they span; 1.5 reaches a little past).
const DIRECTION_STEPS: f32 = 1.5;

/// Scores `poses` (with their origins) against the drawn poses `drawn_poses`: the misread and
/// the turn distance of [`Candidate`].
///
/// # Errors
/// As [`render_crisp`] and [`Model::encode`].
pub fn score(model: &Model, drawn_poses: &[Vec<[f32; 2]>], poses: Vec<(Vec<[f32; 2]>, Origin)>, device: &Device) -> Result<Vec<Candidate>> {
    if poses.is_empty() {
        return Ok(Vec::new());
    }
    let puppet = &model.puppet;
    let (w, h) = (puppet.width, puppet.height);
    let renders: Vec<Picture> = poses
        .par_iter()
        .map(|(p, _)| render_crisp(puppet, p, w, h))
        .collect::<Result<_>>()?;
    let read = model.to_frame_vertices(model.decode(model.encode(&renders.iter().collect::<Vec<_>>(), device)?, device));
    let body = puppet.free_vertices();
    let measure = LimbTurns::new(puppet);
    let drawn_turns: Vec<Vec<f32>> = drawn_poses.iter().map(|p| measure.of(p)).collect();
    let turns: Vec<Vec<f32>> = poses.iter().map(|(p, _)| measure.of(p)).collect();
    let mut candidates: Vec<Candidate> = poses
        .into_iter()
        .zip(read)
        .zip(&turns)
        .map(|(((pose, origin), read), turns)| {
            let misread = body.iter().map(|&v| distance(pose[v], read[v])).sum::<f32>() / body.len().max(1) as f32;
            let distance = drawn_turns.iter().map(|d| turn_distance(turns, d)).fold(f32::INFINITY, f32::min);
            Candidate {
                pose,
                origin,
                misread,
                distance: if distance.is_finite() { distance } else { 0.0 },
                coverage: 0.0,
                typical: 0.0,
            }
        })
        .collect();
    let misread: Vec<f32> = candidates.iter().map(|c| c.misread).collect();
    let coverage_scores = coverage(&turns, &misread, &drawn_turns);
    let typical_scores = coverage(&turns, &vec![1.0; turns.len()], &drawn_turns);
    for ((c, coverage), typical) in candidates.iter_mut().zip(coverage_scores).zip(typical_scores) {
        c.coverage = coverage;
        c.typical = typical;
    }
    Ok(candidates)
}

/// Per pose (limb turns `turns[i]`), what a drawing of it would add to what the drawn poses
/// (`drawn_turns`) already teach ([`Criterion::Coverage`]; [`Criterion::Typical`] with every
/// `misread` 1): the `misread` of every pose `q`,
/// weighted by how much nearer the pose is to `q` than the nearest drawn pose is,
/// `max(0, k(pose, q) − max_d k(d, q))` with `k = exp(−t² / 2w²)`, `t` the [`turn_distance`]
/// and `w` [`COVERAGE_DEGREES`]. Without the drawn poses' share, the densest neighbourhood of
/// suggest's own candidates, which are made around the drawn poses, would be next to a drawn one.
pub fn coverage(turns: &[Vec<f32>], misread: &[f32], drawn_turns: &[Vec<f32>]) -> Vec<f32> {
    let width = 2.0 * COVERAGE_DEGREES * COVERAGE_DEGREES;
    let nearness = |a: &[f32], b: &[f32]| (-turn_distance(a, b).powi(2) / width).exp();
    let taught: Vec<f32> = turns
        .par_iter()
        .map(|q| drawn_turns.iter().map(|d| nearness(d, q)).fold(0.0, f32::max))
        .collect();
    turns
        .par_iter()
        .map(|t| {
            turns
                .iter()
                .zip(misread)
                .zip(&taught)
                .map(|((q, m), c)| m * (nearness(t, q) - c).max(0.0))
                .sum()
        })
        .collect()
}

fn distance(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The indices of at most `options.count` candidates, best first under its criterion, each at
/// least its separation in turn space ([`turn_distance`]) from the poses already drawn
/// (`drawn_poses`: a pose next to a drawn one is drawn in effect) and from the picks before it.
/// Candidates whose score is not a number are never picked; for a puppet without limbs, which
/// has no turn distance, only the best is.
pub fn pick(candidates: &[Candidate], drawn_poses: &[Vec<[f32; 2]>], measure: &LimbTurns, options: &SuggestOptions) -> Vec<usize> {
    let (criterion, count, separation_degrees) = (options.criterion, options.count, options.separation_degrees);
    let mut order: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].score(criterion).is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        candidates[b]
            .score(criterion)
            .total_cmp(&candidates[a].score(criterion))
            .then(a.cmp(&b))
    });
    let turns: Vec<Vec<f32>> = candidates.iter().map(|c| measure.of(&c.pose)).collect();
    // Without limbs every pose is 0° from every other: only the best is taken.
    let mut taken: Vec<Vec<f32>> = if measure.limbs().is_empty() {
        Vec::new()
    } else {
        drawn_poses.iter().map(|p| measure.of(p)).collect()
    };
    let mut picked: Vec<usize> = Vec::new();
    for i in order {
        if picked.len() == count {
            break;
        }
        if taken.iter().all(|t| turn_distance(&turns[i], t) >= separation_degrees) {
            taken.push(turns[i].clone());
            picked.push(i);
        }
    }
    picked
}

/// The longest side of a trace-over picture, at least: a small sprite is scaled up by a whole
/// factor (at most 8) so that the mesh's hairlines stay apart.
pub const TRACE_SIDE: u32 = 384;

/// The picture an artist traces over to draw `pose` (frame pixels, global numbering): the rest
/// art moved into the pose under its faint mesh ([`trace_over`]), scaled up to [`TRACE_SIDE`].
///
/// # Errors
/// As [`render_crisp`].
pub fn trace_picture(puppet: &Puppet, pose: &[[f32; 2]]) -> Result<Picture> {
    let (w, h) = (puppet.width, puppet.height);
    let scale = TRACE_SIDE.div_ceil(w.max(h).max(1)).clamp(1, 8);
    Ok(trace_over(puppet, pose, &render_crisp(puppet, pose, w, h)?, scale))
}

/// What [`suggest`] found.
#[derive(Clone, Debug)]
pub struct Ranking {
    /// Every scored candidate of the search that was kept.
    pub candidates: Vec<Candidate>,
    /// The picked candidates (indices into `candidates`), best first.
    pub picked: Vec<usize>,
    /// The degrees the drawn turn ranges were widened by to make the candidates: the options'
    /// margin, or a wider one when too few candidates were apart from the drawn poses
    /// ([`WIDEST_MARGIN_DEGREES`]); `None` for a pool.
    pub margin_degrees: Option<f32>,
}

impl Ranking {
    /// Why nothing was picked, in words, for an empty `picked`: no candidate could be scored,
    /// or none is `separation_degrees` from every drawn pose.
    pub fn why_none(&self, separation_degrees: f32) -> String {
        if self.candidates.iter().all(|c| !c.misread.is_finite()) {
            return "no candidate pose could be scored, so there is nothing to suggest".into();
        }
        let widened = match self.margin_degrees {
            Some(m) => format!(", even with the drawn turn ranges widened by {m}°"),
            None => String::new(),
        };
        format!(
            "none of the {} candidate poses is {separation_degrees}° in limb turns (the separation) from every drawn pose{widened}: the drawn frames already show them",
            self.candidates.len()
        )
    }
}

/// The widest margin [`suggest`] doubles the options' margin up to when too few of its
/// candidates are new poses: a model whose drawn frames read alike (one early in training)
/// makes candidates all next to them.
pub const WIDEST_MARGIN_DEGREES: f32 = 90.0;

/// The suggestions for `model`, whose drawn frames are `frames`: the candidates of
/// [`candidate_poses`] (or `pool`, poses the caller gives, instead), scored, and the picked
/// ones best first ([`pick`]). When fewer than the options' count of the candidates are apart
/// from the drawn poses and each other, the search is made again with the margin doubled, up
/// to [`WIDEST_MARGIN_DEGREES`], and the search with the most picks (the narrowest of equals;
/// the widest when none picks any) is kept.
///
/// # Errors
/// As [`SuggestOptions::validate`], [`Drawn::read`], [`candidate_poses`] and [`score`].
pub fn suggest(
    model: &Model,
    frames: &[&Picture],
    pool: Option<Vec<Vec<[f32; 2]>>>,
    options: &SuggestOptions,
    device: &Device,
) -> Result<Ranking> {
    options.validate()?;
    let drawn = Drawn::read(model, frames, device)?;
    let measure = LimbTurns::new(&model.puppet);
    let rank = |poses, margin_degrees| -> Result<Ranking> {
        let candidates = score(model, &drawn.poses, poses, device)?;
        let picked = pick(&candidates, &drawn.poses, &measure, options);
        Ok(Ranking {
            candidates,
            picked,
            margin_degrees,
        })
    };
    if let Some(pool) = pool {
        let poses = pool
            .into_iter()
            .enumerate()
            .map(|(index, p)| (p, Origin::Given { index }))
            .collect();
        return rank(poses, None);
    }
    let mut margin = options.margin_degrees;
    let mut best: Option<Ranking> = None;
    loop {
        let widened = SuggestOptions {
            margin_degrees: margin,
            ..options.clone()
        };
        let ranking = rank(candidate_poses(model, &drawn, &widened, device)?, Some(margin))?;
        if best
            .as_ref()
            .is_none_or(|b| b.picked.is_empty() || ranking.picked.len() > b.picked.len())
        {
            best = Some(ranking);
        }
        let found = best.as_ref().map_or(0, |b| b.picked.len());
        // A puppet without limbs makes its candidates from latents only: no margin changes them.
        if found == options.count || margin >= WIDEST_MARGIN_DEGREES || measure.limbs().is_empty() {
            return Ok(best.expect("one search was made"));
        }
        margin = (2.0 * margin).clamp(1.0, WIDEST_MARGIN_DEGREES);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{hinged_puppet, untrained_model};

    fn candidate(pose: Vec<[f32; 2]>, misread: f32, distance: f32) -> Candidate {
        Candidate {
            pose,
            origin: Origin::Given { index: 0 },
            misread,
            distance,
            coverage: misread,
            typical: 1.0,
        }
    }

    #[test]
    fn turn_distance_wraps_and_is_an_rms_in_degrees() {
        let a = [0.0f32, 0.0];
        let b = [std::f32::consts::PI / 18.0, -std::f32::consts::PI / 18.0]; // ±10°
        assert!((turn_distance(&a, &b) - 10.0).abs() < 1e-3);
        // 179° and −179° are 2° apart, not 358°.
        let c = [179f32.to_radians(), 0.0];
        let d = [(-179f32).to_radians(), 0.0];
        assert!((turn_distance(&c, &d) - 2.0 / 2f32.sqrt()).abs() < 1e-3);
        assert_eq!(turn_distance(&[], &[]), 0.0);
    }

    #[test]
    fn coverage_prefers_a_misread_crowd_to_a_misread_outlier() {
        let deg = |a: f32| vec![a.to_radians()];
        // Three poses close together, each misread by 2 px; one far off, misread by 4 px.
        let turns = [deg(0.0), deg(5.0), deg(-5.0), deg(90.0)];
        let scores = coverage(&turns, &[2.0, 2.0, 2.0, 4.0], &[]);
        assert!(scores[0] > scores[3] && scores[0] > scores[1], "{scores:?}");
        // Alone, a pose's coverage is its misread.
        assert!((scores[3] - 4.0).abs() < 1e-3, "{scores:?}");
        // With 0° drawn, the crowd is taught already: the outlier is worth more, the crowd's
        // centre nothing, and each pose of the crowd gets only what it adds beyond the drawing.
        let taught = coverage(&turns, &[2.0, 2.0, 2.0, 4.0], &[deg(0.0)]);
        assert!(taught[3] > taught[1] && taught[0].abs() < 1e-6, "{taught:?}");
        assert!((taught[3] - 4.0).abs() < 1e-2, "{taught:?}");
        assert!(taught[1] > 0.0 && taught[1] < 0.5 * scores[1], "{taught:?}");
    }

    #[test]
    fn typical_prefers_the_centre_of_an_untaught_crowd_however_well_read() {
        let deg = |a: f32| vec![a.to_radians()];
        // A crowd the network reads well, one pose it misreads badly, and a drawn pose at 0°.
        let turns = [deg(0.0), deg(60.0), deg(65.0), deg(55.0), deg(150.0)];
        let misread = [0.1, 0.1, 0.1, 0.1, 9.0];
        let drawn = [deg(0.0)];
        let argmax = |v: &[f32]| (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        assert_eq!(argmax(&coverage(&turns, &misread, &drawn)), 4);
        let typical = coverage(&turns, &[1.0; 5], &drawn);
        assert_eq!(argmax(&typical), 1, "{typical:?}");
        // The drawn pose teaches itself: nothing is left around it.
        assert!(typical[0] < 0.1 * typical[1], "{typical:?}");
    }

    #[test]
    fn pick_takes_the_best_scores_apart_from_each_other() {
        let (model, _) = untrained_model(hinged_puppet(), 16);
        let puppet = &model.puppet;
        let measure = LimbTurns::new(puppet);
        assert!(!measure.limbs().is_empty(), "the hinged puppet has a limb");
        let rest = puppet.rest_vertices();
        let turned = |degrees: f32| {
            let mut p = rest.clone();
            measure.limbs()[0].turn(&mut p, degrees.to_radians());
            p
        };
        let candidates = vec![
            candidate(turned(0.0), 1.0, 9.0),
            candidate(turned(40.0), 5.0, 1.0),
            candidate(turned(41.0), 4.0, 2.0), // as good, but the same pose as the one above
            candidate(turned(-40.0), 3.0, 3.0),
            candidate(turned(-80.0), f32::NAN, 4.0),
        ];
        let n = measure.limbs().len() as f32;
        let separation = 5.0 / n.sqrt();
        let by = |criterion, count, separation_degrees| SuggestOptions {
            criterion,
            count,
            separation_degrees,
            ..SuggestOptions::default()
        };
        let misread = |count, separation| pick(&candidates, &[], &measure, &by(Criterion::Misread, count, separation));
        assert_eq!(misread(3, separation), vec![1, 3, 0]);
        assert_eq!(misread(1, separation), vec![1]);
        // Without a separation, the near-twin is taken; the unscored one never is.
        assert_eq!(misread(9, 0.0), vec![1, 2, 3, 0]);
        assert_eq!(
            pick(&candidates, &[], &measure, &by(Criterion::Distance, 2, separation)),
            vec![0, 4]
        );
        // A pose next to a drawn one is drawn in effect: with −38° drawn, −40° is passed over.
        let drawn = [turned(-38.0)];
        assert_eq!(
            pick(&candidates, &drawn, &measure, &by(Criterion::Misread, 3, separation)),
            vec![1, 0]
        );
    }

    #[test]
    fn candidates_stay_in_the_widened_ranges_and_score_themselves() {
        let (model, _) = untrained_model(hinged_puppet(), 16);
        let device = Default::default();
        let puppet = &model.puppet;
        let rest = puppet.rest_vertices();
        let frame = render_crisp(puppet, &rest, puppet.width, puppet.height).unwrap();
        let other = {
            let measure = LimbTurns::new(puppet);
            let mut p = rest.clone();
            measure.limbs()[0].turn(&mut p, 0.5);
            render_crisp(puppet, &p, puppet.width, puppet.height).unwrap()
        };
        let frames = [&frame, &other];
        let options = SuggestOptions {
            turned: 20,
            ..SuggestOptions::default()
        };
        let drawn = Drawn::read(&model, &frames, &device).unwrap();
        let poses = candidate_poses(&model, &drawn, &options, &device).unwrap();
        // 20 turned, 1 in-between, and up to 2 steps along the one direction two frames have.
        assert!((21..=23).contains(&poses.len()), "{}", poses.len());
        let ranges = JointRanges::from_poses(puppet, &drawn.poses, options.margin_degrees);
        for (pose, origin) in &poses {
            if let Origin::Turned { .. } = origin {
                assert!(
                    ranges.worst(pose).is_none_or(|(_, excess)| excess < 0.1),
                    "{origin:?} leaves the range"
                );
            }
        }
        let scored = score(&model, &drawn.poses, poses, &device).unwrap();
        assert!(scored
            .iter()
            .all(|c| c.misread.is_finite() && c.misread >= 0.0 && c.distance >= 0.0));
        // A drawn pose given back is at distance 0 from the drawn poses.
        let given = score(
            &model,
            &drawn.poses,
            vec![(drawn.poses[1].clone(), Origin::Given { index: 0 })],
            &device,
        )
        .unwrap();
        assert!(given[0].distance < 1e-3, "{}", given[0].distance);
        let found = suggest(&model, &frames, None, &options, &device).unwrap();
        let picked = &found.picked;
        assert!(!picked.is_empty() && picked.len() <= 3 && picked.iter().all(|&i| i < found.candidates.len()));
        let same = suggest(&model, &frames, None, &options, &device).unwrap();
        assert_eq!(&same.picked, picked, "seeded");
        assert!(picked.iter().all(|&i| found.candidates[i].distance >= options.separation_degrees));
        // The untrained network reads both frames as the rest pose, so no candidate turned at
        // most 10° past them is 30° from a drawn pose: the search widens until it finds one.
        let narrow = SuggestOptions {
            margin_degrees: 10.0,
            separation_degrees: 30.0,
            count: 1,
            ..options.clone()
        };
        let widened = suggest(&model, &frames, None, &narrow, &device).unwrap();
        let margin = widened.margin_degrees.unwrap();
        assert!(margin > 10.0 && margin <= WIDEST_MARGIN_DEGREES, "{margin}");
        assert_eq!(widened.picked.len(), 1);
        assert!(widened.candidates[widened.picked[0]].distance >= 30.0);
    }

    #[test]
    fn options_out_of_range_are_refused() {
        for bad in [
            SuggestOptions {
                count: 0,
                ..SuggestOptions::default()
            },
            SuggestOptions {
                separation_degrees: -1.0,
                ..SuggestOptions::default()
            },
            SuggestOptions {
                margin_degrees: f32::NAN,
                ..SuggestOptions::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
