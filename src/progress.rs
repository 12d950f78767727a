//! How long library jobs report progress without printing: the CLI implements [`Progress`] with
//! indicatif bars; tests and library callers use [`Silent`].

/// Receives progress reports from a long job.
pub trait Progress: Sync {
    /// A new stage begins with `total` steps (0 if unknown), e.g. `("meshing", 8)`.
    fn stage(&self, name: &str, total: u64);
    /// `n` more steps of the current stage are done.
    fn advance(&self, n: u64);
    /// A free-form status line for the current stage (losses, the layer being meshed).
    fn message(&self, _text: &str) {}
}

/// A [`Progress`] that ignores everything.
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, _name: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
}
