//! Evaluation reports (DESIGN.md "Metrics"): a model scored on frames with the metrics of
//! [`crate::metrics`] (`puppet eval`), which vertices a pose shows, correspondences scored on
//! synthetic truth (neural-puppet.md Table 2), and in-betweens scored against the true frames.

pub mod edit_poses;
pub mod inbetween_eval;
pub mod parts;
pub mod pck_pairs;
pub mod posed_pairs;
pub mod report;
pub mod rig;
