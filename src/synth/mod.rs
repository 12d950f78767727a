//! Synthetic drawn sequences with ground truth (issue 4): procedural layered cartoon characters,
//! posed by smooth cycles or random joint angles, slightly deformed per part as-rigidly-as-possible
//! (APES appendix B), and drawn anew every frame from their analytic shapes with mild line
//! wobble — so fitting a puppet to them is not trivially exact — together with the template
//! artwork of the rest pose (neural-puppet.md §3.1: layers + character.toml, which
//! `puppet build` meshes), per-frame part label maps and alpha masks, and the true position of
//! every rest point in every frame ([`true_positions`]).
//!
//! ```no_run
//! use puppet::synth::{generate, write_sequence, SynthOptions};
//! let seq = generate(&SynthOptions { seed: 7, frames: 16, ..Default::default() }, &puppet::progress::Silent)?;
//! write_sequence(&seq, std::path::Path::new("out/synth-7"), &puppet::progress::Silent)?;
//! # Ok::<(), puppet::Error>(())
//! ```

pub mod character;
pub mod deformation;
pub mod draw;
pub mod labels;
pub mod look;
pub mod output;
mod part_arap;
pub mod pose;
pub mod sequence;
pub mod shape;
pub mod sheet_flow;
pub mod truth;

pub use output::{write_sequence, write_sprite_sheet, Written};
pub use pose::Motion;
pub use sequence::{generate, Sequence, SynthOptions};
pub use truth::{true_positions, Truth};
