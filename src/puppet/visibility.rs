//! Which vertices of a posed puppet the picture shows: a vertex is hidden when it lies inside a
//! triangle of a layer drawn in front of its own. Hidden vertices get no evidence from the
//! image (a back arm behind the torso can turn freely at no cost): `puppet eval` reports vertex
//! error and PCK over the visible vertices beside the figures over all of them, and a fit places
//! the limbs its frame hides from the ones it shows.

use crate::geom::triangle::contains;
use crate::puppet::Puppet;

/// A triangle's corners and its bounding box `[x0, y0, x1, y1]`.
type BoxedTriangle = ([[f32; 2]; 3], [f32; 4]);

/// One flag per vertex of `puppet` (global numbering): whether it is visible at `positions`
/// (the pose, global numbering; normally the TRUE pose of a synthetic frame).
///
/// # Panics
/// If `positions` is not one point per vertex (a caller bug).
pub fn visible_vertices(puppet: &Puppet, positions: &[[f32; 2]]) -> Vec<bool> {
    assert_eq!(positions.len(), puppet.vertex_count(), "one position per vertex");
    let offsets = puppet.vertex_offsets();
    // Each layer's triangles in this pose with their bounding boxes, for a cheap rejection test.
    let layers: Vec<Vec<BoxedTriangle>> = puppet
        .layers
        .iter()
        .enumerate()
        .map(|(l, layer)| {
            layer
                .mesh
                .triangles
                .iter()
                .map(|t| {
                    let c = t.map(|i| positions[offsets[l] + i as usize]);
                    let xs = c.map(|p| p[0]);
                    let ys = c.map(|p| p[1]);
                    let min = |v: [f32; 3]| v.into_iter().fold(f32::INFINITY, f32::min);
                    let max = |v: [f32; 3]| v.into_iter().fold(f32::NEG_INFINITY, f32::max);
                    (c, [min(xs), min(ys), max(xs), max(ys)])
                })
                .collect()
        })
        .collect();
    let mut visible = Vec::with_capacity(positions.len());
    for l in 0..puppet.layers.len() {
        for &p in &positions[offsets[l]..offsets[l + 1]] {
            let covered = layers[l + 1..]
                .iter()
                .flatten()
                .any(|(t, b)| p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3] && contains(*t, p, 0.0));
            visible.push(!covered);
        }
    }
    visible
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::puppet::Puppet;
    use crate::test_util::rect_layer;

    fn two_squares() -> Puppet {
        let f = (20, 20);
        let grey = |_: f32, _: f32| [0.5; 3];
        Puppet {
            width: f.0,
            height: f.1,
            layers: vec![
                rect_layer("back", f, [0.0, 0.0, 10.0, 10.0], (4, 4), grey),
                rect_layer("front", f, [5.0, 5.0, 15.0, 15.0], (4, 4), grey),
            ],
            root: 0,
            joints: Vec::new(),
            rig: None,
        }
    }

    #[test]
    fn vertices_under_a_front_layer_are_hidden_and_the_rest_visible() {
        // Back square [0,10]², front square [5,15]²: back vertices inside the front square are
        // covered (those on its edges count as covered too); the front square never is.
        let puppet = two_squares();
        let rest: Vec<[f32; 2]> = puppet.layers.iter().flat_map(|l| l.mesh.vertices.clone()).collect();
        let visible = visible_vertices(&puppet, &rest);
        let offsets = puppet.vertex_offsets();
        for (i, &p) in rest.iter().enumerate() {
            let back = i < offsets[1];
            let inside_front = p[0] >= 5.0 && p[0] <= 15.0 && p[1] >= 5.0 && p[1] <= 15.0;
            assert_eq!(visible[i], !(back && inside_front), "vertex {i} at {p:?}");
        }
        // Moving the front square away uncovers everything.
        let moved: Vec<[f32; 2]> = rest
            .iter()
            .enumerate()
            .map(|(i, &p)| if i >= offsets[1] { [p[0] + 100.0, p[1]] } else { p })
            .collect();
        assert!(visible_vertices(&puppet, &moved).iter().all(|&v| v));
    }
}
