//! The limbs of a puppet: for each joint leading away from the root layer, the child layer and
//! every layer hanging from it, which turn together about the joint. Turning a limb rigidly
//! about its joint keeps the joint welded and costs nothing in ARAP; the limb search of a fit
//! and the poses sampled for training both pose a puppet this way.

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
