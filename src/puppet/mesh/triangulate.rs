//! Constrained Delaunay triangulation of a layer's rings, refined to quality (neural-puppet.md
//! §3.1 "standard triangulation algorithm \[52\]"; Ruppert 1995 / Chew refinement as implemented
//! by spade's `ConstrainedDelaunayTriangulation::refine`).
//!
//! Ring edges are constraint edges; triangles outside the part or inside holes (even winding)
//! are excluded from refinement and dropped. Refinement inserts circumcentres and splits
//! encroached segments until every triangle has all angles ≥ the limit and area ≤ the bound;
//! angles between input segments that are already smaller than the limit cannot be improved and
//! are left (spade keeps the small-angle fans of Miller–Pav–Walkington). Required points are
//! inserted before refinement; refinement only adds vertices, so they stay exact vertices.
//!
//! Before refinement the interior is seeded with an equilateral lattice sized to the area bound
//! (bulk-loaded with the rings), so refinement only works along the boundary: on the 248-point
//! robot polygon at ~5,000 vertices this took the time from 27.4 ms to ~10 ms (see
//! bench/README.md).
//!
//! Known limit, measured: spade does not refine a skinny triangle whose shortest edge joins two
//! Steiner points split from segments that share an input vertex, even when that input angle
//! is wide, so the minimum angle can end a little under the bound (29.81° for 30° on a 2048²
//! wavy annulus; ≥ 29.74° on 120 random pixel masks with bounds up to 32°).

use spade::{AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation};

use super::contour::{inside_rings, signed_area};
use super::simplify::segment_distance;
use super::{MeshError, MeshOptions};
use crate::puppet::Mesh;

/// Refinement is refused when it would need more than this many vertices.
pub const MAX_VERTICES: usize = 20_000_000;

/// The lower angle bounds (degrees) a refinement that does not finish is tried again with.
pub const FALLBACK_ANGLES: [f32; 2] = [20.0, 0.0];

/// Interior lattice seeds closer than this many lattice spacings to a ring edge are dropped.
pub const LATTICE_MARGIN: f64 = 0.5;

/// Triangulates the region bounded by `rings` (even-odd) with every point of `required` as a
/// vertex, refined to `opts.min_angle` degrees and `opts.max_area` px².
///
/// Returns a mesh with counter-clockwise triangles (positive [`Mesh::signed_area`]), no unused
/// vertex, and for each required point the index of its vertex. A refinement that does not
/// finish within its vertex budget is run again under each of [`FALLBACK_ANGLES`] in turn.
///
/// # Errors
/// [`MeshError::Options`] for rings with fewer than 3 points, non-finite or out-of-range
/// coordinates, a point repeated, crossing edges, a bound needing more than [`MAX_VERTICES`]
/// vertices, or a refinement that does not finish within its vertex budget even at the lowest
/// fallback angle; [`MeshError::TooSmall`] if the rings enclose no area or features are too close for
/// f32 output; [`MeshError::PointOutside`] for a required point outside the region.
///
/// # Panics
/// Not by this code; spade's `refine` has an `expect` for a circumcentre it cannot insert
/// after loss of precision, never observed in the tests.
pub fn triangulate(rings: &[Vec<[f64; 2]>], required: &[[f64; 2]], opts: &MeshOptions) -> Result<(Mesh, Vec<u32>), MeshError> {
    let mut area = 0.0;
    let mut vertices = Vec::new();
    let mut edges = Vec::new();
    for (r, ring) in rings.iter().enumerate() {
        if ring.len() < 3 {
            return Err(MeshError::Options(format!(
                "ring {r} has {} point(s), expected at least 3",
                ring.len()
            )));
        }
        if let Some(p) = ring.iter().find(|p| !(p[0].abs() <= 1e12 && p[1].abs() <= 1e12)) {
            return Err(MeshError::Options(format!(
                "ring {r}: point ({}, {}) is not a finite pixel position",
                p[0], p[1]
            )));
        }
        area += signed_area(ring).abs();
        let first = vertices.len();
        for k in 0..ring.len() {
            edges.push([first + k, first + (k + 1) % ring.len()]);
        }
        vertices.extend(ring.iter().map(|p| Point2::new(p[0], p[1])));
    }
    let points = vertices.len();
    if area <= 0.0 {
        return Err(MeshError::TooSmall {
            problem: format!("the rings enclose no area ({points} points)"),
        });
    }
    let mut sorted: Vec<[f64; 2]> = rings.iter().flatten().copied().collect();
    sorted.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(MeshError::Options(format!(
            "the point ({}, {}) appears twice in the rings",
            w[0][0], w[0][1]
        )));
    }
    let max_area = f64::from(opts.max_area);
    let estimate = 10.0 * points as f64 + 32.0 * area / max_area + 256.0 + 4096.0 * required.len() as f64;
    if estimate > MAX_VERTICES as f64 {
        return Err(MeshError::Options(format!(
            "max_area {max_area} px² is too small for a part of {area:.0} px² (more than {MAX_VERTICES} vertices)"
        )));
    }
    vertices.extend(lattice(rings, max_area).into_iter().map(|p| Point2::new(p[0], p[1])));
    // Thin strokes (line art's lips, a nose drawn as one curve) can keep the refinement adding
    // vertices along their sharp tips without end; such a part is meshed again under a lower
    // angle bound rather than refused.
    let angles = std::iter::once(opts.min_angle).chain(FALLBACK_ANGLES.iter().map(|&a| a.min(opts.min_angle)));
    let mut refined = None;
    for angle in angles {
        let (mut cdt, required_handles) = constrained(vertices.clone(), edges.clone(), rings, required)?;
        let params = RefinementParameters::<f64>::new()
            .exclude_outer_faces(true)
            .with_angle_limit(AngleLimit::from_deg(f64::from(angle)))
            .with_max_allowed_area(max_area)
            .with_max_additional_vertices(estimate as usize);
        let result = cdt.refine(params);
        if result.refinement_complete {
            refined = Some((cdt, required_handles, result));
            break;
        }
    }
    let Some((cdt, required_handles, result)) = refined else {
        return Err(MeshError::Options(format!(
            "refinement to {}° and {max_area} px² did not finish within {} added vertices, nor at {:?}°",
            opts.min_angle, estimate as usize, FALLBACK_ANGLES
        )));
    };
    let mut excluded = vec![false; cdt.num_all_faces()];
    for f in &result.excluded_faces {
        excluded[f.index()] = true;
    }
    let mut index = vec![u32::MAX; cdt.num_vertices()];
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    let mut id = |v: spade::handles::FixedVertexHandle, vertices: &mut Vec<[f32; 2]>| {
        let slot = &mut index[v.index()];
        if *slot == u32::MAX {
            let p = cdt.vertex(v).position();
            vertices.push([p.x as f32, p.y as f32]);
            *slot = (vertices.len() - 1) as u32;
        }
        *slot
    };
    for face in cdt.inner_faces() {
        if excluded[face.fix().index()] {
            continue;
        }
        let t = face.vertices().map(|v| id(v.fix(), &mut vertices));
        triangles.push(t);
    }
    if triangles.is_empty() {
        return Err(MeshError::TooSmall {
            problem: format!("no triangle inside the rings ({area:.2} px², {points} points)"),
        });
    }
    let required = required_handles.iter().map(|&h| id(h, &mut vertices)).collect();
    let mesh = Mesh { vertices, triangles };
    // Refinement runs in f64; features far below a pixel (a required point 1e-9 px from an edge)
    // can make a triangle flat once rounded to f32. Refuse rather than return a broken mesh.
    if let Some(&t) = mesh.triangles.iter().find(|&&t| mesh.signed_area(t) <= 0.0) {
        let p = mesh.vertices[t[0] as usize];
        return Err(MeshError::TooSmall {
            problem: format!("features near ({}, {}) are closer than f32 precision can mesh", p[0], p[1]),
        });
    }
    Ok((mesh, required))
}

/// The constrained Delaunay triangulation of the ring `edges` over `vertices` (ring points, then
/// lattice seeds), with the `required` points inserted; their handles in order.
#[allow(clippy::type_complexity)]
fn constrained(
    vertices: Vec<Point2<f64>>,
    edges: Vec<[usize; 2]>,
    rings: &[Vec<[f64; 2]>],
    required: &[[f64; 2]],
) -> Result<
    (
        ConstrainedDelaunayTriangulation<Point2<f64>>,
        Vec<spade::handles::FixedVertexHandle>,
    ),
    MeshError,
> {
    let mut crossing = None;
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(vertices, edges, |e| {
        crossing.get_or_insert(e[0]);
    })
    .map_err(|e| MeshError::Options(format!("ring points rejected: {e:?}")))?;
    if let Some(v) = crossing {
        let p = cdt.vertex(spade::handles::FixedVertexHandle::from_index(v)).position();
        return Err(MeshError::Options(format!(
            "the ring edge from ({}, {}) crosses another ring edge",
            p.x, p.y
        )));
    }
    let mut required_handles = Vec::with_capacity(required.len());
    for &p in required {
        let outside = || MeshError::PointOutside {
            x: p[0] as f32,
            y: p[1] as f32,
        };
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(outside());
        }
        if !inside_rings(rings, p) && !on_rings(rings, p) {
            return Err(outside());
        }
        required_handles.push(cdt.insert(Point2::new(p[0], p[1])).map_err(|_| outside())?);
    }
    Ok((cdt, required_handles))
}

/// Seeds for the interior: an equilateral lattice whose triangles have area just under
/// `max_area`, clipped to the region (even-odd) and kept at least [`LATTICE_MARGIN`] spacings
/// away from every ring edge. Bulk-loading them before refinement leaves refinement only the
/// band along the boundary, which is much faster than growing the interior by circumcentre
/// insertion, and gives near-equilateral interior triangles.
fn lattice(rings: &[Vec<[f64; 2]>], max_area: f64) -> Vec<[f64; 2]> {
    let spacing = (4.0 * max_area / 3f64.sqrt()).sqrt() * 0.98;
    let row_step = spacing * 3f64.sqrt() / 2.0;
    let margin = LATTICE_MARGIN * spacing;
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in rings.iter().flatten() {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let rows = ((hi[1] - lo[1]) / row_step) as usize + 1;
    let cols = ((hi[0] - lo[0]) / spacing) as usize + 2;
    if (rows as f64) * (cols as f64) > MAX_VERTICES as f64 {
        return Vec::new();
    }
    let row_y = |r: usize| lo[1] + (r as f64 + 0.5) * row_step;
    // Crossings of each row with the ring edges, and the edges near each bucket of a grid.
    let mut crossings: Vec<Vec<f64>> = vec![Vec::new(); rows];
    let bucket = spacing.max(1e-9);
    let (bw, bh) = (((hi[0] - lo[0]) / bucket) as usize + 1, ((hi[1] - lo[1]) / bucket) as usize + 1);
    let mut near: Vec<Vec<([f64; 2], [f64; 2])>> = vec![Vec::new(); bw * bh];
    let cell = |v: f64, k: usize, count: usize| (((v - lo[k]) / bucket).max(0.0) as usize).min(count - 1);
    for ring in rings {
        for k in 0..ring.len() {
            let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
            let (ylo, yhi) = (a[1].min(b[1]), a[1].max(b[1]));
            let first = ((ylo - lo[1]) / row_step - 0.5).floor().max(0.0) as usize;
            for (r, row) in crossings.iter_mut().enumerate().skip(first) {
                let y = row_y(r);
                if y > yhi {
                    break;
                }
                if (a[1] > y) != (b[1] > y) {
                    row.push(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
                }
            }
            for by in cell(ylo - margin, 1, bh)..=cell(yhi + margin, 1, bh) {
                for bx in cell(a[0].min(b[0]) - margin, 0, bw)..=cell(a[0].max(b[0]) + margin, 0, bw) {
                    near[by * bw + bx].push((a, b));
                }
            }
        }
    }
    let mut seeds = Vec::new();
    for (r, row) in crossings.iter_mut().enumerate() {
        row.sort_by(f64::total_cmp);
        let y = row_y(r);
        let shift = if r % 2 == 0 { 0.0 } else { 0.5 * spacing };
        for pair in row.chunks_exact(2) {
            let first = ((pair[0] + margin - lo[0] - shift) / spacing).ceil().max(0.0) as usize;
            let mut x = lo[0] + shift + first as f64 * spacing;
            while x <= pair[1] - margin {
                let p = [x, y];
                let clear = near[cell(y, 1, bh) * bw + cell(x, 0, bw)]
                    .iter()
                    .all(|&(a, b)| segment_distance(p, a, b) >= margin);
                if clear {
                    seeds.push(p);
                }
                x += spacing;
            }
        }
    }
    seeds
}

/// Whether `p` lies on a ring edge (within 1e-9 px).
fn on_rings(rings: &[Vec<[f64; 2]>], p: [f64; 2]) -> bool {
    rings
        .iter()
        .any(|ring| (0..ring.len()).any(|k| segment_distance(p, ring[k], ring[(k + 1) % ring.len()]) <= 1e-9))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn star(cx: f64, cy: f64, r0: f64, r1: f64, points: usize) -> Vec<[f64; 2]> {
        (0..2 * points)
            .map(|k| {
                let a = std::f64::consts::PI * k as f64 / points as f64;
                let r = if k % 2 == 0 { r1 } else { r0 };
                [cx + r * a.cos(), cy + r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn lattice_seeds_are_inside_and_clear_of_the_rings() {
        let rings = vec![
            star(50.0, 50.0, 20.0, 45.0, 7),
            star(50.0, 50.0, 5.0, 10.0, 5).into_iter().rev().collect(),
        ];
        for max_area in [2.0, 10.0, 50.0] {
            let seeds = lattice(&rings, max_area);
            assert!(!seeds.is_empty());
            let spacing = (4.0 * max_area / 3f64.sqrt()).sqrt() * 0.98;
            for &p in &seeds {
                assert!(inside_rings(&rings, p), "{p:?}");
                for r in &rings {
                    for k in 0..r.len() {
                        assert!(segment_distance(p, r[k], r[(k + 1) % r.len()]) >= LATTICE_MARGIN * spacing - 1e-9);
                    }
                }
            }
        }
    }

    #[test]
    fn star_with_hole_meets_the_bounds() {
        // Hole given with the same orientation as the outer ring: the even-odd rule decides.
        let rings = vec![star(50.0, 50.0, 25.0, 45.0, 7), star(50.0, 50.0, 5.0, 10.0, 5)];
        let opts = MeshOptions {
            max_area: 8.0,
            ..MeshOptions::default()
        };
        let (mesh, required) = triangulate(&rings, &[[50.0, 20.0], [75.0, 50.0]], &opts).unwrap();
        mesh.check_invariants().unwrap();
        assert!(mesh.min_angle_degrees() >= 29.99, "{}", mesh.min_angle_degrees());
        assert_eq!(mesh.vertices[required[0] as usize], [50.0, 20.0]);
        assert_eq!(mesh.vertices[required[1] as usize], [75.0, 50.0]);
        let area = signed_area(&rings[0]).abs() - signed_area(&rings[1]).abs();
        let total: f64 = mesh.triangles.iter().map(|&t| f64::from(mesh.signed_area(t))).sum();
        assert!((total - area).abs() < 1e-3 * area, "{total} vs {area}");
        assert!(mesh.triangles.iter().all(|&t| mesh.signed_area(t) <= 8.0 * 1.0001));
    }

    #[test]
    fn required_point_on_a_ring_edge_is_accepted() {
        let square = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let (mesh, required) = triangulate(&[square], &[[5.0, 0.0], [10.0, 10.0]], &MeshOptions::default()).unwrap();
        assert_eq!(mesh.vertices[required[0] as usize], [5.0, 0.0]);
        assert_eq!(mesh.vertices[required[1] as usize], [10.0, 10.0]);
        mesh.check_invariants().unwrap();
    }

    #[test]
    fn required_points_near_an_edge_refine_or_fail_cleanly() {
        let square = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        for d in [0.1, 1e-2, 1e-4, 1e-6] {
            let (mesh, _) = triangulate(std::slice::from_ref(&square), &[[5.0, d], [5.0 + d, d]], &MeshOptions::default()).unwrap();
            mesh.check_invariants().unwrap();
            assert!(mesh.min_angle_degrees() >= 29.99, "{d}: {}", mesh.min_angle_degrees());
        }
        match triangulate(&[square], &[[5.0, 1e-9], [5.0 + 1e-9, 1e-9]], &MeshOptions::default()) {
            Ok((mesh, _)) => mesh.check_invariants().unwrap(),
            Err(e) => assert!(matches!(e, MeshError::TooSmall { .. }), "{e}"),
        }
    }
}
