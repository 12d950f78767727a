//! Drawing (neural-puppet.md §3.2): [`soft_raster`] is the one renderer of the project — soft
//! for training, crisp (σ = 0) for every preview and export through [`render_crisp`] /
//! [`render_pose`]; [`burn_op`] exposes it to Burn as a differentiable operation; [`preview`]
//! draws wireframes and joints over artwork; [`animation`] writes frame lists as GIF, PNG
//! sequences and sprite sheets.

pub mod animation;
pub mod burn_op;
mod pose;
pub mod preview;
pub mod soft_raster;

pub use pose::{render_crisp, render_pose, straight_picture};
pub use soft_raster::{Background, Params, SoftRasterizer};
