//! The terminal side of [`puppet::progress::Progress`]: indicatif bars with ETA on stderr when
//! it is a terminal, plain lines at most every few seconds when it is not (a log file, CI),
//! warnings as `puppet: warning: …` lines, and every line a command prints on stdout — through
//! one place, so a closed pipe or a full disk ends the command with an error, never a panic.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use puppet::progress::Progress;

/// How often a plain progress line is printed when stderr is not a terminal.
const PLAIN_EVERY: Duration = Duration::from_secs(5);

/// Progress, warnings and output for one command run.
pub struct Ui {
    quiet: bool,
    terminal: bool,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    bar: Option<ProgressBar>,
    plain: Option<Plain>,
}

/// A stage reported as plain lines.
struct Plain {
    name: String,
    total: u64,
    done: u64,
    /// Steps an earlier run did ([`Progress::resume`]): not in the pace.
    resumed: u64,
    started: Instant,
    printed: Instant,
    message: String,
}

impl Plain {
    fn line(&self) -> String {
        let elapsed = self.started.elapsed().as_secs_f64();
        let mut line = if self.total > 0 {
            let paced = self.done.saturating_sub(self.resumed).max(1);
            let left = (self.total.saturating_sub(self.done)) as f64 * elapsed / paced as f64;
            format!(
                "{}: {}/{} ({:.0} %), {elapsed:.0} s, about {left:.0} s left",
                self.name,
                self.done,
                self.total,
                100.0 * self.done as f64 / self.total as f64
            )
        } else {
            format!("{}: {elapsed:.0} s", self.name)
        };
        if !self.message.is_empty() {
            line.push_str(" — ");
            line.push_str(&self.message);
        }
        line
    }
}

impl Ui {
    /// A UI that reports progress unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Ui {
            quiet,
            terminal: std::io::stderr().is_terminal(),
            state: Mutex::new(State::default()),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Prints a summary line on stdout (suppressed by `--quiet`).
    ///
    /// # Errors
    /// Writing to stdout failed (a closed pipe, a full disk).
    pub fn say(&self, text: impl AsRef<str>) -> anyhow::Result<()> {
        if self.quiet {
            return Ok(());
        }
        self.print(text)
    }

    /// Prints a result on stdout (a table, a report), even with `--quiet`.
    ///
    /// # Errors
    /// Writing to stdout failed (a closed pipe, a full disk).
    pub fn print(&self, text: impl AsRef<str>) -> anyhow::Result<()> {
        self.finish();
        let mut out = std::io::stdout().lock();
        writeln!(out, "{}", text.as_ref())
            .and_then(|()| out.flush())
            .context("cannot write to standard output")
    }

    /// Ends the current stage, leaving its last state on screen.
    pub fn finish(&self) {
        let mut state = self.state();
        if let Some(bar) = state.bar.take() {
            bar.finish();
        }
        if let Some(plain) = state.plain.take() {
            if plain.done > 0 || plain.total == 0 {
                eprint_quietly(&plain.line());
            }
        }
    }
}

/// Writes a line to stderr; a failure there has nowhere to be reported.
fn eprint_quietly(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

impl Progress for Ui {
    fn stage(&self, name: &str, total: u64) {
        if self.quiet {
            return;
        }
        self.finish();
        let mut state = self.state();
        if !self.terminal {
            let now = Instant::now();
            state.plain = Some(Plain {
                name: name.to_string(),
                total,
                done: 0,
                resumed: 0,
                started: now,
                printed: now,
                message: String::new(),
            });
            eprint_quietly(&format!(
                "{name}: started{}",
                if total > 0 { format!(", {total} steps") } else { String::new() }
            ));
            return;
        }
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
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(name.to_string());
        state.bar = Some(bar);
    }

    fn advance(&self, n: u64) {
        let mut state = self.state();
        if let Some(bar) = &state.bar {
            bar.inc(n);
        }
        if let Some(plain) = &mut state.plain {
            plain.done += n;
            if plain.printed.elapsed() >= PLAIN_EVERY {
                plain.printed = Instant::now();
                eprint_quietly(&plain.line());
            }
        }
    }

    fn resume(&self, n: u64) {
        let mut state = self.state();
        if let Some(bar) = &state.bar {
            bar.inc(n);
            bar.reset_eta();
        }
        if let Some(plain) = &mut state.plain {
            plain.done += n;
            plain.resumed += n;
        }
    }

    fn message(&self, text: &str) {
        let mut state = self.state();
        if let Some(bar) = &state.bar {
            bar.set_message(text.to_string());
        }
        if let Some(plain) = &mut state.plain {
            plain.message = text.to_string();
        }
    }

    fn warn(&self, text: &str) {
        let state = self.state();
        let line = format!("puppet: warning: {text}");
        match &state.bar {
            Some(bar) => bar.suspend(|| eprint_quietly(&line)),
            None => eprint_quietly(&line),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A resumed stage estimates the time left from this run's pace, not from steps an earlier
    /// run did before the clock started.
    #[test]
    fn time_left_after_a_resume_counts_this_runs_steps_only() {
        let ten_seconds_ago = Instant::now() - Duration::from_secs(10);
        let plain = |resumed| Plain {
            name: "training".into(),
            total: 5000,
            done: 3100,
            resumed,
            started: ten_seconds_ago,
            printed: ten_seconds_ago,
            message: String::new(),
        };
        // 100 steps in 10 s, 1,900 to go: about 190 s.
        assert!(plain(3000).line().contains("about 190 s left"), "{}", plain(3000).line());
        assert!(plain(0).line().contains("about 6 s left"), "{}", plain(0).line());
    }
}
