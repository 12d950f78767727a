//! The plausibility term of a fit (issue 19; not in neural-puppet.md): each limb's turn about its
//! joint, relative to the layer it hangs from, kept inside the range the training frames showed,
//! widened by a margin. A frame the template cannot draw (a back view, a prop it lacks) otherwise
//! pulls limbs wherever they cover some pixels — the limb search tries turns up to ±120° — and
//! the fit contorts; held to the trained range it degrades to the nearest pose the character
//! takes. The limb search skips turns that leave the range, and the latent and vertex steps add
//! a penalty on the excess.
//!
//! Turns are measured as [`LimbTurns`] does; being linear in the posed vertices before the
//! `atan2`, the penalty is a product with one constant matrix.

use std::f32::consts::PI;

use burn::tensor::{Device, Tensor, TensorData};

use crate::puppet::limbs::{circular_mean, wrap, Limb, LimbTurns};
use crate::puppet::Puppet;

/// Each limb's allowed turn relative to its parent layer: the range of a set of poses, widened.
#[derive(Clone, Debug, PartialEq)]
pub struct JointRanges {
    turns: LimbTurns,
    /// Per limb: the middle of its allowed turn and half the allowed width (radians; half ≥ π
    /// allows every turn).
    centre: Vec<f32>,
    half: Vec<f32>,
}

impl JointRanges {
    /// The ranges of `poses` (frame pixels, global numbering) of `puppet`, each widened by
    /// `margin_degrees` either way. With no pose, every limb is held to its rest turn ± margin.
    pub fn from_poses(puppet: &Puppet, poses: &[Vec<[f32; 2]>], margin_degrees: f32) -> Self {
        let measure = LimbTurns::new(puppet);
        let turns: Vec<Vec<f32>> = poses.iter().map(|p| measure.of(p)).collect();
        let margin = margin_degrees.to_radians();
        let (mut centre, mut half) = (Vec::new(), Vec::new());
        for k in 0..measure.limbs().len() {
            // The circular mean, then the extremes of each turn's difference from it.
            let mean = circular_mean(turns.iter().map(|t| t[k]));
            let (lo, hi) = turns
                .iter()
                .map(|t| wrap(t[k] - mean))
                .fold((0.0f32, 0.0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
            centre.push(wrap(mean + (lo + hi) / 2.0));
            half.push(((hi - lo) / 2.0 + margin).min(PI));
        }
        JointRanges {
            turns: measure,
            centre,
            half,
        }
    }

    /// Each limb's turn relative to its parent layer in `pose` (radians, in (−π, π]).
    pub fn turns(&self, pose: &[[f32; 2]]) -> Vec<f32> {
        self.turns.of(pose)
    }

    /// Limb `k`'s allowed turn relative to its parent layer: the middle and half the width
    /// (radians).
    pub fn range(&self, k: usize) -> (f32, f32) {
        (self.centre[k], self.half[k])
    }

    /// How far limb `k`'s relative turn `turn` lies outside its range (radians; 0 inside).
    pub fn excess(&self, k: usize, turn: f32) -> f32 {
        (wrap(turn - self.centre[k]).abs() - self.half[k]).max(0.0)
    }

    /// The limb of `pose` furthest outside its range: its layer and the excess in degrees
    /// (`None` if every limb is inside).
    pub fn worst(&self, pose: &[[f32; 2]]) -> Option<(usize, f32)> {
        self.turns(pose)
            .iter()
            .enumerate()
            .map(|(k, &t)| (self.turns.limbs()[k].layer, self.excess(k, t).to_degrees()))
            .filter(|&(_, e)| e > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The penalty on vertices `[B, V, 2]` (any frame a similarity without rotation away from
    /// the puppet's pixels, e.g. the working square), a batch mean: for each limb, with `c` the
    /// cosine of its turn's distance from the range's middle, `max(0, cos half − c)²`, summed
    /// over the limbs — zero inside every range, growing smoothly past its ends.
    pub fn penalty(&self, vertices: Tensor<3>, device: &Device) -> Tensor<1> {
        let [batch, count, _] = vertices.dims();
        let (offsets, centred_rest, limbs) = (self.turns.offsets(), self.turns.centred_rest(), self.turns.limbs());
        let layers = offsets.len() - 1;
        if limbs.is_empty() {
            return Tensor::zeros([1], device);
        }
        // dot = x·Rx + y·Ry and cross = y·Rx − x·Ry, per layer, with R the centred rest of that
        // layer's vertices (zero elsewhere).
        let (mut rx, mut ry) = (vec![0.0f32; count * layers], vec![0.0f32; count * layers]);
        for (l, w) in offsets.windows(2).enumerate() {
            for i in w[0]..w[1].min(count) {
                rx[i * layers + l] = centred_rest[i][0];
                ry[i * layers + l] = centred_rest[i][1];
            }
        }
        let matrix = |m: Vec<f32>| Tensor::<2>::from_data(TensorData::new(m, [count, layers]), device);
        let (rx, ry) = (matrix(rx), matrix(ry));
        let x: Tensor<2> = vertices.clone().narrow(2, 0, 1).reshape([batch, count]);
        let y: Tensor<2> = vertices.narrow(2, 1, 1).reshape([batch, count]);
        let dot = x.clone().matmul(rx.clone()) + y.clone().matmul(ry.clone());
        let cross = y.matmul(rx) - x.matmul(ry);
        let norm = (dot.clone().powf_scalar(2.0) + cross.clone().powf_scalar(2.0))
            .add_scalar(1e-12)
            .sqrt();
        let (cos, sin) = (dot / norm.clone(), cross / norm);
        let pick = |t: &Tensor<2>, f: fn(&Limb) -> usize| {
            let index: Vec<i64> = limbs.iter().map(|l| f(l) as i64).collect();
            let n = index.len();
            t.clone()
                .select(1, Tensor::<1, burn::tensor::Int>::from_data(TensorData::new(index, [n]), device))
        };
        let (cl, sl) = (pick(&cos, |l| l.layer), pick(&sin, |l| l.layer));
        let (cp, sp) = (pick(&cos, |l| l.parent), pick(&sin, |l| l.parent));
        // The turn relative to the parent, then its cosine of distance from the range's middle.
        let (cd, sd) = (cl.clone() * cp.clone() + sl.clone() * sp.clone(), sl * cp - cl * sp);
        let n = limbs.len();
        let row = |v: Vec<f32>| Tensor::<2>::from_data(TensorData::new(v, [1, n]), device);
        let (cm, sm) = (
            row(self.centre.iter().map(|m| m.cos()).collect()),
            row(self.centre.iter().map(|m| m.sin()).collect()),
        );
        let limit = row(self.half.iter().map(|h| h.cos()).collect());
        let c = cd * cm + sd * sm;
        let excess = (limit - c).clamp_min(0.0);
        excess.powf_scalar(2.0).sum_dim(1).mean()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::puppet::limbs::limbs;
    use crate::test_util::hinged_puppet;

    fn turned(puppet: &Puppet, degrees: f32) -> Vec<[f32; 2]> {
        let mut pose = puppet.rest_vertices();
        limbs(puppet)[0].turn(&mut pose, degrees.to_radians());
        pose
    }

    #[test]
    fn a_limbs_turn_is_measured_relative_to_its_parent_and_ranges_widen_the_poses_seen() {
        let puppet = hinged_puppet();
        let ranges = JointRanges::from_poses(&puppet, &[turned(&puppet, -10.0), turned(&puppet, 30.0)], 15.0);
        let t = ranges.turns(&turned(&puppet, 25.0))[0].to_degrees();
        assert!((t - 25.0).abs() < 1e-3, "{t}");
        // The whole figure turned: no limb turns relative to its parent.
        let mut spun = turned(&puppet, 25.0);
        let c = spun[0];
        for p in &mut spun {
            let (s, co) = 0.8f32.sin_cos();
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            *p = [c[0] + co * dx - s * dy, c[1] + s * dx + co * dy];
        }
        assert!((ranges.turns(&spun)[0].to_degrees() - 25.0).abs() < 1e-3);
        // Seen: −10° to 30°, widened by 15°: −25° to 45°.
        for (degrees, outside) in [(-24.0, 0.0), (44.0, 0.0), (55.0, 10.0), (-45.0, 20.0), (170.0, 125.0)] {
            let e = ranges.worst(&turned(&puppet, degrees)).map_or(0.0, |(layer, e)| {
                assert_eq!(layer, limbs(&puppet)[0].layer);
                e
            });
            assert!((e - outside).abs() < 1e-2, "{degrees}°: {e}° outside, expected {outside}°");
        }
        let free = JointRanges::from_poses(&puppet, &[turned(&puppet, -100.0), turned(&puppet, 100.0)], 0.0);
        assert_eq!(free.worst(&turned(&puppet, 180.0)), None, "a range of 200° + the other side");
    }

    #[test]
    fn the_penalty_is_zero_inside_grows_outside_and_its_gradient_matches_finite_differences() {
        let puppet = hinged_puppet();
        let device = crate::backend::device();
        let ranges = JointRanges::from_poses(&puppet, &[turned(&puppet, 0.0)], 20.0);
        let count = puppet.vertex_count();
        let as_tensor = |pose: &[[f32; 2]]| {
            let flat: Vec<f32> = pose.iter().flatten().copied().collect();
            Tensor::<3>::from_data(TensorData::new(flat, [1, count, 2]), &device)
        };
        let value = |pose: &[[f32; 2]]| -> f32 { ranges.penalty(as_tensor(pose), &device).into_data().try_to_vec::<f32>().unwrap()[0] };
        assert_eq!(value(&turned(&puppet, 15.0)), 0.0);
        let (a, b) = (value(&turned(&puppet, 40.0)), value(&turned(&puppet, 70.0)));
        let expect = |d: f32| (20f32.to_radians().cos() - d.to_radians().cos()).powi(2);
        assert!((a - expect(40.0)).abs() < 1e-4 && (b - expect(70.0)).abs() < 1e-4, "{a} {b}");
        // Gradient against central differences, at a pose off the range with noise on it.
        let mut pose = turned(&puppet, 50.0);
        let mut rng = crate::rng::Rng::new(4);
        for p in &mut pose {
            *p = [p[0] + rng.range(-0.5, 0.5), p[1] + rng.range(-0.5, 0.5)];
        }
        let x = as_tensor(&pose).autodiff().require_grad();
        let grads = ranges.penalty(x.clone(), &device).backward();
        let g: Vec<f32> = x.grad(&grads).unwrap().into_data().try_to_vec::<f32>().unwrap();
        let eps = 1e-2;
        let mut checked = 0;
        for i in (0..count).step_by((count / 12).max(1)) {
            for axis in 0..2 {
                let shifted = |d: f32| {
                    let mut q = pose.clone();
                    q[i][axis] += d;
                    f64::from(value(&q))
                };
                let numeric = (shifted(eps) - shifted(-eps)) / (2.0 * f64::from(eps));
                let analytic = f64::from(g[2 * i + axis]);
                assert!(
                    (numeric - analytic).abs() <= 2e-3 * numeric.abs().max(analytic.abs()) + 1e-5,
                    "vertex {i} axis {axis}: {analytic} vs {numeric}"
                );
                checked += usize::from(analytic != 0.0);
            }
        }
        assert!(checked > 0, "some vertex feels the penalty");
    }
}
