//! Training the deformation network (neural-puppet.md §3.2): the config, the seeded split,
//! the fused Adam, checkpoints, logs, the one harness every trainer runs in ([`harness`]), and
//! the deformation network's steps, which lower [`crate::objective`] over its weights.

pub mod augment;
pub mod checkpoint;
pub mod config;
pub mod guide;
pub mod harness;
pub mod log;
pub mod optim;
pub mod sampled;
pub mod split;
pub mod trainer;

pub use config::TrainConfig;
pub use trainer::{train, TrainOptions, TrainSummary};
