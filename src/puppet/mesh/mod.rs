//! Meshing one layer (neural-puppet.md §3.1: "standard triangulation algorithm \[52\]"): alpha
//! threshold → boundary polygons with holes (marching squares, sub-pixel) → simplification →
//! constrained Delaunay triangulation (spade) refined to a minimum angle and maximum area →
//! optional midpoint subdivision.
//!
//! One step per file: [`contour`] traces the rings, [`simplify`] thins them without uncovering
//! any inside pixel centre, [`triangulate`] builds and refines the constrained Delaunay
//! triangulation (Ruppert/Chew refinement as implemented by spade), [`subdivide`] splits every
//! triangle into four.
//!
//! Ring convention used throughout: a ring is a closed polygon without its closing point; the
//! part lies on the side where `cross(b - a, p - a) > 0` for every ring edge `a → b` (y down), so
//! outer boundaries have positive shoelace area and holes negative.

pub mod contour;
pub mod simplify;
pub mod subdivide;
pub mod triangulate;

use super::Mesh;

/// Rings whose enclosed area is below this many px² are dropped by simplification: they are
/// specks of anti-aliasing or single stray pixels, too small to deform meaningfully.
pub const MIN_RING_AREA: f64 = 2.0;

/// Largest number of midpoint-subdivision rounds accepted (each multiplies triangles by 4).
pub const MAX_SUBDIVIDE: u32 = 5;

/// How a layer is meshed.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshOptions {
    /// Pixels with alpha above this are inside the part.
    pub alpha_threshold: f32,
    /// Largest distance, in pixels, a simplified boundary may stray from the traced contour.
    pub simplify_tolerance: f32,
    /// Largest triangle area in px² after refinement.
    pub max_area: f32,
    /// Smallest interior angle in degrees after refinement (1 to 34; up to 32 is reliable, above
    /// that refinement may not finish and meshing fails with [`MeshError::Options`]).
    pub min_angle: f32,
    /// Rounds of midpoint (1→4) subdivision after refinement.
    pub subdivide: u32,
}

impl Default for MeshOptions {
    /// Alpha 0.5, tolerance 0.5 px, triangles of at most 16 px², angles of at least 30°, no
    /// subdivision.
    fn default() -> Self {
        Self {
            alpha_threshold: 0.5,
            simplify_tolerance: 0.5,
            max_area: 16.0,
            min_angle: 30.0,
            subdivide: 0,
        }
    }
}

impl MeshOptions {
    /// Checks every option is in range.
    ///
    /// # Errors
    /// [`MeshError::Options`] naming the first bad option and its accepted range.
    pub fn validate(&self) -> Result<(), MeshError> {
        let bad = |what: String| Err(MeshError::Options(what));
        if !(self.alpha_threshold >= 0.0 && self.alpha_threshold < 1.0) {
            return bad(format!("alpha_threshold {} (expected 0 ≤ threshold < 1)", self.alpha_threshold));
        }
        if !(self.simplify_tolerance >= 0.0 && self.simplify_tolerance <= 16.0) {
            return bad(format!("simplify_tolerance {} (expected 0..=16 px)", self.simplify_tolerance));
        }
        if !(self.max_area > 0.0 && self.max_area.is_finite()) {
            return bad(format!("max_area {} (expected a finite area > 0 px²)", self.max_area));
        }
        if !(1.0..=34.0).contains(&self.min_angle) {
            return bad(format!("min_angle {} (expected 1..=34 degrees)", self.min_angle));
        }
        if self.subdivide > MAX_SUBDIVIDE {
            return bad(format!("subdivide {} (expected at most {MAX_SUBDIVIDE} rounds)", self.subdivide));
        }
        Ok(())
    }
}

/// A meshed layer, and where the required points ended up.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerMesh {
    /// The mesh, counter-clockwise triangles (see [`Mesh`]).
    pub mesh: Mesh,
    /// For each required point passed in, the index of the vertex placed exactly on it.
    pub required: Vec<u32>,
}

/// Why a layer could not be meshed; the caller adds the file and layer name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// No pixel is above the alpha threshold.
    #[error("no pixel has alpha above {threshold} (the layer is empty)")]
    Empty {
        /// The threshold used.
        threshold: f32,
    },
    /// The part (or every component of it) is too small to triangulate.
    #[error("part too small to mesh: {problem}")]
    TooSmall {
        /// What was too small, with sizes.
        problem: String,
    },
    /// Options out of range.
    #[error("invalid mesh options: {0}")]
    Options(String),
    /// A required point lies outside the part.
    #[error("required point ({x}, {y}) is outside the part")]
    PointOutside {
        /// x in pixels.
        x: f32,
        /// y in pixels.
        y: f32,
    },
}

/// Meshes the region where `alpha[y * width + x] > opts.alpha_threshold`.
///
/// Every pixel centre `(x + 0.5, y + 0.5)` with alpha above the threshold lies inside the mesh
/// (the boundary may sit slightly outside the traced contour), except in components or holes
/// whose traced area is below [`MIN_RING_AREA`] px², which are dropped. Several components and
/// holes are allowed. Each point of `required` becomes a vertex (returned in
/// [`LayerMesh::required`]), so a joint placed there is exact.
///
/// # Errors
/// [`MeshError`] if the region is empty or too small, a required point is outside, or the
/// options are out of range (also when `alpha.len() != width * height`).
pub fn mesh_alpha(alpha: &[f32], width: u32, height: u32, required: &[[f32; 2]], opts: &MeshOptions) -> Result<LayerMesh, MeshError> {
    opts.validate()?;
    if alpha.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(MeshError::Options(format!(
            "alpha has {} values, expected {width}×{height} = {}",
            alpha.len(),
            u64::from(width) * u64::from(height)
        )));
    }
    let threshold = opts.alpha_threshold;
    let inside_count = alpha.iter().filter(|&&a| a > threshold).count();
    if inside_count == 0 {
        return Err(MeshError::Empty { threshold });
    }
    let grid = contour::AlphaGrid {
        alpha,
        width,
        height,
        threshold,
    };
    let traced = contour::contour(&grid);
    // Simplified corners stay at least this sharp-free: 1.5× the angle bound, at most 60°.
    let min_vertex_angle = (1.5 * f64::from(opts.min_angle)).min(60.0);
    let rings = simplify::simplify(&traced, &grid, f64::from(opts.simplify_tolerance), min_vertex_angle);
    if rings.is_empty() {
        let largest = traced.iter().map(|r| contour::signed_area(r)).fold(0.0, f64::max);
        return Err(MeshError::TooSmall {
            problem: format!(
                "{inside_count} pixel(s) above alpha {threshold}, largest traced component {largest:.2} px² \
                 (components under {MIN_RING_AREA} px² are dropped)"
            ),
        });
    }
    let rings: Vec<Vec<[f32; 2]>> = rings
        .iter()
        .map(|r| r.iter().map(|p| [p[0] as f32, p[1] as f32]).collect())
        .collect();
    mesh_polygons(&rings, required, opts)
}

/// Meshes the region bounded by `rings` (closed polygons without the closing point; even-odd
/// rule, so a ring inside another is a hole; orientation does not matter here).
///
/// The constraint edges are the ring edges; the triangulation is refined until every triangle
/// has angles ≥ `opts.min_angle` (except next to input angles that are smaller) and area ≤
/// `opts.max_area`, then subdivided `opts.subdivide` times. `opts.alpha_threshold` and
/// `opts.simplify_tolerance` are not used. Each required point becomes a vertex.
///
/// # Errors
/// [`MeshError::Options`] for bad options or rings (fewer than 3 points, non-finite or huge
/// coordinates, crossing edges); [`MeshError::TooSmall`] when the rings enclose no area;
/// [`MeshError::PointOutside`] for a required point outside the region.
pub fn mesh_polygons(rings: &[Vec<[f32; 2]>], required: &[[f32; 2]], opts: &MeshOptions) -> Result<LayerMesh, MeshError> {
    opts.validate()?;
    let rings64: Vec<Vec<[f64; 2]>> = rings
        .iter()
        .map(|r| r.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect())
        .collect();
    let required64: Vec<[f64; 2]> = required.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
    let (mut mesh, required_idx) = triangulate::triangulate(&rings64, &required64, opts)?;
    for _ in 0..opts.subdivide {
        mesh = subdivide::subdivide(&mesh);
    }
    Ok(LayerMesh {
        mesh,
        required: required_idx,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An alpha image from a signed distance-like function `f(x, y)` (positive inside), with a
    /// one-pixel anti-aliased edge, sampled at pixel centres.
    fn image(width: u32, height: u32, f: impl Fn(f32, f32) -> f32) -> Vec<f32> {
        (0..height)
            .flat_map(|y| (0..width).map(move |x| (x as f32 + 0.5, y as f32 + 0.5)))
            .map(|(x, y)| (0.5 + f(x, y)).clamp(0.0, 1.0))
            .collect()
    }

    fn disc(cx: f32, cy: f32, r: f32) -> impl Fn(f32, f32) -> f32 {
        move |x, y| r - ((x - cx).powi(2) + (y - cy).powi(2)).sqrt()
    }

    /// Named test shapes: (name, alpha, width, height).
    fn shapes() -> Vec<(&'static str, Vec<f32>, u32, u32)> {
        let mut shapes = vec![
            ("disc", image(48, 48, disc(24.0, 24.0, 17.3)), 48, 48),
            (
                "ring",
                image(48, 48, |x, y| {
                    let d = disc(24.0, 24.0, 20.0)(x, y);
                    d.min(-(disc(24.0, 24.0, 9.0)(x, y)))
                }),
                48,
                48,
            ),
            (
                "two discs",
                image(64, 32, |x, y| disc(14.0, 16.0, 10.0)(x, y).max(disc(47.0, 15.0, 12.5)(x, y))),
                64,
                32,
            ),
            (
                "bar 2px",
                image(40, 12, |x, y| {
                    if (5.0..6.99).contains(&y) && (3.0..37.0).contains(&x) {
                        1.0
                    } else {
                        -1.0
                    }
                }),
                40,
                12,
            ),
            (
                "L shape",
                image(30, 30, |x, y| {
                    if (x < 10.0 && y < 27.0 && x > 3.0 && y > 2.0) || (x > 3.0 && x < 27.0 && y > 20.0 && y < 27.0) {
                        1.0
                    } else {
                        -1.0
                    }
                }),
                30,
                30,
            ),
            (
                "edge touching",
                image(20, 16, |x, y| if x < 12.0 || y > 10.0 { 1.0 } else { -1.0 }),
                20,
                16,
            ),
        ];
        // Random blobs: sums of seeded Gaussian bumps, thresholded smoothly.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        for _ in 0..4 {
            let bumps: Vec<[f32; 3]> = (0..6)
                .map(|_| [8.0 + 48.0 * next(), 8.0 + 48.0 * next(), 3.0 + 6.0 * next()])
                .collect();
            let alpha = image(64, 64, |x, y| {
                let s: f32 = bumps
                    .iter()
                    .map(|b| (-((x - b[0]).powi(2) + (y - b[1]).powi(2)) / (2.0 * b[2] * b[2])).exp())
                    .sum();
                4.0 * (s - 0.5)
            });
            shapes.push(("blobs", alpha, 64, 64));
        }
        shapes
    }

    /// Marks the pixel centres covered by some triangle (closed, with a 1e-4 px slack).
    fn covered(mesh: &Mesh, width: u32, height: u32) -> Vec<bool> {
        let mut covered = vec![false; (width * height) as usize];
        for &t in &mesh.triangles {
            let p = t.map(|i| mesh.vertices[i as usize]);
            let area2 = 2.0 * mesh.signed_area(t);
            let x0 = p.iter().map(|q| q[0]).fold(f32::MAX, f32::min).floor().max(0.0) as u32;
            let y0 = p.iter().map(|q| q[1]).fold(f32::MAX, f32::min).floor().max(0.0) as u32;
            let x1 = (p.iter().map(|q| q[0]).fold(f32::MIN, f32::max).ceil() as u32).min(width);
            let y1 = (p.iter().map(|q| q[1]).fold(f32::MIN, f32::max).ceil() as u32).min(height);
            for y in y0..y1 {
                for x in x0..x1 {
                    let c = [x as f32 + 0.5, y as f32 + 0.5];
                    let inside = (0..3).all(|k| {
                        let (a, b) = (p[k], p[(k + 1) % 3]);
                        let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                        cross / len >= -1e-4 && area2 > 0.0
                    });
                    if inside {
                        covered[(y * width + x) as usize] = true;
                    }
                }
            }
        }
        covered
    }

    /// Invariants, and coverage of every inside pixel centre except those in traced components
    /// under [`MIN_RING_AREA`] px² (dropped by design).
    fn check_coverage(name: &str, alpha: &[f32], width: u32, height: u32, mesh: &Mesh, opts: &MeshOptions) {
        mesh.check_invariants().unwrap_or_else(|e| panic!("{name}: {e}"));
        let grid = contour::AlphaGrid {
            alpha,
            width,
            height,
            threshold: opts.alpha_threshold,
        };
        let kept: Vec<Vec<[f64; 2]>> = contour::contour(&grid)
            .into_iter()
            .filter(|r| contour::signed_area(r).abs() >= MIN_RING_AREA)
            .collect();
        let cov = covered(mesh, width, height);
        for (i, (&a, &c)) in alpha.iter().zip(&cov).enumerate() {
            let (x, y) = (i as u32 % width, i as u32 / width);
            let must = a > opts.alpha_threshold && contour::inside_rings(&kept, [f64::from(x) + 0.5, f64::from(y) + 0.5]);
            assert!(!must || c, "{name}: pixel ({x}, {y}) alpha {a} not covered");
        }
    }

    fn check_mesh(name: &str, alpha: &[f32], width: u32, height: u32, out: &LayerMesh, opts: &MeshOptions) {
        let mesh = &out.mesh;
        mesh.check_invariants().unwrap_or_else(|e| panic!("{name}: {e}"));
        let cov = covered(mesh, width, height);
        for (i, (&a, &c)) in alpha.iter().zip(&cov).enumerate() {
            assert!(
                a <= opts.alpha_threshold || c,
                "{name}: pixel ({}, {}) alpha {a} not covered",
                i as u32 % width,
                i as u32 / width
            );
        }
        let min_angle = mesh.min_angle_degrees();
        assert!(min_angle >= opts.min_angle - 0.01, "{name}: min angle {min_angle}");
        let max_area = mesh.triangles.iter().map(|&t| mesh.signed_area(t)).fold(0.0, f32::max);
        assert!(max_area <= opts.max_area * 1.0001, "{name}: max area {max_area}");
    }

    #[test]
    fn meshes_cover_every_inside_pixel_with_quality() {
        for opts in [
            MeshOptions::default(),
            MeshOptions {
                max_area: 4.0,
                min_angle: 32.0,
                simplify_tolerance: 1.0,
                ..MeshOptions::default()
            },
        ] {
            for (name, alpha, w, h) in shapes() {
                let out = mesh_alpha(&alpha, w, h, &[], &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
                check_mesh(name, &alpha, w, h, &out, &opts);
            }
        }
    }

    #[test]
    fn holes_stay_empty() {
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "ring").unwrap();
        let out = mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap();
        let m = &out.mesh;
        for &t in &m.triangles {
            let p = t.map(|i| m.vertices[i as usize]);
            let c = [(p[0][0] + p[1][0] + p[2][0]) / 3.0, (p[0][1] + p[1][1] + p[2][1]) / 3.0];
            let r = ((c[0] - 24.0).powi(2) + (c[1] - 24.0).powi(2)).sqrt();
            // The hole has radius 9; the boundary may move outward (into it) by ~1 px at most.
            assert!(r > 7.5, "triangle {t:?} centroid {c:?} is in the hole (r = {r})");
        }
    }

    /// Number of connected components of the triangle adjacency (through shared vertices).
    fn components(mesh: &Mesh) -> usize {
        crate::geom::component_labels(mesh.vertices.len(), crate::geom::triangle_edges(&mesh.triangles)).1
    }

    #[test]
    fn several_components_are_kept_apart() {
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "two discs").unwrap();
        let out = mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap();
        assert_eq!(components(&out.mesh), 2);
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "ring").unwrap();
        assert_eq!(components(&mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap().mesh), 1);
    }

    #[test]
    fn required_points_are_exact_vertices_and_survive_subdivision() {
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "disc").unwrap();
        let required = [[24.0, 24.0], [30.25, 17.5], [24.013, 24.0], [10.0, 30.0]];
        for subdivide in [0, 2] {
            let opts = MeshOptions {
                subdivide,
                ..MeshOptions::default()
            };
            let out = mesh_alpha(&alpha, w, h, &required, &opts).unwrap();
            assert_eq!(out.required.len(), required.len());
            for (p, &i) in required.iter().zip(&out.required) {
                assert_eq!(out.mesh.vertices[i as usize], *p);
            }
            check_mesh("disc with required points", &alpha, w, h, &out, &opts);
        }
    }

    #[test]
    fn subdivision_multiplies_triangles_by_four() {
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "L shape").unwrap();
        let base = mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap().mesh;
        for rounds in 1..=2u32 {
            let opts = MeshOptions {
                subdivide: rounds,
                ..MeshOptions::default()
            };
            let fine = mesh_alpha(&alpha, w, h, &[], &opts).unwrap().mesh;
            assert_eq!(fine.triangles.len(), base.triangles.len() * 4usize.pow(rounds));
            assert_eq!(&fine.vertices[..base.vertices.len()], &base.vertices[..]);
            fine.check_invariants().unwrap();
            assert!((fine.min_angle_degrees() - base.min_angle_degrees()).abs() < 0.01);
        }
    }

    #[test]
    fn meshing_is_deterministic() {
        for (name, alpha, w, h) in shapes() {
            let a = mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap();
            let b = mesh_alpha(&alpha, w, h, &[], &MeshOptions::default()).unwrap();
            assert_eq!(a, b, "{name}");
        }
    }

    #[test]
    fn errors_name_the_problem() {
        let opts = MeshOptions::default();
        assert_eq!(mesh_alpha(&[0.0; 16], 4, 4, &[], &opts), Err(MeshError::Empty { threshold: 0.5 }));
        let mut speck = vec![0.0; 16];
        speck[5] = 1.0;
        match mesh_alpha(&speck, 4, 4, &[], &opts) {
            Err(MeshError::TooSmall { problem }) => assert!(problem.contains("1 pixel") && problem.contains("0.50 px²"), "{problem}"),
            other => panic!("{other:?}"),
        }
        let bad = [
            MeshOptions {
                min_angle: 35.0,
                ..opts.clone()
            },
            MeshOptions {
                min_angle: 0.5,
                ..opts.clone()
            },
            MeshOptions {
                min_angle: f32::NAN,
                ..opts.clone()
            },
            MeshOptions {
                max_area: 0.0,
                ..opts.clone()
            },
            MeshOptions {
                max_area: f32::NAN,
                ..opts.clone()
            },
            MeshOptions {
                alpha_threshold: f32::NAN,
                ..opts.clone()
            },
            MeshOptions {
                simplify_tolerance: -1.0,
                ..opts.clone()
            },
            MeshOptions {
                subdivide: 9,
                ..opts.clone()
            },
        ];
        let (_, alpha, w, h) = shapes().into_iter().find(|s| s.0 == "disc").unwrap();
        for o in bad {
            assert!(matches!(mesh_alpha(&alpha, w, h, &[], &o), Err(MeshError::Options(_))), "{o:?}");
        }
        assert!(matches!(mesh_alpha(&alpha, w, h + 1, &[], &opts), Err(MeshError::Options(_))));
        assert_eq!(
            mesh_alpha(&alpha, w, h, &[[1.0, 1.0]], &opts),
            Err(MeshError::PointOutside { x: 1.0, y: 1.0 })
        );
        assert!(matches!(
            mesh_alpha(&alpha, w, h, &[[f32::NAN, 1.0]], &opts),
            Err(MeshError::PointOutside { .. })
        ));
    }

    #[test]
    fn mesh_polygons_meshes_a_square_with_a_hole_and_rejects_bad_rings() {
        let outer = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [0.0, 40.0]];
        let hole = vec![[15.0, 15.0], [15.0, 25.0], [25.0, 25.0], [25.0, 15.0]];
        let opts = MeshOptions {
            max_area: 10.0,
            ..MeshOptions::default()
        };
        let out = mesh_polygons(&[outer.clone(), hole.clone()], &[[5.0, 5.0]], &opts).unwrap();
        let m = &out.mesh;
        m.check_invariants().unwrap();
        let total: f32 = m.triangles.iter().map(|&t| m.signed_area(t)).sum();
        assert!((total - (1600.0 - 100.0)).abs() < 0.01, "area {total}");
        assert!(m.min_angle_degrees() >= 29.99);
        assert_eq!(m.vertices[out.required[0] as usize], [5.0, 5.0]);
        assert!(matches!(
            mesh_polygons(std::slice::from_ref(&outer), &[[20.0, 50.0]], &opts),
            Err(MeshError::PointOutside { .. })
        ));
        let bow_tie = vec![[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [12.0, 12.0]];
        assert!(matches!(mesh_polygons(&[bow_tie], &[], &opts), Err(MeshError::Options(_))));
        assert!(matches!(
            mesh_polygons(&[vec![[0.0, 0.0], [1.0, 1.0]]], &[], &opts),
            Err(MeshError::Options(_))
        ));
        let flat = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        assert!(matches!(mesh_polygons(&[flat], &[], &opts), Err(MeshError::TooSmall { .. })));
        assert!(matches!(
            mesh_polygons(&[vec![[0.0, 0.0], [f32::INFINITY, 0.0], [0.0, 1.0]]], &[], &opts),
            Err(MeshError::Options(_))
        ));
    }

    /// Binary masks of random pixels: many components, saddles, one-pixel spurs and holes. The
    /// traced contour has no angle below 90°, so the mesh keeps the bound up to spade's small
    /// shortfalls above 30° (measured: 29.74° for a 31.3° request) and never goes below 25°.
    #[test]
    fn random_pixel_masks_mesh_cleanly_with_angles_kept() {
        let mut state = 7u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        for trial in 0..120 {
            let (w, h) = (8 + (next() * 40.0) as u32, 8 + (next() * 40.0) as u32);
            let density = 0.3 + 0.5 * next();
            let alpha: Vec<f32> = (0..w * h).map(|_| if next() < density { 1.0 } else { 0.0 }).collect();
            let opts = MeshOptions {
                max_area: 1.0 + 20.0 * next(),
                min_angle: 25.0 + 7.0 * next(),
                simplify_tolerance: 2.0 * next(),
                ..MeshOptions::default()
            };
            match mesh_alpha(&alpha, w, h, &[], &opts) {
                Ok(out) => {
                    check_coverage(&format!("trial {trial}"), &alpha, w, h, &out.mesh, &opts);
                    let angle = out.mesh.min_angle_degrees();
                    assert!(
                        angle >= 25.0 && angle >= opts.min_angle.min(30.0) - 0.5,
                        "trial {trial}: {angle} for {opts:?}"
                    );
                }
                Err(MeshError::TooSmall { .. }) | Err(MeshError::Empty { .. }) => {}
                Err(e) => panic!("trial {trial}: {e}"),
            }
        }
    }
}
