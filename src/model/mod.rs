//! Burn modules (neural-puppet.md §3.2): the deformation network that maps a frame to the
//! template's vertex positions, the letterbox between frames and its input, and the model folder.
//! Losses and training live in `train`; this module holds only modules and their configs.

pub mod bundle;
pub mod conv_kernel;
pub mod conv_op;
pub mod deformation;
pub mod letterbox;

pub use bundle::Model;
pub use letterbox::Letterbox;
