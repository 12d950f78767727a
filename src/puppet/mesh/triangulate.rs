//! Constrained Delaunay triangulation of a layer's rings, refined to quality (neural-puppet.md
//! §3.1 "standard triangulation algorithm [52]"; Ruppert 1995 / Chew refinement as implemented
//! by spade's `ConstrainedDelaunayTriangulation::refine`).
//!
//! Ring edges are constraint edges; triangles outside the part or inside holes (even winding)
//! are excluded from refinement and dropped. Refinement inserts circumcentres and splits
//! encroached segments until every triangle has all angles ≥ the limit and area ≤ the bound;
//! angles between input segments that are already smaller than the limit cannot be improved and
//! are left (spade keeps the small-angle fans of Miller–Pav–Walkington). Required points are
//! inserted before refinement; refinement only adds vertices, so they stay exact vertices.

use std::collections::HashMap;

use spade::{AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation};

use super::contour::{inside_rings, signed_area};
use super::{MeshError, MeshOptions};
use crate::puppet::Mesh;

/// Refinement is refused when it would need more than this many vertices.
pub const MAX_VERTICES: usize = 20_000_000;

/// Triangulates the region bounded by `rings` (even-odd) with every point of `required` as a
/// vertex, refined to `opts.min_angle` degrees and `opts.max_area` px².
///
/// Returns a mesh with counter-clockwise triangles (positive [`Mesh::signed_area`]), no unused
/// vertex, and for each required point the index of its vertex.
///
/// # Errors
/// [`MeshError::Options`] for rings with fewer than 3 points, non-finite or out-of-range
/// coordinates, crossing edges, or a bound needing more than [`MAX_VERTICES`] vertices;
/// [`MeshError::TooSmall`] if no triangle is inside; [`MeshError::PointOutside`] for a required
/// point outside the region.
pub fn triangulate(rings: &[Vec<[f64; 2]>], required: &[[f64; 2]], opts: &MeshOptions) -> Result<(Mesh, Vec<u32>), MeshError> {
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    let mut area = 0.0;
    let mut points = 0;
    for (r, ring) in rings.iter().enumerate() {
        if ring.len() < 3 {
            return Err(MeshError::Options(format!("ring {r} has {} point(s), expected at least 3", ring.len())));
        }
        area += signed_area(ring).abs();
        points += ring.len();
        let handles = ring
            .iter()
            .map(|p| {
                cdt.insert(Point2::new(p[0], p[1]))
                    .map_err(|e| MeshError::Options(format!("ring {r}: point ({}, {}) rejected: {e:?}", p[0], p[1])))
            })
            .collect::<Result<Vec<_>, _>>()?;
        for k in 0..handles.len() {
            let (a, b) = (handles[k], handles[(k + 1) % handles.len()]);
            if a != b && cdt.try_add_constraint(a, b).is_empty() {
                let p = ring[k];
                return Err(MeshError::Options(format!("ring {r}: the edge from ({}, {}) crosses another ring edge", p[0], p[1])));
            }
        }
    }
    if area <= 0.0 {
        return Err(MeshError::TooSmall { problem: format!("the rings enclose no area ({points} points)") });
    }
    let mut required_handles = Vec::with_capacity(required.len());
    for &p in required {
        let outside = || MeshError::PointOutside { x: p[0] as f32, y: p[1] as f32 };
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(outside());
        }
        if !inside_rings(rings, p) && !on_rings(rings, p) {
            return Err(outside());
        }
        required_handles.push(cdt.insert(Point2::new(p[0], p[1])).map_err(|_| outside())?);
    }
    let max_area = f64::from(opts.max_area);
    let estimate = 10.0 * points as f64 + 8.0 * area / max_area + 64.0;
    if estimate > MAX_VERTICES as f64 {
        return Err(MeshError::Options(format!(
            "max_area {max_area} px² is too small for a part of {area:.0} px² (more than {MAX_VERTICES} vertices)"
        )));
    }
    let params = RefinementParameters::<f64>::new()
        .exclude_outer_faces(true)
        .with_angle_limit(AngleLimit::from_deg(f64::from(opts.min_angle)))
        .with_max_allowed_area(max_area)
        .with_max_additional_vertices(estimate as usize);
    let result = cdt.refine(params);
    if !result.refinement_complete {
        return Err(MeshError::Options(format!(
            "refinement to {}° and {max_area} px² did not finish within {} added vertices",
            opts.min_angle, estimate as usize
        )));
    }
    let mut excluded = vec![false; cdt.num_all_faces()];
    for f in &result.excluded_faces {
        excluded[f.index()] = true;
    }
    let mut index = HashMap::new();
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    let mut id = |v: spade::handles::FixedVertexHandle, vertices: &mut Vec<[f32; 2]>| {
        *index.entry(v).or_insert_with(|| {
            let p = cdt.vertex(v).position();
            vertices.push([p.x as f32, p.y as f32]);
            (vertices.len() - 1) as u32
        })
    };
    for face in cdt.inner_faces() {
        if excluded[face.fix().index()] {
            continue;
        }
        let t = face.vertices().map(|v| id(v.fix(), &mut vertices));
        triangles.push(t);
    }
    if triangles.is_empty() {
        return Err(MeshError::TooSmall { problem: format!("no triangle inside the rings ({area:.2} px², {points} points)") });
    }
    let required = required_handles.iter().map(|&h| id(h, &mut vertices)).collect();
    Ok((Mesh { vertices, triangles }, required))
}

/// Whether `p` lies on a ring edge (within 1e-9 px).
fn on_rings(rings: &[Vec<[f64; 2]>], p: [f64; 2]) -> bool {
    rings.iter().any(|ring| {
        (0..ring.len()).any(|k| {
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let t = if len2 > 0.0 { (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let q = [a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]];
            q[0] * q[0] + q[1] * q[1] <= 1e-18
        })
    })
}
