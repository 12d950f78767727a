//! The terminal side of [`puppet::progress::Progress`]: indicatif bars with ETA on stderr, and
//! the summary lines commands print on stdout.

use std::io::Write;
use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};
use puppet::progress::Progress;

/// Progress bars and messages for one command run.
pub struct Ui {
    quiet: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Ui {
    /// A UI that shows bars unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Ui {
            quiet,
            bar: Mutex::new(None),
        }
    }

    /// Prints a summary line on stdout (suppressed by `--quiet`).
    pub fn say(&self, text: impl AsRef<str>) {
        if !self.quiet {
            self.finish();
            // A closed pipe (`puppet info … | head`) is not worth failing over.
            let _ = writeln!(std::io::stdout().lock(), "{}", text.as_ref());
        }
    }

    /// Ends the current bar, leaving its last state on screen.
    pub fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("no panics while holding the bar").take() {
            bar.finish();
        }
    }
}

impl Progress for Ui {
    fn stage(&self, name: &str, total: u64) {
        if self.quiet {
            return;
        }
        self.finish();
        let bar = if total == 0 {
            ProgressBar::new_spinner()
        } else {
            ProgressBar::new(total)
        };
        let template = if total == 0 {
            "{spinner} {prefix:>10} {elapsed_precise} {msg}"
        } else {
            "{prefix:>10} [{bar:30}] {pos}/{len} {elapsed_precise} eta {eta_precise} {msg}"
        };
        bar.set_style(
            ProgressStyle::with_template(template)
                .expect("template is valid")
                .progress_chars("=> "),
        );
        bar.set_prefix(name.to_string());
        *self.bar.lock().expect("no panics while holding the bar") = Some(bar);
    }

    fn advance(&self, n: u64) {
        if let Some(bar) = self.bar.lock().expect("no panics while holding the bar").as_ref() {
            bar.inc(n);
        }
    }

    fn message(&self, text: &str) {
        if let Some(bar) = self.bar.lock().expect("no panics while holding the bar").as_ref() {
            bar.set_message(text.to_string());
        }
    }
}
