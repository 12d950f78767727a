//! `puppet`: learn a layered 2D puppet of a cartoon character from a few drawn frames, then make
//! new frames with it (Neural Puppet, accessory rigs, APES — see `papers/`).
//!
//! The pipeline and layout are described in DESIGN.md; every command of the `puppet` binary is a
//! thin wrapper over a function of this library.

#![warn(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]
#![forbid(unsafe_code)]

pub mod atomic_file;
pub mod backend;
pub mod edit;
pub mod error;
pub mod eval;
pub mod geom;
pub mod model;
pub mod picture;
pub mod progress;
pub mod puppet;
pub mod render;
pub mod synth;
#[cfg(test)]
pub(crate) mod test_util;
pub mod train;

pub use error::{Error, Result};
