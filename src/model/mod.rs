//! Burn modules (neural-puppet.md §3.2): the deformation network that maps a frame to the
//! template's vertex positions, the letterbox between frames and its input, and the model folder.
//! Losses live in `objective` and training in `train`; this module holds the modules, their
//! configs, and the model folder's layout.

pub mod appearance;
pub mod bundle;
pub mod conv_kernel;
pub mod conv_op;
pub mod conv_phases;
pub mod correspondence;
pub mod decoder;
pub mod deformation;
pub mod folder;
pub mod gate_kernel;
pub mod gate_op;
pub mod lanes;
pub mod letterbox;

pub use bundle::Model;
pub use folder::ModelFolder;
pub use letterbox::Letterbox;
