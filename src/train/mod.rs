//! Training the deformation network (neural-puppet.md §3.2): configs, frame sequences and their
//! split, the losses of eq. 1–4, 10, 11 (ARAP as a custom Burn operation), checkpoints, logs,
//! and the loop that ties them together.

pub mod arap_op;
pub mod checkpoint;
pub mod config;
pub mod limb_search;
pub mod log;
pub mod loss;
pub mod optim;
pub mod refine;
pub mod sequence;
pub mod trainer;

pub use config::TrainConfig;
pub use sequence::Frames;
pub use trainer::{train, TrainOptions, TrainSummary};
