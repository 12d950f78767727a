//! The sticker baseline: each accessory vertex moves with the body point under it.

use super::edits::body_layers;
use super::scene::{position, Bound};
use crate::puppet::{LayerKind, Puppet};
use crate::rig::deform::bind_point;

/// The sticker baseline's bindings: each accessory vertex in the front-most body layer under it
/// (or off the nearest body layer, keeping its offset from that layer's nearest point).
pub(super) struct Sticker {
    /// (global accessory vertex, the body point it follows, its offset from that point at rest).
    bound: Vec<(usize, Bound, [f32; 2])>,
}

impl Sticker {
    /// Binds every accessory vertex of `puppet` at rest.
    pub(super) fn new(puppet: &Puppet) -> Self {
        let offsets = puppet.vertex_offsets();
        let bodies: Vec<usize> = body_layers(puppet).collect();
        let rest = puppet.rest_vertices();
        let mut bound = Vec::new();
        for (l, layer) in puppet.layers.iter().enumerate() {
            if layer.kind == LayerKind::Body {
                continue;
            }
            for (v, &p) in layer.mesh.vertices.iter().enumerate() {
                let holding = bodies.iter().rev().find(|&&b| {
                    let m = &puppet.layers[b].mesh;
                    m.triangles
                        .iter()
                        .any(|t| crate::geom::triangle::contains(t.map(|i| m.vertices[i as usize]), p, 0.0))
                });
                let b = holding.copied().unwrap_or_else(|| {
                    *bodies
                        .iter()
                        .min_by(|&&x, &&y| nearest(puppet, x, p).total_cmp(&nearest(puppet, y, p)))
                        .expect("a puppet has a body layer")
                });
                let (t, w) = bind_point(&puppet.layers[b].mesh, p);
                let tri = puppet.layers[b].mesh.triangles[t as usize].map(|i| offsets[b] + i as usize);
                let at = position(&(tri, w), &rest);
                bound.push((offsets[l] + v, (tri, w), [p[0] - at[0], p[1] - at[1]]));
            }
        }
        Sticker { bound }
    }

    /// The accessories of a pose of the body `body` (global numbering; accessory entries ignored).
    pub(super) fn apply(&self, body: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let mut out = body.to_vec();
        for (v, point, offset) in &self.bound {
            let at = position(point, body);
            out[*v] = [at[0] + offset[0], at[1] + offset[1]];
        }
        out
    }
}

/// The distance from `p` to the nearest vertex of layer `l`.
fn nearest(puppet: &Puppet, l: usize, p: [f32; 2]) -> f32 {
    puppet.layers[l]
        .mesh
        .vertices
        .iter()
        .map(|q| (q[0] - p[0]).hypot(q[1] - p[1]))
        .fold(f32::INFINITY, f32::min)
}
