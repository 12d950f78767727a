//! `puppet`: learn a layered 2D puppet of a cartoon character from a few drawn frames, then make
//! new frames with it (Neural Puppet, accessory rigs, APES — see `papers/`).
//!
//! The pipeline and layout are described in DESIGN.md; every command of the `puppet` binary is a
//! thin wrapper over a function of this library.

#![warn(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

// Layer 0, base (DESIGN.md "Layers of the code"; src/layering.rs checks the imports).
pub mod atomic_file;
pub mod backend;
pub mod error;
pub mod folder_lock;
pub mod picture;
pub mod progress;
pub mod rng;
pub mod user_file;
// Layer 1, maths.
pub mod geom;
pub mod metrics;
// Layer 2, data.
pub mod puppet;
// Layer 3, the geometry of a character.
pub mod render;
pub mod rig;
// Layer 4, learning.
pub mod model;
pub mod objective;
pub mod train;
// Layer 5, using a model.
pub mod appearance;
pub mod edit;
pub mod fit;
pub mod parts;
// Layer 6, products.
pub mod demo;
pub mod eval;
pub mod export;
pub mod serve;
pub mod synth;

#[cfg(test)]
mod layering;
#[cfg(test)]
pub(crate) mod test_util;

pub use error::{Error, Result};
