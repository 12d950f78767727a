//! Training the deformation network (neural-puppet.md §3.2): the config, the seeded split,
//! the fused Adam, checkpoints, logs, and the loop that lowers [`crate::objective`] over the
//! network's weights.

pub mod augment;
pub mod checkpoint;
pub mod config;
pub mod log;
pub mod optim;
pub mod sampled;
pub mod split;
pub mod trainer;

pub use config::TrainConfig;
pub use trainer::{train, TrainOptions, TrainSummary};
