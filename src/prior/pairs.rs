//! The prior's training pairs: two frames of one drawn character posed by the posing engine
//! (the first its rest pose or another pose, as a fit and a sprite sheet pair them), with every
//! pixel of the first whose point shows in the second; and pairs mixed from two sources (the
//! drawn characters and the generator's).

use crate::error::{Error, Result};
use crate::parts::learn::{PairSource, TrainingPair};
use crate::parts::matching::WorkingPose;
use crate::parts::pose::SheetPose;
use crate::posing::{surface_points, PoseEngine, PosedFrame, NO_LAYER};
use crate::rng::Rng;

/// Pairs of posed characters: pair `index` is always the same pair.
pub struct PosedPairs {
    /// One engine per drawn character.
    pub engines: Vec<PoseEngine>,
    /// The working size S of the pairs.
    pub size: u32,
    /// Seeds every pair.
    pub seed: u64,
    /// The share of pairs whose first frame is the rest pose.
    pub rest_share: f32,
}

impl PairSource for PosedPairs {
    fn size(&self) -> usize {
        self.size as usize
    }

    fn pair(&self, index: u64) -> Result<TrainingPair> {
        if self.engines.is_empty() {
            return Err(Error::setting("characters", 0, "at least one character to pose"));
        }
        let mut rng = Rng::new(self.seed).fork(index);
        let engine = &self.engines[rng.below(self.engines.len())];
        let first = if rng.unit() < self.rest_share {
            engine.frame(engine.puppet().rest_vertices())?
        } else {
            engine.pose(rng.next_u64())?
        };
        let second = engine.pose(rng.next_u64())?;
        Ok(training_pair(engine, &first, &second, self.size))
    }
}

/// The stream of [`MixedPairs`]' choice of source, forked from each pair's.
const SOURCE_CHOICE: u64 = 1;

/// Pairs from two sources of one working size: pair `index` is the other source's with
/// probability `other_share` (a function of `seed` and `index`), each source's pairs numbered
/// on by their own count.
pub struct MixedPairs<'a> {
    /// The main source.
    pub main: &'a dyn PairSource,
    /// The other.
    pub other: &'a dyn PairSource,
    /// The other's share of the pairs.
    pub other_share: f32,
    /// Seeds the choice.
    pub seed: u64,
}

impl PairSource for MixedPairs<'_> {
    fn size(&self) -> usize {
        self.main.size()
    }

    fn pair(&self, index: u64) -> Result<TrainingPair> {
        // Both sources see every index, each its own stream of pairs, so a pair never repeats.
        // The choice has a stream of its own: a source seeded alike draws from
        // `Rng::new(seed).fork(index)`, and a choice made with that stream's first number left
        // it only part of its range (`PosedPairs` only the second half of its characters).
        if Rng::new(self.seed).fork(index).fork(SOURCE_CHOICE).unit() < self.other_share {
            self.other.pair(index)
        } else {
            self.main.pair(index)
        }
    }
}

/// The pair `first`, `second` of `engine`'s character in the `size`² working square: each
/// working pixel of the first whose centre shows a point of the surface that the second also
/// shows (the same layer in front there), with that point's working pixel in the second.
pub fn training_pair(engine: &PoseEngine, first: &PosedFrame, second: &PosedFrame, size: u32) -> TrainingPair {
    let puppet = engine.puppet();
    let (w, h) = (puppet.width, puppet.height);
    let [a, b] = [first, second].map(|f| WorkingPose::new(&SheetPose::new("", f.picture.clone()), size));
    let surface = surface_points(puppet, &first.vertices, &first.labels, w, h);
    let s = size as usize;
    let matches = (0..s * s)
        .filter(|&i| a.mask[i])
        .filter_map(|i| {
            let p = a.letterbox.to_frame([(i % s) as f32 + 0.5, (i / s) as f32 + 0.5]);
            let point = surface[frame_index(p, w, h)?]?;
            let q = point.on(&second.vertices);
            let j = frame_index(q, w, h)?;
            if second.labels[j] == NO_LAYER || second.labels[j] != point.layer {
                return None;
            }
            let k = frame_index(b.letterbox.to_work(q), size, size)?;
            b.mask[k].then_some([i as u32, k as u32])
        })
        .collect();
    TrainingPair {
        a: a.planes,
        b: b.planes,
        matches,
        masks: [a.mask, b.mask],
    }
}

/// The row-major index of the pixel holding `p` in a `width × height` frame, if inside.
fn frame_index(p: [f32; 2], width: u32, height: u32) -> Option<usize> {
    let (x, y) = (p[0].floor(), p[1].floor());
    (x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32).then(|| y as usize * width as usize + x as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::posing::EngineSettings;
    use crate::test_util::{hinged_puppet, weld};

    /// Premultiplied RGB of working pixel `i` of `planes` (`[4, S, S]`).
    fn colour(planes: &[f32], i: usize, pixels: usize) -> [f32; 3] {
        std::array::from_fn(|c| planes[c * pixels + i])
    }

    /// A source whose pair `index` carries, as its one plane value, the first number of the
    /// stream `PosedPairs` draws its character from, or `marker` when `marker` is set.
    struct FirstDraw {
        seed: u64,
        marker: Option<f32>,
    }

    impl PairSource for FirstDraw {
        fn size(&self) -> usize {
            1
        }

        fn pair(&self, index: u64) -> Result<TrainingPair> {
            let value = self.marker.unwrap_or_else(|| Rng::new(self.seed).fork(index).unit());
            Ok(TrainingPair {
                a: vec![value],
                b: vec![value],
                matches: Vec::new(),
                masks: [vec![true], vec![true]],
            })
        }
    }

    #[test]
    fn mixing_two_sources_leaves_each_its_whole_range_of_draws() {
        let seed = 11;
        let main = FirstDraw { seed, marker: None };
        let other = FirstDraw { seed, marker: Some(-1.0) };
        let mixed = MixedPairs {
            main: &main,
            other: &other,
            other_share: 0.5,
            seed,
        };
        let draws: Vec<f32> = (0..4000).map(|i| mixed.pair(i).unwrap().a[0]).filter(|&v| v >= 0.0).collect();
        let share = draws.len() as f64 / 4000.0;
        assert!((0.45..0.55).contains(&share), "the main source gave {share} of the pairs");
        // The main source's own first numbers still spread over [0, 1): each tenth holds ~10 %.
        for tenth in 0..10 {
            let n = draws.iter().filter(|&&v| (v * 10.0) as usize == tenth).count();
            let part = n as f64 / draws.len() as f64;
            assert!(
                (0.07..0.13).contains(&part),
                "tenth {tenth} holds {part} of the main source's draws"
            );
        }
    }

    #[test]
    fn no_character_to_pose_is_an_error_not_a_panic() {
        let none = PosedPairs {
            engines: Vec::new(),
            size: 48,
            seed: 1,
            rest_share: 0.5,
        };
        assert!(none.pair(0).unwrap_err().to_string().contains("characters"));
    }

    #[test]
    fn matched_pixels_show_the_same_point_of_the_character_in_both_frames() {
        let mut puppet = hinged_puppet();
        weld(&mut puppet, 1, 2, [24.0, 14.0]);
        let engine = PoseEngine::new(&puppet, EngineSettings::default()).unwrap();
        // At the puppet's own width the working square copies the frame, so colours compare
        // without resampling.
        let source = PosedPairs {
            engines: vec![engine],
            size: 48,
            seed: 4,
            rest_share: 0.5,
        };
        let pixels = 48 * 48;
        let (mut matched, mut agree) = (0, 0);
        for index in 0..6 {
            let pair = source.pair(index).unwrap();
            assert_eq!(pair.a.len(), 4 * pixels);
            let shown = pair.masks[0].iter().filter(|&&m| m).count();
            assert!(
                pair.matches.len() > shown / 2,
                "pair {index}: {} matches of {shown} pixels",
                pair.matches.len()
            );
            for &[i, j] in &pair.matches {
                let (i, j) = (i as usize, j as usize);
                assert!(pair.masks[0][i] && pair.masks[1][j], "a match off the character");
                let (a, b) = (colour(&pair.a, i, pixels), colour(&pair.b, j, pixels));
                matched += 1;
                agree += usize::from((0..3).all(|c| (a[c] - b[c]).abs() <= 0.15));
            }
            assert!(
                source.pair(index).unwrap().matches == pair.matches,
                "pair {index} is not a function of its index"
            );
        }
        // Pixels land on their true place up to rounding to a pixel, and the textures' stripes
        // change by little within one.
        assert!(
            agree as f64 >= 0.9 * matched as f64,
            "{agree} of {matched} matched pixels agree in colour"
        );
    }
}
