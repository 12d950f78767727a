//! Geometry kernels on 2D triangle meshes: the cotangent Laplacian, a sparse constrained
//! quadratic solver, as-rigid-as-possible (ARAP) energy, rotations and deformation
//! (Sorkine & Alexa 2007; neural-puppet.md §3.2 eq. 2 as the training regulariser,
//! apes-part-extraction.md appendix B for handle-driven deformation), and bounded biharmonic
//! weights (Jacobson et al. 2011; accessory-rigs.md §3.5).
//!
//! Conventions (shared with `crate::puppet`): geometry is flat slices — positions `&[[T; 2]]` in
//! pixels (origin top-left, y down), triangles `&[[u32; 3]]` counter-clockwise as seen on screen
//! (positive signed area with y down). A mesh may have several connected components (a puppet is
//! one mesh whose layers are components); nothing here assumes connectivity, but the ARAP solver
//! needs at least one handle per component (see [`arap::ArapSolver::new`]).
//!
//! Entry points:
//! - [`cotan_laplacian::cotan_weights`] / [`cotan_laplacian::cotan_laplacian`]: weights
//!   w_ij = ½(cot α + cot β) as an edge list or as the sparse matrix L (negative semi-definite).
//! - [`min_quad_with_fixed::MinQuadWithFixed`]: minimise ½xᵀQx − bᵀx with some entries fixed,
//!   Q factorised once (sparse Cholesky, faer).
//! - [`arap::ArapEnergy`]: energy (eq. 2) and its gradient, batched, f32 or f64.
//! - [`arap::ArapSolver`]: local/global ARAP deformation with positional handles.
//! - [`arap::ArapFit`]: the same pulled by soft point targets (noisy correspondences).
//! - [`bbw::bbw`]: bounded biharmonic skinning weights of point handles, rows summing to one.
//! - [`rigid_interpolation::RigidInterpolation`]: as-rigid-as-possible shape interpolation
//!   between two poses (Alexa et al. 2000), the classical in-between.
//! - [`components::component_labels`]: connected components of vertices joined by edges.
//! - [`similarity::Similarity`]: a 2D similarity transform and its least-squares fit.
//! - [`triangle_grid::TriangleGrid`]: exact point-in-union and distance queries on a triangle soup.

pub mod arap;
pub mod bbw;
pub mod components;
pub mod cotan_laplacian;
pub mod min_quad_with_fixed;
pub mod rigid_interpolation;
pub mod similarity;
pub mod triangle;
pub mod triangle_grid;

pub use arap::{arap_energy, best_fit_rotations, ArapEnergy, ArapFit, ArapSolver, MeshPoint};
pub use bbw::{bbw, lumped_mass, BbwError, BbwOptions, BbwWeights, MassMatrix, MeshComponent};
pub use components::{component_labels, triangle_edges};
pub use cotan_laplacian::{cotan_laplacian, cotan_weights, CotanEdge};
pub use min_quad_with_fixed::MinQuadWithFixed;
pub use rigid_interpolation::RigidInterpolation;
