//! What [`bbw`](super::bbw) reports: the error type and the mesh component it names.

use std::fmt;

/// A connected component of a mesh (vertices joined by triangle edges), as named by
/// [`BbwError::UnpinnedComponents`]. Components are numbered in the order of their smallest vertex.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshComponent {
    /// The component's number (0 is the component of vertex 0).
    pub index: usize,
    /// Its smallest vertex index: a vertex that a caller could pin.
    pub first_vertex: u32,
    /// How many vertices it has.
    pub vertices: usize,
    /// How many triangles it has.
    pub triangles: usize,
}

impl fmt::Display for MeshComponent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "component {} ({} vertices from vertex {}, {} triangles)",
            self.index, self.vertices, self.first_vertex, self.triangles
        )
    }
}

/// What [`bbw`](super::bbw) could not do, with the vertex, triangle, handle or component at fault.
#[derive(Debug, thiserror::Error)]
pub enum BbwError {
    /// A position is NaN or infinite.
    #[error("bbw: vertex {vertex}: position {position:?} is not finite (expected finite x and y)")]
    NonFinite {
        /// The vertex.
        vertex: usize,
        /// Its position.
        position: [f64; 2],
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("bbw: triangle {triangle} {corners:?}: index {index} is past the {vertices} vertices")]
    TriangleIndex {
        /// The triangle.
        triangle: usize,
        /// Its corners.
        corners: [u32; 3],
        /// The bad index.
        index: u32,
        /// `#V`.
        vertices: usize,
    },
    /// A triangle has a repeated corner or no area, so its cotangents are undefined.
    #[error("bbw: triangle {triangle} {corners:?} is degenerate (expected three distinct corners enclosing a non-zero area)")]
    DegenerateTriangle {
        /// The triangle.
        triangle: usize,
        /// Its corners.
        corners: [u32; 3],
    },
    /// A handle refers to a vertex that does not exist.
    #[error("bbw: handle {handle}: vertex {vertex} is past the {vertices} vertices")]
    HandleIndex {
        /// The handle (its position in `handles`).
        handle: usize,
        /// The vertex it names.
        vertex: u32,
        /// `#V`.
        vertices: usize,
    },
    /// Two handles are the same vertex.
    #[error("bbw: handles {first} and {second} are both vertex {vertex} (expected distinct vertices)")]
    RepeatedHandle {
        /// The first handle naming the vertex.
        first: usize,
        /// The second one.
        second: usize,
        /// The vertex.
        vertex: u32,
    },
    /// Vertices that belong to no triangle and are not handles: they have no mass, no neighbours
    /// and so no weights.
    #[error("bbw: {} used by no triangle (expected every vertex in a triangle, or a handle)", vertex_list(.vertices))]
    UnusedVertices {
        /// The vertices, ascending.
        vertices: Vec<u32>,
    },
    /// Connected components without a handle: their weights are undetermined (Q is singular on
    /// them). The caller adds a pin to each or makes the layer rigid.
    #[error("bbw: {} (expected at least one handle in every connected component)", component_list(.components))]
    UnpinnedComponents {
        /// The components, in order.
        components: Vec<MeshComponent>,
    },
    /// An option is out of range.
    #[error("bbw: option {option}: {problem}")]
    Option {
        /// The option's name.
        option: &'static str,
        /// What is wrong with its value.
        problem: String,
    },
    /// The cotangent Laplacian could not be built (the input checks above make this unexpected).
    #[error("bbw: cotangent laplacian: {0}")]
    Laplacian(String),
    /// A sparse Cholesky factorisation failed (the matrices are positive definite once every
    /// component has a handle, so this means numerical breakdown).
    #[error("bbw: {stage}: sparse cholesky of {size} unknowns failed: {problem}")]
    Factorisation {
        /// Which solve ("unconstrained weights" or "handle k").
        stage: String,
        /// Size of the factorised matrix.
        size: usize,
        /// faer's error.
        problem: String,
    },
    /// A handle's active set still changed after [`BbwOptions::max_iterations`](super::BbwOptions::max_iterations) iterations.
    #[error("bbw: handle {handle} (vertex {vertex}): active set still changing after {iterations} iterations (expected convergence; raise the iteration limit or the tolerance)")]
    NotConverged {
        /// The handle.
        handle: usize,
        /// Its vertex.
        vertex: u32,
        /// Iterations done.
        iterations: usize,
    },
    /// Every handle's weight is zero at a vertex, so its row cannot be normalised.
    #[error("bbw: vertex {vertex}: every weight is zero (expected a positive row sum to normalise)")]
    ZeroRow {
        /// The vertex.
        vertex: usize,
    },
}

fn vertex_list(vertices: &[u32]) -> String {
    const SHOWN: usize = 10;
    let shown: Vec<String> = vertices.iter().take(SHOWN).map(u32::to_string).collect();
    let more = vertices.len().saturating_sub(SHOWN);
    let tail = if more > 0 { format!(" and {more} more") } else { String::new() };
    match vertices.len() {
        1 => format!("vertex {} is", shown[0]),
        _ => format!("vertices {}{tail} are", shown.join(", ")),
    }
}

fn component_list(components: &[MeshComponent]) -> String {
    let names: Vec<String> = components.iter().map(MeshComponent::to_string).collect();
    match components.len() {
        1 => format!("{} has no handle", names[0]),
        n => format!("{n} connected components have no handle: {}", names.join(", ")),
    }
}
