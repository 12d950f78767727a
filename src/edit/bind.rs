//! Binding an image point to the fitted puppet by barycentric coordinates (neural-puppet.md §4.2:
//! "each user-selected control point p_i can now be found on the surface of the puppet mesh …
//! we use barycentric coordinates of the triangle that encloses p_i"; §4.3 uses the same binding
//! to carry points from one frame to another).
//!
//! A point is bound to the front-most layer whose deformed triangle contains it — what the
//! viewer sees there. Points a little outside every triangle (a click on the anti-aliased
//! outline) snap to the nearest triangle within [`SNAP_DISTANCE`] pixels; farther points are
//! not on the character.

use crate::error::{Error, Result};
use crate::geom::triangle::{barycentric, closest_on_segment};
use crate::puppet::Puppet;

/// How far (pixels) outside the mesh a point may be and still bind to its nearest triangle.
pub const SNAP_DISTANCE: f32 = 1.5;

/// A point expressed on the puppet: `p(v) = Σ_k weights[k] · v[vertices[k]]` (eq. 7's `p_i(v)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Binding {
    /// Index of the layer the point lies on.
    pub layer: usize,
    /// The enclosing triangle's corners, in the puppet's global vertex numbering.
    pub vertices: [u32; 3],
    /// Barycentric weights (sum 1; all ≥ 0 for a point inside the triangle).
    pub weights: [f32; 3],
}

impl Binding {
    /// The vertex `vertex` (global numbering) of layer `layer` itself.
    pub fn at_vertex(layer: usize, vertex: u32) -> Self {
        Binding {
            layer,
            vertices: [vertex; 3],
            weights: [1.0, 0.0, 0.0],
        }
    }

    /// The bound point's position on a pose `vertices` (global numbering, any pixel space that
    /// is an affine image of the one it was bound in).
    ///
    /// # Panics
    /// If `vertices` is shorter than the puppet it was bound on (a caller bug).
    pub fn position(&self, vertices: &[[f32; 2]]) -> [f32; 2] {
        let mut p = [0.0f32; 2];
        for (k, &v) in self.vertices.iter().enumerate() {
            let q = vertices[v as usize];
            p[0] += self.weights[k] * q[0];
            p[1] += self.weights[k] * q[1];
        }
        p
    }
}

/// Binds point `p` to the pose `vertices` of `puppet` (global numbering, same pixel space as
/// `p`): front-most layer first; within [`SNAP_DISTANCE`] of a triangle if no triangle contains it.
///
/// # Errors
/// [`Error::Mismatch`] if `vertices` is not one position per puppet vertex, [`Error::Geometry`]
/// if `p` is not finite or the puppet has no triangle, [`Error::OffCharacter`] if `p` is farther
/// than [`SNAP_DISTANCE`] from every triangle (with the nearest layer and its distance).
pub fn bind(puppet: &Puppet, vertices: &[[f32; 2]], p: [f32; 2]) -> Result<Binding> {
    if vertices.len() != puppet.vertex_count() {
        return Err(Error::mismatch(
            "bind: the pose's vertex count",
            vertices.len(),
            puppet.vertex_count(),
        ));
    }
    if !p[0].is_finite() || !p[1].is_finite() {
        return Err(Error::geometry(format!("point ({}, {})", p[0], p[1]), "is not finite"));
    }
    let offsets = puppet.vertex_offsets();
    // (distance, binding) of the nearest triangle seen so far, front to back.
    let mut nearest: Option<(f32, Binding)> = None;
    for (l, layer) in puppet.layers.iter().enumerate().rev() {
        for t in &layer.mesh.triangles {
            let g = t.map(|i| (offsets[l] + i as usize) as u32);
            let corners = g.map(|i| vertices[i as usize]);
            let Some(w) = barycentric(corners, p) else { continue };
            let binding = Binding {
                layer: l,
                vertices: g,
                weights: w,
            };
            if w.iter().all(|&x| x >= -1e-5) {
                return Ok(binding);
            }
            let d = distance_to_triangle(corners, p);
            if nearest.as_ref().is_none_or(|(best, _)| d < *best) {
                // Clamp to the triangle so the snapped point lies on the mesh.
                let q = closest_point(corners, p);
                let wq = barycentric(corners, q).unwrap_or(w);
                nearest = Some((d, Binding { weights: wq, ..binding }));
            }
        }
    }
    match nearest {
        Some((d, b)) if d <= SNAP_DISTANCE => Ok(b),
        Some((d, b)) => Err(Error::OffCharacter {
            point: p,
            nearest: Some((puppet.layers[b.layer].name.clone(), d)),
        }),
        None => Err(Error::geometry("bind: the puppet", "has no triangle")),
    }
}

/// The point of triangle `t` (edges included) closest to `p`.
fn closest_point(t: [[f32; 2]; 3], p: [f32; 2]) -> [f32; 2] {
    (0..3)
        .map(|k| closest_on_segment(t[k], t[(k + 1) % 3], p))
        .min_by(|a, b| dist2(*a, p).total_cmp(&dist2(*b, p)))
        .unwrap_or(t[0])
}

/// Distance from `p` to triangle `t` when `p` is outside it.
fn distance_to_triangle(t: [[f32; 2]; 3], p: [f32; 2]) -> f32 {
    dist2(closest_point(t, p), p).sqrt()
}

fn dist2(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::layered_puppet;

    #[test]
    fn points_bind_to_the_front_layer_and_reproduce_themselves() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let mut rng = crate::test_util::Rng::new(6);
        let mut bound = 0;
        for _ in 0..400 {
            let p = [
                rng.uniform(0.0, puppet.width as f64) as f32,
                rng.uniform(0.0, puppet.height as f64) as f32,
            ];
            let Ok(b) = bind(&puppet, &rest, p) else { continue };
            bound += 1;
            let q = b.position(&rest);
            assert!(dist2(p, q).sqrt() <= SNAP_DISTANCE + 1e-3, "{p:?} → {q:?}");
            assert!((b.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
            // No layer in front of the bound one contains p.
            let offsets = puppet.vertex_offsets();
            for l in b.layer + 1..puppet.layers.len() {
                for t in &puppet.layers[l].mesh.triangles {
                    let c = t.map(|i| rest[offsets[l] + i as usize]);
                    if let Some(w) = barycentric(c, p) {
                        assert!(w.iter().any(|&x| x < -1e-4), "{p:?} is inside front layer {l}");
                    }
                }
            }
        }
        assert!(bound > 50, "only {bound} of 400 random points landed on the puppet");
    }

    #[test]
    fn a_bound_point_follows_an_affine_motion_of_the_mesh() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let centre = rest[0];
        let b = bind(&puppet, &rest, [centre[0] + 0.3, centre[1] + 0.2]).unwrap();
        let f = |p: [f32; 2]| [1.1 * p[0] - 0.2 * p[1] + 3.0, 0.3 * p[0] + 0.9 * p[1] - 1.0];
        let moved: Vec<[f32; 2]> = rest.iter().map(|&p| f(p)).collect();
        let want = f(b.position(&rest));
        let got = b.position(&moved);
        assert!(dist2(want, got) < 1e-6, "{want:?} vs {got:?}");
    }

    #[test]
    fn points_off_the_character_are_refused_with_the_distance() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let err = bind(&puppet, &rest, [-40.0, -40.0]).unwrap_err().to_string();
        assert!(err.contains("not on the character") && err.contains("px away"), "{err}");
        assert!(bind(&puppet, &rest, [f32::NAN, 1.0]).is_err());
        assert!(bind(&puppet, &rest[1..], [1.0, 1.0]).is_err());
    }
}
