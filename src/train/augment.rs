//! Augmenting the drawn frames (issue 19): at each step each drawn frame is shown moved a little
//! — shifted, scaled and turned about the working square's centre — and with its colours
//! jittered. The move is a similarity, which the puppet draws exactly (the template moved
//! alike), so the image loss compares the render with the moved frame; the colour jitter is
//! applied to the network's input only, since the template's colours do not change. Not in
//! neural-puppet.md.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::rng::Rng;

/// `[train.augment]`: how the drawn frames are moved and recoloured. Off (all ranges 0) unless a
/// config asks for it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Augment {
    /// Shifted by up to this share of the working square either way, along each axis.
    pub shift: f32,
    /// Scaled by up to this share either way about the square's centre.
    pub scale: f32,
    /// Turned by up to this many degrees either way about the square's centre.
    pub max_degrees: f32,
    /// Each colour channel of the input multiplied by a gain within 1 ± this.
    pub colour: f32,
}

/// The stream of a step's augmentation, apart from the sampled poses' stream of the same step.
const STREAM: u64 = 0xa06_0e57;

/// A step's drawn frames as the network takes them and as the image loss compares them.
pub struct Augmented {
    /// The network's inputs: premultiplied planes `[4, S, S]`, moved and recoloured.
    pub inputs: Vec<Vec<f32>>,
    /// The image loss's targets: the same frames moved, colours as drawn.
    pub targets: Vec<Vec<f32>>,
    /// Each frame's move, as [`moved_point`] takes it.
    pub moves: Vec<[f32; 4]>,
}

impl Augment {
    /// Whether frames are shown as drawn (the config's table may then be left out).
    pub fn is_off(&self) -> bool {
        self.shift == 0.0 && self.scale == 0.0 && self.max_degrees == 0.0 && self.colour == 0.0
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first key out of range.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("shift", self.shift, 0.0..=0.5, "from 0 to 0.5"),
            ("scale", self.scale, 0.0..=0.5, "from 0 to 0.5"),
            ("max_degrees", self.max_degrees, 0.0..=180.0, "from 0 to 180"),
            ("colour", self.colour, 0.0..=1.0, "from 0 to 1"),
        ];
        for (key, value, range, expected) in checks {
            if !(value.is_finite() && range.contains(&value)) {
                return Err(Error::setting(format!("train.augment.{key}"), f64::from(value), expected));
            }
        }
        Ok(())
    }

    /// `frames` (premultiplied planes `[4, size, size]`) augmented for step `step`: a function of
    /// the seed, the step and the frames' place in the batch, so a resumed run sees what an
    /// uninterrupted one would.
    pub fn apply(&self, frames: &[&Vec<f32>], size: usize, seed: u64, step: u64) -> Augmented {
        let mut rng = Rng::new(seed).fork(step).fork(STREAM);
        let draws: Vec<([f32; 4], [f32; 3])> = frames
            .iter()
            .map(|_| {
                let angle = rng.range(-self.max_degrees, self.max_degrees).to_radians();
                let scale = 1.0 + rng.range(-self.scale, self.scale);
                let shift = [rng.range(-self.shift, self.shift), rng.range(-self.shift, self.shift)];
                let gains = [(); 3].map(|_| 1.0 + rng.range(-self.colour, self.colour));
                ([angle, scale, shift[0] * size as f32, shift[1] * size as f32], gains)
            })
            .collect();
        let (targets, inputs) = frames
            .par_iter()
            .zip(&draws)
            .map(|(planes, &(motion, gains))| {
                let moved = moved(planes, size, motion);
                let mut input = moved.clone();
                for (channel, gain) in input.chunks_exact_mut(size * size).zip(gains) {
                    // Premultiplied: a colour gain cannot push a channel past its alpha.
                    channel.iter_mut().for_each(|c| *c *= gain);
                }
                let (colours, alpha) = input.split_at_mut(3 * size * size);
                for channel in colours.chunks_exact_mut(size * size) {
                    channel.iter_mut().zip(alpha.iter()).for_each(|(c, &a)| *c = c.min(a));
                }
                (moved, input)
            })
            .unzip();
        Augmented {
            inputs,
            targets,
            moves: draws.iter().map(|&(motion, _)| motion).collect(),
        }
    }
}

/// Where the move `[angle, scale, dx, dy]` of a frame takes its point `p` (working pixels): the
/// forward map of the similarity a frame's picture is moved by.
pub fn moved_point([angle, scale, dx, dy]: [f32; 4], p: [f32; 2], size: usize) -> [f32; 2] {
    let centre = size as f32 / 2.0;
    let (s, c) = angle.sin_cos();
    let (x, y) = (p[0] - centre, p[1] - centre);
    [scale * (c * x - s * y) + centre + dx, scale * (s * x + c * y) + centre + dy]
}

/// `planes` `[4, size, size]` moved by the similarity `[angle, scale, dx, dy]` about the square's
/// centre (bilinear; transparent outside the square).
fn moved(planes: &[f32], size: usize, [angle, scale, dx, dy]: [f32; 4]) -> Vec<f32> {
    let n = size * size;
    let centre = size as f32 / 2.0;
    let (s, c) = angle.sin_cos();
    let mut out = vec![0.0; 4 * n];
    for y in 0..size {
        for x in 0..size {
            // The inverse map: this pixel's centre, unshifted, unturned and unscaled.
            let (px, py) = (x as f32 + 0.5 - centre - dx, y as f32 + 0.5 - centre - dy);
            let sx = (c * px + s * py) / scale + centre - 0.5;
            let sy = (-s * px + c * py) / scale + centre - 0.5;
            let (x0, y0) = (sx.floor(), sy.floor());
            let (fx, fy) = (sx - x0, sy - y0);
            // The four neighbours' offsets in a plane and bilinear weights; outside is transparent.
            let tap = |xi: f32, yi: f32, weight: f32| {
                let inside = xi >= 0.0 && yi >= 0.0 && xi < size as f32 && yi < size as f32;
                inside.then(|| (yi as usize * size + xi as usize, weight))
            };
            let taps = [
                tap(x0, y0, (1.0 - fx) * (1.0 - fy)),
                tap(x0 + 1.0, y0, fx * (1.0 - fy)),
                tap(x0, y0 + 1.0, (1.0 - fx) * fy),
                tap(x0 + 1.0, y0 + 1.0, fx * fy),
            ];
            for channel in 0..4 {
                let plane = &planes[channel * n..(channel + 1) * n];
                out[channel * n + y * size + x] = taps.iter().flatten().map(|&(k, w)| plane[k] * w).sum();
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An opaque square `[x0, x1)²` of colour (0.2, 0.5, 0.8) in a `size`² frame.
    fn square(size: usize, x0: usize, x1: usize) -> Vec<f32> {
        let n = size * size;
        let mut planes = vec![0.0; 4 * n];
        for y in x0..x1 {
            for x in x0..x1 {
                for (channel, v) in [0.2, 0.5, 0.8, 1.0].into_iter().enumerate() {
                    planes[channel * n + y * size + x] = v;
                }
            }
        }
        planes
    }

    #[test]
    fn no_move_keeps_the_frame_and_a_whole_pixel_shift_moves_it_exactly() {
        let (size, frame) = (16, square(16, 4, 8));
        assert_eq!(moved(&frame, size, [0.0, 1.0, 0.0, 0.0]), frame);
        let shifted = moved(&frame, size, [0.0, 1.0, 3.0, -2.0]);
        let n = size * size;
        for y in 0..size {
            for x in 0..size {
                let inside = (7..11).contains(&x) && (2..6).contains(&y);
                assert_eq!(shifted[3 * n + y * size + x], if inside { 1.0 } else { 0.0 }, "({x}, {y})");
            }
        }
        // A quarter turn about the centre maps the square [4, 8)² to [8, 12) × [4, 8).
        let turned = moved(&frame, size, [std::f32::consts::FRAC_PI_2, 1.0, 0.0, 0.0]);
        let alpha = |p: &[f32], x: usize, y: usize| p[3 * n + y * size + x];
        assert!((alpha(&turned, 9, 5) - 1.0).abs() < 1e-5 && alpha(&turned, 5, 5) < 1e-5);
        // The square's centre goes where the picture's square went, for vertices moved alike.
        let close = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-5;
        assert!(close(
            moved_point([std::f32::consts::FRAC_PI_2, 1.0, 0.0, 0.0], [6.0, 6.0], size),
            [10.0, 6.0]
        ));
        assert!(close(moved_point([0.0, 1.0, 3.0, -2.0], [6.0, 6.0], size), [9.0, 4.0]));
        assert!(close(moved_point([0.0, 2.0, 0.0, 0.0], [6.0, 6.0], size), [4.0, 4.0]));
        // Doubling about the centre: [4, 8)² becomes [0, 8)².
        let doubled = moved(&frame, size, [0.0, 2.0, 0.0, 0.0]);
        assert!(alpha(&doubled, 1, 1) > 0.99 && alpha(&doubled, 9, 9) < 1e-5);
    }

    #[test]
    fn inputs_and_targets_move_alike_colours_only_in_the_input_and_steps_repeat() {
        let (size, frame) = (16, square(16, 4, 10));
        let augment = Augment {
            shift: 0.1,
            scale: 0.1,
            max_degrees: 10.0,
            colour: 0.2,
        };
        let a = augment.apply(&[&frame, &frame], size, 5, 7);
        let n = size * size;
        assert_eq!(a.inputs[0][3 * n..], a.targets[0][3 * n..], "alpha is moved alike");
        assert_ne!(a.inputs[0][..3 * n], a.targets[0][..3 * n], "the input's colours are jittered");
        assert_ne!(a.targets[0], a.targets[1], "each frame of a batch is moved its own way");
        assert_ne!(a.targets[0], frame, "the frame moved");
        for (c, alpha) in a.inputs[0][..3 * n].iter().zip(a.inputs[0][3 * n..].iter().cycle()) {
            assert!(*c <= alpha + 1e-6, "premultiplied colour {c} past alpha {alpha}");
        }
        let again = augment.apply(&[&frame, &frame], size, 5, 7);
        assert_eq!((a.inputs, a.targets), (again.inputs, again.targets), "a function of seed and step");
        assert!(Augment::default().is_off() && Augment { colour: 1.5, ..augment }.validate().is_err());
    }
}
