//! Drawing: previews now; the differentiable soft rasterizer arrives with its issue.
//!
//! [`soft_raster`] is the one renderer of the project (neural-puppet.md §3.2): soft for training,
//! crisp (σ = 0) for every preview and export through [`render_crisp`] / [`render_pose`];
//! [`burn_op`] exposes it to Burn as a differentiable operation.

pub mod burn_op;
mod pose;
pub mod soft_raster;

pub use pose::{render_crisp, render_pose};
pub use soft_raster::{Background, Params, SoftRasterizer};
