//! The limbs of a puppet: for each joint leading away from the root layer, the child layer and
//! every layer hanging from it, which turn together about the joint. Turning a limb rigidly
//! about its joint keeps the joint welded and costs nothing in ARAP; the limb search of a fit
//! and the poses sampled for training both pose a puppet this way.

use std::f32::consts::PI;

use super::Puppet;

/// One limb: the layers that turn together about a joint.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limb {
    /// The layer at the limb's root, turning about its joint with `parent`.
    pub layer: usize,
    /// The layer it hangs from (one step nearer the puppet's root layer).
    pub parent: usize,
    /// Global index of the child layer's joint vertex: the pivot.
    pub pivot: usize,
    /// Global vertex indices of the child layer and every layer hanging from it.
    pub vertices: Vec<usize>,
}

impl Limb {
    /// Turns the limb's vertices of `pose` (global numbering) by `angle` radians about the
    /// pivot's place in `pose`.
    pub fn turn(&self, pose: &mut [[f32; 2]], angle: f32) {
        let (s, c) = angle.sin_cos();
        let [px, py] = pose[self.pivot];
        for &v in &self.vertices {
            let [x, y] = pose[v];
            let (dx, dy) = (x - px, y - py);
            pose[v] = [px + c * dx - s * dy, py + s * dx + c * dy];
        }
    }
}

/// The limbs of `puppet` in breadth-first order from its root layer (a parent's limb before
/// its children's, so turning them in order turns each child about its pivot as already
/// moved).
pub fn limbs(puppet: &Puppet) -> Vec<Limb> {
    let n = puppet.layers.len();
    let offsets = puppet.vertex_offsets();
    // Layer adjacency through joints, with the joint's vertex on each side.
    let mut links: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    for j in &puppet.joints {
        links[j.a.layer].push((j.b.layer, puppet.global_index(j.b)));
        links[j.b.layer].push((j.a.layer, puppet.global_index(j.a)));
    }
    let mut parent = vec![usize::MAX; n];
    let mut order = vec![puppet.root];
    parent[puppet.root] = puppet.root;
    let mut pivots = vec![0usize; n];
    let mut k = 0;
    while k < order.len() {
        let layer = order[k];
        for &(next, pivot) in &links[layer] {
            if parent[next] == usize::MAX {
                parent[next] = layer;
                pivots[next] = pivot;
                order.push(next);
            }
        }
        k += 1;
    }
    let below = |layer: usize| -> Vec<usize> {
        // Layers whose chain of parents passes through `layer`.
        (0..n)
            .filter(|&l| {
                let mut at = l;
                while parent[at] != usize::MAX && at != puppet.root {
                    if at == layer {
                        return true;
                    }
                    at = parent[at];
                }
                false
            })
            .collect()
    };
    order
        .iter()
        .skip(1)
        .map(|&layer| Limb {
            layer,
            parent: parent[layer],
            pivot: pivots[layer],
            vertices: below(layer)
                .into_iter()
                .flat_map(|l| offsets[l]..offsets[l] + puppet.layers[l].mesh.vertices.len())
                .collect(),
        })
        .collect()
}

/// Measures each limb's turn about its joint relative to the layer it hangs from. A layer's turn
/// is the rotation of the least-squares similarity taking its rest vertices to posed ones:
/// `atan2(Σ r̃ × p, Σ r̃ · p)` with `r̃` the rest vertices less their centroid. Both sums are
/// linear in the posed vertices (a differentiable penalty on turns is a product with one matrix).
#[derive(Clone, Debug, PartialEq)]
pub struct LimbTurns {
    limbs: Vec<Limb>,
    centred_rest: Vec<[f32; 2]>,
    offsets: Vec<usize>,
}

impl LimbTurns {
    /// The turns of `puppet`'s [`limbs`].
    pub fn new(puppet: &Puppet) -> Self {
        let offsets = puppet.vertex_offsets();
        let mut centred_rest = puppet.rest_vertices();
        for w in offsets.windows(2) {
            let part = &mut centred_rest[w[0]..w[1]];
            let n = part.len().max(1) as f32;
            let mean = part.iter().fold([0.0, 0.0], |m, p| [m[0] + p[0] / n, m[1] + p[1] / n]);
            for p in part {
                *p = [p[0] - mean[0], p[1] - mean[1]];
            }
        }
        LimbTurns {
            limbs: limbs(puppet),
            centred_rest,
            offsets,
        }
    }

    /// The limbs, in the order of [`limbs`] (a parent's before its children's).
    pub fn limbs(&self) -> &[Limb] {
        &self.limbs
    }

    /// Each vertex's rest place less its layer's rest centroid (global numbering).
    pub fn centred_rest(&self) -> &[[f32; 2]] {
        &self.centred_rest
    }

    /// Where each layer's vertices start in the global numbering, and the total last.
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// Each layer's turn from its rest pose in `pose` (global numbering; radians, in (−π, π]).
    pub fn layer_turns(&self, pose: &[[f32; 2]]) -> Vec<f32> {
        self.offsets
            .windows(2)
            .map(|w| {
                let (dot, cross) = (w[0]..w[1]).fold((0.0f32, 0.0f32), |(d, c), i| {
                    let (r, p) = (self.centred_rest[i], pose[i]);
                    (d + r[0] * p[0] + r[1] * p[1], c + r[0] * p[1] - r[1] * p[0])
                });
                cross.atan2(dot)
            })
            .collect()
    }

    /// Each limb's turn relative to its parent layer in `pose` (global numbering; radians, in
    /// (−π, π]).
    pub fn of(&self, pose: &[[f32; 2]]) -> Vec<f32> {
        let layer = self.layer_turns(pose);
        self.limbs.iter().map(|l| wrap(layer[l.layer] - layer[l.parent])).collect()
    }
}

/// The angle in (−π, π] equal to `a` modulo 2π.
pub fn wrap(a: f32) -> f32 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// The circular mean of `angles` (radians; 0 for none).
pub fn circular_mean(angles: impl Iterator<Item = f32>) -> f32 {
    let (s, c) = angles.fold((0.0f32, 0.0f32), |(s, c), a| (s + a.sin(), c + a.cos()));
    s.atan2(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::hinged_puppet;

    #[test]
    fn a_turned_limb_keeps_its_pivot_and_its_distances_and_the_rest_stays() {
        let puppet = hinged_puppet();
        let rest = puppet.rest_vertices();
        let limbs = limbs(&puppet);
        assert!(!limbs.is_empty(), "the test puppet has a joint");
        let limb = &limbs[0];
        let mut pose = rest.clone();
        limb.turn(&mut pose, 0.7);
        assert_eq!(pose[limb.pivot], rest[limb.pivot]);
        for (v, (a, b)) in pose.iter().zip(&rest).enumerate() {
            let moved = (a[0] - b[0]).hypot(a[1] - b[1]);
            if limb.vertices.contains(&v) {
                let d = |p: &[f32; 2], q: &[f32; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
                assert!((d(a, &pose[limb.pivot]) - d(b, &rest[limb.pivot])).abs() < 1e-4, "vertex {v}");
            } else {
                assert_eq!(moved, 0.0, "vertex {v} is not on the limb");
            }
        }
        assert!(limb.vertices.iter().any(|&v| pose[v] != rest[v]), "the limb turned");
    }
}
