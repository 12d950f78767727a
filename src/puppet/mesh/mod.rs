//! Meshing one layer (neural-puppet.md §3.1: "standard triangulation algorithm [52]"): alpha
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
    /// Smallest interior angle in degrees after refinement (at least 25, at most ~33).
    pub min_angle: f32,
    /// Rounds of midpoint (1→4) subdivision after refinement.
    pub subdivide: u32,
}

impl Default for MeshOptions {
    /// Alpha 0.5, tolerance 0.5 px, triangles of at most 16 px², angles of at least 30°, no
    /// subdivision.
    fn default() -> Self {
        Self { alpha_threshold: 0.5, simplify_tolerance: 0.5, max_area: 16.0, min_angle: 30.0, subdivide: 0 }
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
pub fn mesh_alpha(
    alpha: &[f32],
    width: u32,
    height: u32,
    required: &[[f32; 2]],
    opts: &MeshOptions,
) -> Result<LayerMesh, MeshError> {
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
    let grid = contour::AlphaGrid { alpha, width, height, threshold };
    let traced = contour::contour(&grid);
    let rings = simplify::simplify(&traced, &grid, f64::from(opts.simplify_tolerance));
    if rings.is_empty() {
        let largest = traced.iter().map(|r| contour::signed_area(r)).fold(0.0, f64::max);
        return Err(MeshError::TooSmall {
            problem: format!(
                "{inside_count} pixel(s) above alpha {threshold}, largest traced component {largest:.2} px² \
                 (components under {MIN_RING_AREA} px² are dropped)"
            ),
        });
    }
    let rings: Vec<Vec<[f32; 2]>> =
        rings.iter().map(|r| r.iter().map(|p| [p[0] as f32, p[1] as f32]).collect()).collect();
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
    let rings64: Vec<Vec<[f64; 2]>> =
        rings.iter().map(|r| r.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect()).collect();
    let required64: Vec<[f64; 2]> = required.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
    let (mut mesh, required_idx) = triangulate::triangulate(&rings64, &required64, opts)?;
    for _ in 0..opts.subdivide {
        mesh = subdivide::subdivide(&mesh);
    }
    Ok(LayerMesh { mesh, required: required_idx })
}
