//! Meshing one layer (neural-puppet.md §3.1: "standard triangulation algorithm [52]"): alpha
//! threshold → boundary polygons with holes (marching squares, sub-pixel) → simplification →
//! constrained Delaunay triangulation (spade) refined to a minimum angle and maximum area →
//! optional midpoint subdivision.

use super::Mesh;

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
/// (the boundary may sit slightly outside the traced contour). Several components and holes are
/// allowed. Each point of `required` becomes a vertex (returned in [`LayerMesh::required`]), so a
/// joint placed there is exact.
///
/// # Errors
/// [`MeshError`] if the region is empty or too small, a required point is outside, or the
/// options are out of range.
pub fn mesh_alpha(
    alpha: &[f32],
    width: u32,
    height: u32,
    required: &[[f32; 2]],
    opts: &MeshOptions,
) -> Result<LayerMesh, MeshError> {
    let _ = (alpha, width, height, required, opts);
    todo!("meshing pipeline")
}
