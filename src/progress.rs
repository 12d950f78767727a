//! How long library jobs report progress and warnings without printing: the CLI implements
//! [`Progress`] with bars (or plain lines when not on a terminal); tests and library callers use
//! [`Silent`] or [`Recorder`].

use std::sync::Mutex;

/// Receives progress reports and warnings from a long job.
pub trait Progress: Sync {
    /// A new stage begins with `total` steps (0 if unknown), e.g. `("meshing", 8)`.
    fn stage(&self, name: &str, total: u64);
    /// `n` more steps of the current stage are done.
    fn advance(&self, n: u64);
    /// The first `n` steps of the current stage were done by an earlier run (a resumed
    /// training): counted as done, but not in the pace the time left is estimated from.
    fn resume(&self, n: u64) {
        self.advance(n);
    }
    /// A free-form status line for the current stage (losses, the layer being meshed).
    fn message(&self, _text: &str) {}
    /// Something the user should know that does not stop the job (a layer no joint connects, a
    /// setting that was reduced to what the input allows), in the library's words.
    fn warn(&self, text: &str);
    /// Whether whoever watches asks the job to stop at its next safe point (a training run
    /// checkpoints and ends there, resumable). Never, by default.
    fn stop_requested(&self) -> bool {
        false
    }
}

/// A [`Progress`] that ignores everything.
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, _name: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
    fn warn(&self, _text: &str) {}
}

/// A [`Progress`] that keeps the warnings it receives (for callers that show them later, and
/// for tests).
#[derive(Debug, Default)]
pub struct Recorder {
    warnings: Mutex<Vec<String>>,
}

impl Recorder {
    /// The warnings received so far.
    pub fn warnings(&self) -> Vec<String> {
        self.warnings.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
    }
}

impl Progress for Recorder {
    fn stage(&self, _name: &str, _total: u64) {}
    fn advance(&self, _n: u64) {}
    fn warn(&self, text: &str) {
        self.warnings
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(text.to_string());
    }
}
