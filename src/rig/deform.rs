//! Deforming accessories (accessory-rigs.md §3.5): in topological order, each pin's target is
//! its parent's deformed mesh at the pin's point (barycentric in a parent triangle), and the
//! accessory moves by its bounded biharmonic weights. With [`Skinning::Translation`] (the
//! paper's) `v_i = rest_i + Σ_j w_ij d_j`, `d_j` the target's displacement from where it is on
//! the parent at rest — so the rest pose is kept exactly, also for a pin bound by projection just
//! outside its parent. With [`Skinning::Affine`] `v_i = Σ_j w_ij A_j(rest_i)`, `A_j` the affine
//! map of pin `j`'s parent triangle from rest to pose, evaluated at the accessory vertex (its
//! barycentric coordinates in that triangle, outside it as well): the rest pose is kept because
//! each `A_j` is the identity there, and an affine motion of the parent is reproduced exactly
//! because every `A_j` is then that motion and the weights sum to one. BBW weights are not
//! local (a vertex between two pins also leans on farther ones), so translations alone let a
//! turned or widened head pull the accessory's rim off the outline it covers.
//!
//! Every step is linear in the body's vertices, so the whole rig is one sparse affine map
//! `accessories = M · body + c` ([`RigMap`]); a constant displacement of the body translates
//! every accessory exactly (the weights are a partition of unity). [`deform`] adds two steps
//! that are not linear and so not part of the map: the single-point constraint can also turn the
//! child with its parent ([`PointMotion::Turn`]; the paper's translates it), and an accessory
//! whose skinning turns a triangle over is polished by ARAP with its pins held (the issue's
//! fold repair; translation-only skinning of a rotation can fold a mesh near its pins).

use crate::geom::triangle::{barycentric, closest_on_segment};
use crate::puppet::rig_data::{Constraint, RigData, Skinning};
use crate::puppet::{LayerKind, Mesh, Puppet};

/// How a layer held by single-point pins only moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PointMotion {
    /// Translates with the pin (the paper).
    #[default]
    Translate,
    /// Also turns by the parent triangle's rotation at the pin, so glasses tilt with a head (a
    /// rig with [`Skinning::Affine`] turns them so already, and this adds nothing).
    Turn,
}

/// Binds point `p` to `mesh`: the triangle holding it and its barycentric coordinates, or, if
/// no triangle holds it, those of its projection onto the nearest triangle.
///
/// # Panics
/// If the mesh has no triangle (a caller bug: meshes of built layers always have one).
pub fn bind_point(mesh: &Mesh, p: [f32; 2]) -> (u32, [f32; 3]) {
    let corners = |t: &[u32; 3]| t.map(|i| mesh.vertices[i as usize]);
    let mut best: Option<(f32, u32, [f32; 2])> = None;
    for (k, t) in mesh.triangles.iter().enumerate() {
        let c = corners(t);
        if let Some(w) = barycentric(c, p) {
            if w.iter().all(|&x| x >= -1e-6) {
                return (k as u32, w);
            }
        }
        for e in 0..3 {
            let q = closest_on_segment(c[e], c[(e + 1) % 3], p);
            let d = (q[0] - p[0]).hypot(q[1] - p[1]);
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, k as u32, q));
            }
        }
    }
    let (_, k, q) = best.expect("a mesh to bind to has triangles");
    let w = barycentric(corners(&mesh.triangles[k as usize]), q).unwrap_or([1.0 / 3.0; 3]);
    // The projection lies on an edge: clamp rounding so the weights stay a convex combination.
    let clamped = w.map(|x| x.max(0.0));
    let sum: f32 = clamped.iter().sum();
    (k, clamped.map(|x| x / sum))
}

/// The rig as a sparse affine map from every vertex position (global numbering; only body
/// vertices have non-zero columns) to each accessory vertex: `v_i = Σ_k m_ik x_k + c_i`, the same
/// for the x and y coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct RigMap {
    /// Global indices of the accessory vertices, in the order of the rows.
    pub rows: Vec<usize>,
    /// Per row, (global body vertex, coefficient) pairs.
    pub coefficients: Vec<Vec<(usize, f32)>>,
    /// Per row, the constant `c_i` (pixels).
    pub offsets: Vec<[f32; 2]>,
}

impl RigMap {
    /// The map of `rig` on `puppet` (see the module doc).
    pub fn new(puppet: &Puppet, rig: &RigData) -> Self {
        let offsets_of = puppet.vertex_offsets();
        // Each vertex's affine expression over body vertices: body vertices are themselves.
        let mut expressions: Vec<Option<Affine>> = vec![None; puppet.vertex_count()];
        for (l, layer) in puppet.layers.iter().enumerate() {
            if layer.kind == LayerKind::Body {
                for v in 0..layer.mesh.vertices.len() {
                    expressions[offsets_of[l] + v] = Some((vec![(offsets_of[l] + v, 1.0)], [0.0, 0.0]));
                }
            }
        }
        let mut map = RigMap {
            rows: Vec::new(),
            coefficients: Vec::new(),
            offsets: Vec::new(),
        };
        for acc in &rig.accessories {
            let layer = &puppet.layers[acc.layer];
            // Each pin's target as an expression (its parent triangle's corners, blended), and
            // where that point is at rest.
            let targets: Vec<(Affine, [f32; 2])> = acc
                .pins
                .iter()
                .map(|pin| {
                    let parent = &puppet.layers[pin.parent].mesh;
                    let tri = parent.triangles[pin.triangle as usize];
                    let mut terms = Vec::new();
                    let (mut constant, mut rest) = ([0.0f32; 2], [0.0f32; 2]);
                    for (corner, &b) in tri.iter().zip(&pin.weights) {
                        let (t, c) = expressions[offsets_of[pin.parent] + *corner as usize]
                            .as_ref()
                            .expect("parents come before their children");
                        terms.extend(t.iter().map(|&(k, m)| (k, m * b)));
                        constant = [constant[0] + b * c[0], constant[1] + b * c[1]];
                        let r = parent.vertices[*corner as usize];
                        rest = [rest[0] + b * r[0], rest[1] + b * r[1]];
                    }
                    ((merge(terms), constant), rest)
                })
                .collect();
            for (v, row) in acc.weights.iter().enumerate() {
                let rest = layer.mesh.vertices[v];
                let mut terms = Vec::new();
                // Translations: rest + Σ w_j d_j. Affine: Σ w_j A_j(rest), written as rest plus
                // each pin's w_j (A_j(rest) − rest), since the weights sum to one.
                let mut constant = rest;
                for &(j, w) in row {
                    let pin = &acc.pins[j as usize];
                    let parent = &puppet.layers[pin.parent].mesh;
                    let tri = parent.triangles[pin.triangle as usize];
                    // The vertex in the pin's parent triangle; a degenerate triangle has no
                    // affine map, and its pin then translates the vertex.
                    let affine = (rig.skinning == Skinning::Affine)
                        .then(|| barycentric(tri.map(|i| parent.vertices[i as usize]), rest))
                        .flatten();
                    if let Some(at) = affine {
                        constant = [constant[0] - w * rest[0], constant[1] - w * rest[1]];
                        for (corner, &b) in tri.iter().zip(&at) {
                            let (t, c) = expressions[offsets_of[pin.parent] + *corner as usize]
                                .as_ref()
                                .expect("parents come before their children");
                            terms.extend(t.iter().map(|&(k, m)| (k, m * w * b)));
                            constant = [constant[0] + w * b * c[0], constant[1] + w * b * c[1]];
                        }
                    } else {
                        let ((t, c), pin_rest) = &targets[j as usize];
                        terms.extend(t.iter().map(|&(k, m)| (k, m * w)));
                        constant = [constant[0] + w * (c[0] - pin_rest[0]), constant[1] + w * (c[1] - pin_rest[1])];
                    }
                }
                let terms = merge(terms);
                let g = offsets_of[acc.layer] + v;
                expressions[g] = Some((terms.clone(), constant));
                map.rows.push(g);
                map.coefficients.push(terms);
                map.offsets.push(constant);
            }
        }
        map
    }

    /// Fills the accessory vertices of `pose` (global numbering) from its body vertices.
    ///
    /// # Panics
    /// If `pose` is not one position per vertex of the puppet the map was made for.
    pub fn apply(&self, pose: &mut [[f32; 2]]) {
        for ((&row, terms), c) in self.rows.iter().zip(&self.coefficients).zip(&self.offsets) {
            let mut p = *c;
            for &(k, m) in terms {
                p[0] += m * pose[k][0];
                p[1] += m * pose[k][1];
            }
            pose[row] = p;
        }
    }
}

/// An affine expression over body vertices: (global body vertex, coefficient) terms and a
/// constant, pixels.
type Affine = (Vec<(usize, f32)>, [f32; 2]);

/// Sums the coefficients of repeated indices, sorted by index, dropping zeros.
fn merge(mut terms: Vec<(usize, f32)>) -> Vec<(usize, f32)> {
    terms.sort_by_key(|&(k, _)| k);
    let mut out: Vec<(usize, f32)> = Vec::with_capacity(terms.len());
    for (k, m) in terms {
        match out.last_mut() {
            Some(last) if last.0 == k => last.1 += m,
            _ => out.push((k, m)),
        }
    }
    out.retain(|&(_, m)| m != 0.0);
    out
}

/// How [`deform`] moves accessories beyond the linear map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeformOptions {
    /// How layers held by single points only move.
    pub point_motion: PointMotion,
    /// ARAP iterations polishing an accessory whose skinning turned a triangle over (0: none).
    pub polish_iterations: usize,
}

impl Default for DeformOptions {
    fn default() -> Self {
        DeformOptions {
            point_motion: PointMotion::Translate,
            polish_iterations: 20,
        }
    }
}

/// `pose` (global numbering) with its accessories moved by `rig` from its body vertices (the
/// accessory entries of `pose` are ignored): the linear map, then the options' extra steps.
/// With [`PointMotion::Turn`], an accessory whose pins are all single points also turns by its
/// first pin's parent triangle's rotation.
///
/// # Panics
/// If `pose` is not one position per vertex of `puppet`.
pub fn deform(puppet: &Puppet, rig: &RigData, pose: &[[f32; 2]], options: &DeformOptions) -> Vec<[f32; 2]> {
    let mut out = pose.to_vec();
    RigMap::new(puppet, rig).apply(&mut out);
    if options.polish_iterations > 0 {
        polish(puppet, rig, &mut out, options.polish_iterations);
    }
    // Affine skinning turns a point-pinned layer with its parent triangle already.
    if options.point_motion == PointMotion::Turn && rig.skinning == Skinning::Translation {
        let offsets = puppet.vertex_offsets();
        for acc in &rig.accessories {
            let Some(pin) = acc
                .pins
                .first()
                .filter(|_| acc.pins.iter().all(|p| p.constraint == Constraint::Point))
            else {
                continue;
            };
            let parent = &puppet.layers[pin.parent];
            let tri = parent.mesh.triangles[pin.triangle as usize];
            let rest: [[f32; 2]; 3] = tri.map(|i| parent.mesh.vertices[i as usize]);
            let moved: [[f32; 2]; 3] = tri.map(|i| out[offsets[pin.parent] + i as usize]);
            let angle = rotation(rest, moved);
            let layer = &puppet.layers[acc.layer];
            let anchor = out[offsets[acc.layer] + pin.vertex as usize];
            let (s, c) = angle.sin_cos();
            for v in 0..layer.mesh.vertices.len() {
                let p = out[offsets[acc.layer] + v];
                let d = [p[0] - anchor[0], p[1] - anchor[1]];
                out[offsets[acc.layer] + v] = [anchor[0] + c * d[0] - s * d[1], anchor[1] + s * d[0] + c * d[1]];
            }
        }
    }
    out
}

/// ARAP (w.r.t. its rest mesh) on each accessory with a triangle turned over in `pose`, its pin
/// vertices held where the skinning put them, starting from the skinned positions.
fn polish(puppet: &Puppet, rig: &RigData, pose: &mut [[f32; 2]], iterations: usize) {
    let offsets = puppet.vertex_offsets();
    for acc in &rig.accessories {
        let mesh = &puppet.layers[acc.layer].mesh;
        let range = offsets[acc.layer]..offsets[acc.layer + 1];
        let signed = |p: &[[f32; 2]], t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        };
        let folded = mesh
            .triangles
            .iter()
            .any(|t| signed(&pose[range.clone()], t) * signed(&mesh.vertices, t) <= 0.0);
        if !folded {
            continue;
        }
        let rest: Vec<[f64; 2]> = mesh.vertices.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
        let handles: Vec<u32> = acc.pins.iter().map(|p| p.vertex).collect();
        // A mesh the ARAP system cannot be set up on (it always can for a rigged accessory: every
        // piece has a pin) is left as skinned.
        let Ok(mut solver) = crate::geom::ArapSolver::new(&rest, &mesh.triangles, &handles) else {
            continue;
        };
        let current: Vec<[f64; 2]> = pose[range.clone()].iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
        let targets: Vec<[f64; 2]> = handles.iter().map(|&h| current[h as usize]).collect();
        let solved = solver.solve(&targets, iterations, &current);
        for (p, q) in pose[range].iter_mut().zip(solved) {
            *p = [q[0] as f32, q[1] as f32];
        }
    }
}

/// The angle of the best-fit rotation taking triangle `a` to `b` (about their centroids).
fn rotation(a: [[f32; 2]; 3], b: [[f32; 2]; 3]) -> f32 {
    let centre = |t: [[f32; 2]; 3]| [(t[0][0] + t[1][0] + t[2][0]) / 3.0, (t[0][1] + t[1][1] + t[2][1]) / 3.0];
    let (ca, cb) = (centre(a), centre(b));
    let (mut cross, mut dot) = (0.0f32, 0.0f32);
    for k in 0..3 {
        let p = [a[k][0] - ca[0], a[k][1] - ca[1]];
        let q = [b[k][0] - cb[0], b[k][1] - cb[1]];
        dot += p[0] * q[0] + p[1] * q[1];
        cross += p[0] * q[1] - p[1] * q[0];
    }
    cross.atan2(dot)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_bind_inside_a_triangle_or_by_projection() {
        let mesh = Mesh {
            vertices: vec![[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]],
            triangles: vec![[0, 1, 2]],
        };
        let (t, w) = bind_point(&mesh, [1.0, 1.0]);
        assert_eq!(t, 0);
        assert!((w[1] - 0.25).abs() < 1e-6 && (w[2] - 0.25).abs() < 1e-6);
        // Outside, beyond the hypotenuse: projected onto it.
        let (_, w) = bind_point(&mesh, [3.0, 3.0]);
        assert!(w[0].abs() < 1e-6 && (w[1] - 0.5).abs() < 1e-5 && (w[2] - 0.5).abs() < 1e-5, "{w:?}");
    }

    #[test]
    fn affine_skinning_carries_an_affine_motion_of_the_body_exactly_and_translations_do_not() {
        let mut puppet = crate::test_util::dressed_puppet();
        let rest = puppet.rest_vertices();
        let accessories = puppet.accessory_vertices();
        // A turn of 0.3 rad with a stretch and a shear, about a point off the character.
        let motion = |p: [f32; 2]| {
            let (s, c) = 0.3f32.sin_cos();
            let q = [1.15 * p[0] + 0.1 * p[1], 0.9 * p[1]];
            [c * q[0] - s * q[1] + 4.0, s * q[0] + c * q[1] - 7.0]
        };
        let moved: Vec<[f32; 2]> = rest.iter().map(|&p| motion(p)).collect();
        let error = |puppet: &Puppet| {
            let mut pose = moved.clone();
            for &k in &accessories {
                pose[k] = [f32::NAN; 2];
            }
            RigMap::new(puppet, puppet.rig.as_ref().unwrap()).apply(&mut pose);
            accessories
                .iter()
                .map(|&k| (pose[k][0] - moved[k][0]).hypot(pose[k][1] - moved[k][1]))
                .fold(0.0f32, f32::max)
        };
        assert_eq!(puppet.rig.as_ref().unwrap().skinning, Skinning::Translation, "the default");
        puppet.rig.as_mut().unwrap().skinning = Skinning::Affine;
        let affine = error(&puppet);
        assert!(affine < 1e-3, "{affine}");
        puppet.rig.as_mut().unwrap().skinning = Skinning::Translation;
        let translation = error(&puppet);
        assert!(translation > 0.5, "{translation}");
        // Both keep the rest pose.
        for skinning in [Skinning::Translation, Skinning::Affine] {
            puppet.rig.as_mut().unwrap().skinning = skinning;
            let mut pose = rest.clone();
            RigMap::new(&puppet, puppet.rig.as_ref().unwrap()).apply(&mut pose);
            assert!(crate::test_util::largest_distance(&pose, &rest) < 1e-3, "{skinning:?}");
        }
    }

    #[test]
    fn the_best_fit_rotation_of_a_turned_triangle_is_its_angle() {
        let a = [[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]];
        let turn = 0.3f32;
        let (s, c) = turn.sin_cos();
        let b = a.map(|p| [5.0 + c * p[0] - s * p[1], 2.0 + s * p[0] + c * p[1]]);
        assert!((rotation(a, b) - turn).abs() < 1e-5);
    }
}
