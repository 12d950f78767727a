//! `puppet`: learn a layered 2D puppet of a cartoon character from a few drawn frames, then make
//! new frames with it (Neural Puppet, accessory rigs, APES — see `papers/`).
//!
//! The pipeline and layout are described in DESIGN.md; every command of the `puppet` binary is a
//! thin wrapper over a function of this library. The main types and entry points are here at
//! the root; the modules hold the rest.
//!
//! ```no_run
//! use std::path::Path;
//!
//! # fn main() -> puppet::Result<()> {
//! // Artwork (PNG layers + character.toml, a label map, .ora or .psd) → a layered puppet.
//! let artwork = puppet::load_artwork(Path::new("data/kenney/robot"), &puppet::ImportOptions::default())?;
//! let (built, _report) = puppet::build(&artwork, &puppet::BuildOptions::default(), &puppet::Silent)?;
//! // Its rest pose, drawn by the renderer every stage shares.
//! let rest = puppet::render_crisp(&built, &built.rest_vertices(), built.width, built.height)?;
//! rest.save_png(Path::new("rest.png"))?;
//! # Ok(())
//! # }
//! ```
//!
//! `examples/` has whole programs: building, training a model, fitting, in-betweening and
//! exporting to Spine.

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
pub mod posing;
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
pub mod prior;
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

// The crate root: the main types and calls of each stage (docs/architecture.md lists them by
// stage); everything else stays in its module.
pub use appearance::{train_appearance, AppearanceConfig, AppearanceStage};
pub use atomic_file::Outputs;
pub use edit::manifold_path::Waypoints;
pub use edit::{correspond, inbetween, Easing, InbetweenPath, Inbetweens, PoseEditor, PoseOptions};
pub use export::spine::{skeleton as spine_skeleton, PoseAnimation, SpineSkeleton};
pub use fit::{fit, FitOptions};
pub use model::{Model, ModelFolder};
pub use parts::{find_parts, Parts, PartsOptions};
pub use picture::Picture;
pub use posing::{EngineSettings, PoseEngine, PosedFrame};
pub use progress::{Progress, Silent};
pub use puppet::artwork::load as load_artwork;
pub use puppet::build::{build, BuildOptions};
pub use puppet::layers::{Artwork, ImportOptions};
pub use puppet::sequence::Frames;
pub use puppet::Puppet;
pub use render::{render_crisp, Background};
pub use rig::{build_rigged, RigOptions};
pub use train::{train, TrainConfig, TrainOptions, TrainSummary};
