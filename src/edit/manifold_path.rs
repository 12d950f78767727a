//! A latent path that follows the learned manifold (issue 19; not in neural-puppet.md): the
//! straight line between two keyframes' latents cuts across the manifold — between two walk
//! poses a quarter of a cycle apart it passes near no pose the character takes — while the
//! frames the model was trained on are points on it. The path goes from one keyframe to the
//! other through the training frames' latents (waypoints) wherever that is shorter in the sum of
//! squared steps between poses (a step half as long counts a quarter: the path takes waypoints
//! that lie between the keyframes and skips those off to the side), piecewise linear in latent
//! space, and is timed by the distance its poses travel. With no waypoint between the keyframes
//! it is the straight line.

use burn::tensor::{Device, Tensor};

use crate::error::Result;
use crate::model::Model;
use crate::picture::Picture;

/// Points the path may pass through: latents `[1, Z]` and their decodes (frame pixels).
#[derive(Clone, Debug)]
pub struct Waypoints {
    latents: Vec<Tensor<2>>,
    poses: Vec<Vec<[f32; 2]>>,
}

impl Waypoints {
    /// The encoder's latents of `frames` (the frames the model was trained on: their latents
    /// decode to poses on the manifold), decoded by `model`.
    ///
    /// # Errors
    /// As [`Model::encode`].
    pub fn of_frames(model: &Model, frames: &[&Picture], device: &Device) -> Result<Self> {
        if frames.is_empty() {
            return Ok(Waypoints {
                latents: Vec::new(),
                poses: Vec::new(),
            });
        }
        Ok(Self::of_latents(model, model.encode(frames, device)?, device))
    }

    /// The latents `[N, Z]` (the training frames' encodings), decoded by `model` — the model
    /// that encoded them or the same body in another outfit.
    pub fn of_latents(model: &Model, z: Tensor<2>, device: &Device) -> Self {
        let [n, _] = z.dims();
        let poses = if n == 0 {
            Vec::new()
        } else {
            model.to_frame_vertices(model.decode(z.clone(), device))
        };
        let latents = (0..n).map(|k| z.clone().narrow(0, k, 1)).collect();
        Waypoints { latents, poses }
    }

    /// How many waypoints there are.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }
}

/// A waypoint closer than this share of the keyframes' distance to either keyframe is skipped.
const NEAR: f32 = 0.2;

/// The mean distance between two poses' vertices (frame pixels). (The root mean square, which
/// weighs the few vertices that move most, timed the walks' in-betweens worse: docs/results.md
/// "In-betweens along the manifold".)
fn distance(a: &[[f32; 2]], b: &[[f32; 2]]) -> f32 {
    let sum: f32 = a.iter().zip(b).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).sum();
    sum / a.len().max(1) as f32
}

/// A path from one latent to another through waypoints: its corners and their arc lengths.
#[derive(Clone, Debug)]
pub struct ManifoldPath {
    /// The corners' latents, `[1, Z]` each, from the first keyframe's to the second's.
    corners: Vec<Tensor<2>>,
    /// The corners' poses (frame pixels): the decodes of their latents.
    poses: Vec<Vec<[f32; 2]>>,
    /// The distance travelled (frame pixels) at each corner, from 0.
    arc: Vec<f32>,
}

impl ManifoldPath {
    /// The path from `(z_a, pose_a)` to `(z_b, pose_b)` (latents `[1, Z]` and their decodes)
    /// minimising the sum of squared distances between consecutive poses over paths through any
    /// of `waypoints` (Dijkstra on the complete graph).
    pub fn new(z_a: Tensor<2>, pose_a: &[[f32; 2]], z_b: Tensor<2>, pose_b: &[[f32; 2]], waypoints: &Waypoints) -> Self {
        // Nodes: 0 = a, 1..=N the waypoints, N + 1 = b.
        let n = waypoints.len();
        let pose = |k: usize| -> &[[f32; 2]] {
            match k {
                0 => pose_a,
                k if k == n + 1 => pose_b,
                k => &waypoints.poses[k - 1],
            }
        };
        let nodes = n + 2;
        // A waypoint beside a keyframe (the keyframe itself, when it is a training frame) adds
        // no pose between them, only the difference between its latent and the key's.
        let span = distance(pose_a, pose_b);
        let beside_a_key: Vec<bool> = (0..nodes)
            .map(|k| (1..=n).contains(&k) && distance(pose(k), pose_a).min(distance(pose(k), pose_b)) < NEAR * span)
            .collect();
        let (mut cost, mut previous, mut done) = (vec![f32::INFINITY; nodes], vec![usize::MAX; nodes], vec![false; nodes]);
        cost[0] = 0.0;
        for _ in 0..nodes {
            let Some(u) = (0..nodes).filter(|&k| !done[k]).min_by(|&x, &y| cost[x].total_cmp(&cost[y])) else {
                break;
            };
            done[u] = true;
            if u == n + 1 {
                break;
            }
            for v in (0..nodes).filter(|&k| !done[k] && !beside_a_key[k]) {
                let c = cost[u] + distance(pose(u), pose(v)).powi(2);
                if c < cost[v] {
                    (cost[v], previous[v]) = (c, u);
                }
            }
        }
        let mut order = vec![n + 1];
        while let Some(&last) = order.last() {
            if last == 0 || previous[last] == usize::MAX {
                break;
            }
            order.push(previous[last]);
        }
        order.reverse();
        let latent = |k: usize| match k {
            0 => z_a.clone(),
            k if k == n + 1 => z_b.clone(),
            k => waypoints.latents[k - 1].clone(),
        };
        let mut arc = vec![0.0];
        for w in order.windows(2) {
            arc.push(arc[arc.len() - 1] + distance(pose(w[0]), pose(w[1])));
        }
        ManifoldPath {
            corners: order.iter().map(|&k| latent(k)).collect(),
            poses: order.iter().map(|&k| pose(k).to_vec()).collect(),
            arc,
        }
    }

    /// How many waypoints the path passes through.
    pub fn waypoints(&self) -> usize {
        self.corners.len().saturating_sub(2)
    }

    /// The corners' poses, from the first keyframe's decode to the second's.
    pub fn corner_poses(&self) -> &[Vec<[f32; 2]>] {
        &self.poses
    }

    /// Where `t` (0: the first keyframe, 1: the second) falls on the path, spread by the
    /// distance travelled: the segment from corner `k` to `k + 1`, and the share along it.
    pub fn segment(&self, t: f32) -> (usize, f32) {
        let s = t.clamp(0.0, 1.0) * self.arc[self.arc.len() - 1];
        // The segment holding s (the last one for s at the end).
        let k = self.arc.partition_point(|&a| a <= s).clamp(1, self.arc.len() - 1) - 1;
        let length = self.arc[k + 1] - self.arc[k];
        (
            k,
            if length > 0.0 {
                ((s - self.arc[k]) / length).clamp(0.0, 1.0)
            } else {
                0.0
            },
        )
    }

    /// The latents `[T, Z]` at each of `t` ([`Self::segment`]).
    pub fn latents(&self, t: &[f32], device: &Device) -> Tensor<2> {
        let rows: Vec<Tensor<2>> = t
            .iter()
            .map(|&t| {
                let (k, share) = self.segment(t);
                self.corners[k].clone().mul_scalar(1.0 - share) + self.corners[k + 1].clone().mul_scalar(share)
            })
            .collect();
        if rows.is_empty() {
            return Tensor::zeros([0, self.corners[0].dims()[1]], device);
        }
        Tensor::cat(rows, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::TensorData;

    fn latent(x: f32, y: f32, device: &Device) -> Tensor<2> {
        Tensor::from_data(TensorData::new(vec![x, y], [1, 2]), device)
    }

    /// Waypoints whose "decode" is the latent itself, as a one-vertex pose.
    fn points(xy: &[[f32; 2]], device: &Device) -> Waypoints {
        Waypoints {
            latents: xy.iter().map(|p| latent(p[0], p[1], device)).collect(),
            poses: xy.iter().map(|&p| vec![p]).collect(),
        }
    }

    fn rows(t: Tensor<2>) -> Vec<[f32; 2]> {
        let v = t.into_data().try_to_vec::<f32>().unwrap();
        v.chunks(2).map(|c| [c[0], c[1]]).collect()
    }

    #[test]
    fn the_path_bends_through_waypoints_between_the_keys_and_skips_the_others() {
        let device = crate::backend::device();
        // From (0, 0) to (4, 0): (2, 1) lies between (5 < 16 twice over), (2, 3) does not
        // (13 + 13 > 16), nor does (9, 0) beyond the end.
        let waypoints = points(&[[2.0, 3.0], [9.0, 0.0], [2.0, 1.0]], &device);
        let path = ManifoldPath::new(
            latent(0.0, 0.0, &device),
            &[[0.0, 0.0]],
            latent(4.0, 0.0, &device),
            &[[4.0, 0.0]],
            &waypoints,
        );
        assert_eq!(path.waypoints(), 1);
        let half = 5f32.sqrt();
        let at = rows(path.latents(&[0.0, 0.25, 0.5, 1.0], &device));
        let close = |p: [f32; 2], q: [f32; 2]| (p[0] - q[0]).abs() < 1e-5 && (p[1] - q[1]).abs() < 1e-5;
        assert!(close(at[0], [0.0, 0.0]) && close(at[3], [4.0, 0.0]), "{at:?}");
        assert!(close(at[2], [2.0, 1.0]), "halfway along, the waypoint: {at:?}");
        let quarter = [2.0 * 0.5, 0.5];
        assert!(close(at[1], quarter), "a quarter of {} along: {at:?}", 2.0 * half);
        // No waypoint between: the straight line.
        let straight = ManifoldPath::new(
            latent(0.0, 0.0, &device),
            &[[0.0, 0.0]],
            latent(4.0, 0.0, &device),
            &[[4.0, 0.0]],
            &points(&[[2.0, 3.0]], &device),
        );
        assert_eq!(straight.waypoints(), 0);
        assert!(close(rows(straight.latents(&[0.25], &device))[0], [1.0, 0.0]));
    }
}
