//! The appearance stage (neural-puppet.md §3.3, eq. 5–6): an optional conditional GAN that takes
//! the rendered, deformed puppet and draws the frame an artist would have drawn — shading, line
//! changes, small turns that warping a template cannot make. Trained after, and independently
//! of, the deformation network ([`train`]), on the model's own training frames fitted and
//! rendered ([`pairs`]); stored in the model folder and applied to any render of that model
//! ([`stage`]). The networks are [`crate::model::appearance`], the losses
//! [`crate::objective::adversarial`].

pub mod config;
pub mod pairs;
pub mod stage;
pub mod train;

pub use config::AppearanceConfig;
pub use stage::{AppearanceStage, StageFolder};
pub use train::{train_appearance, AppearanceOptions, AppearanceSummary};
