//! Midpoint subdivision of a layer mesh (neural-puppet.md §3.1: a finer mesh gives the
//! deformation network more freedom): every triangle becomes four similar ones.

use std::collections::HashMap;

use crate::puppet::Mesh;

/// Splits every triangle `(a, b, c)` into `(a, ab, ca)`, `(ab, b, bc)`, `(ca, bc, c)` and
/// `(ab, bc, ca)`, where `ab` is the midpoint of edge `a b`.
///
/// Vertices keep their indices; each edge's midpoint is added once (shared by both triangles
/// of an interior edge) after them, in order of first use. `T` triangles become `4T`; angles are
/// unchanged and areas quartered; winding is kept.
pub fn subdivide(mesh: &Mesh) -> Mesh {
    let mut vertices = mesh.vertices.clone();
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 2);
    let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<[f32; 2]>| {
        *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (p, q) = (vertices[a as usize], vertices[b as usize]);
            vertices.push([(p[0] + q[0]) * 0.5, (p[1] + q[1]) * 0.5]);
            (vertices.len() - 1) as u32
        })
    };
    let mut triangles = Vec::with_capacity(mesh.triangles.len() * 4);
    for &[a, b, c] in &mesh.triangles {
        let ab = midpoint(a, b, &mut vertices);
        let bc = midpoint(b, c, &mut vertices);
        let ca = midpoint(c, a, &mut vertices);
        triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    Mesh { vertices, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Mesh {
        Mesh {
            vertices: vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
        }
    }

    #[test]
    fn four_triangles_per_triangle_and_shared_midpoints() {
        let mut m = square();
        // Make the winding positive for this crate's convention first.
        m.triangles = m
            .triangles
            .iter()
            .map(|&[a, b, c]| if m.signed_area([a, b, c]) > 0.0 { [a, b, c] } else { [a, c, b] })
            .collect();
        m.check_invariants().unwrap();
        let s = subdivide(&m);
        assert_eq!(s.triangles.len(), 8);
        // 4 corners + 5 edges (4 sides + the shared diagonal).
        assert_eq!(s.vertices.len(), 9);
        assert_eq!(&s.vertices[..4], &m.vertices[..]);
        s.check_invariants().unwrap();
        let s2 = subdivide(&s);
        assert_eq!(s2.triangles.len(), 32);
        // (2^2 + 1)^2 grid points.
        assert_eq!(s2.vertices.len(), 25);
        s2.check_invariants().unwrap();
        assert!((s2.min_angle_degrees() - m.min_angle_degrees()).abs() < 1e-3);
        let total: f32 = s2.triangles.iter().map(|&t| s2.signed_area(t)).sum();
        assert!((total - 16.0).abs() < 1e-4);
    }
}
