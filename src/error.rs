//! The library's error type: each variant says what went wrong; wrappers add the file, frame,
//! key or pin where each becomes known (ripgrep's `WithPath`/`Partial`, STYLE.md §1).
//!
//! Messages follow STYLE.md: lowercase, no final period, `where: what is wrong (what was
//! expected)`, in the library's words — never a command-line flag (the CLI adds those).
//! Display prints the whole message, wrappers included; the wrapped error stays typed (boxed,
//! never flattened to a string), so a caller can still ask what went wrong
//! ([`Error::innermost`]).

use std::fmt;
use std::path::{Path, PathBuf};

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The kinds of folder the library reads, so an error can say which one it expected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FolderKind {
    /// Character artwork: PNG layers + `character.toml`, a label map, or an `.ora` file.
    Artwork,
    /// A built puppet: `puppet.json` and its textures.
    Puppet,
    /// A trained model: network, weights, puppet, training config and split.
    Model,
    /// A sequence of frames (PNG files, or a folder holding `frames/`).
    Sequence,
    /// A trained appearance stage: `appearance/` in a model folder.
    Appearance,
}

impl fmt::Display for FolderKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FolderKind::Artwork => "character artwork (PNG layers with character.toml, a label map, or an .ora or .psd file)",
            FolderKind::Puppet => "a puppet folder (puppet.json and textures/)",
            FolderKind::Model => "a model folder (net.json, weights.bpk, puppet/, train.toml)",
            FolderKind::Sequence => "a sequence of frames (PNG files, or a folder holding frames/)",
            FolderKind::Appearance => "a trained appearance stage (appearance/ with net.json, generator.bpk and stage.json)",
        })
    }
}

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {err}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        err: std::io::Error,
    },
    /// An image file could not be decoded or encoded.
    #[error("{}: {problem}", .path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong with it.
        problem: String,
    },
    /// A file was read but its content is wrong (bad TOML/JSON/XML/zip, unknown key, missing entry).
    #[error("{}: {problem}", .path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        problem: String,
    },
    /// A sprite sheet whose poses cannot be told apart by their alpha: its grid must be given.
    #[error("{}: {problem}", .path.display())]
    SheetLayout {
        /// The sheet.
        path: PathBuf,
        /// Why the poses cannot be split.
        problem: String,
    },
    /// One layer of a character is wrong.
    #[error("{}: layer {layer:?}: {problem}", .path.display())]
    Layer {
        /// The file that defines or holds the layer.
        path: PathBuf,
        /// The layer's name as the user wrote it.
        layer: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A setting is out of range or inconsistent.
    #[error("{name} = {value} ({expected})")]
    Setting {
        /// The setting, in the library's words (a config key or an options field).
        name: String,
        /// The value given.
        value: String,
        /// What would have been accepted.
        expected: String,
    },
    /// Sizes or counts that must agree do not (a frame of another size, a pose of another puppet).
    #[error("{what} is {found}, expected {expected}")]
    Mismatch {
        /// What was measured.
        what: String,
        /// What it is.
        found: String,
        /// What it should be.
        expected: String,
    },
    /// Geometry that cannot be worked with (a degenerate triangle, a coordinate that is not finite).
    #[error("{what}: {problem}")]
    Geometry {
        /// The mesh, triangle, vertex or point.
        what: String,
        /// What is wrong with it.
        problem: String,
    },
    /// Honouring the input would spend more memory or time than a limit allows; checked before
    /// the memory is spent.
    #[error("{what} is {amount} {unit}, above the limit of {limit} {unit}")]
    Limit {
        /// What is too large (names the limit's setting where one can raise it).
        what: String,
        /// Its size.
        amount: u64,
        /// The limit.
        limit: u64,
        /// The unit of both.
        unit: &'static str,
    },
    /// A point the user chose is not on the character.
    #[error("point ({:.1}, {:.1}) is not on the character{}", .point[0], .point[1], nearest_text(.nearest))]
    OffCharacter {
        /// The point, frame pixels.
        point: [f32; 2],
        /// The nearest layer and its distance in pixels, if the puppet has any triangle.
        nearest: Option<(String, f32)>,
    },
    /// Training stopped on a loss that is not finite.
    #[error("step {step}: the loss is not finite ({losses}); stopped — the last good checkpoint is {}", checkpoint_text(.checkpoint))]
    Diverged {
        /// The step (1-based) whose loss was not finite.
        step: u64,
        /// The loss terms as numbers.
        losses: String,
        /// The newest checkpoint written before it.
        checkpoint: Option<PathBuf>,
    },
    /// An output would replace a file or folder this program did not write.
    #[error("{}: {reason}; refusing to overwrite it", .path.display())]
    WouldOverwrite {
        /// The existing file or folder.
        path: PathBuf,
        /// What it is and why it is in the way.
        reason: String,
    },
    /// A folder is not the kind an operation needs.
    #[error("{}: {problem} (expected {expected})", .path.display())]
    WrongFolder {
        /// The folder.
        path: PathBuf,
        /// The kind expected.
        expected: FolderKind,
        /// What was found instead.
        problem: String,
    },
    /// Continuing a training run was refused; nothing was written.
    #[error("{}: cannot resume: {problem}", .path.display())]
    Resume {
        /// The model folder.
        path: PathBuf,
        /// Why.
        problem: String,
    },
    /// An output folder is being written by another running command.
    #[error("{}: in use by {holder}; wait for it to finish or choose another output", .path.display())]
    InUse {
        /// The folder.
        path: PathBuf,
        /// The process holding it, as it described itself ("pid N: command line").
        holder: String,
    },
    /// A training run's folder already holds a checkpoint, and resuming was not asked for.
    #[error("{}: holds a checkpoint of an earlier run at step {step}; resume it or choose another output", .path.display())]
    RunExists {
        /// The model folder.
        path: PathBuf,
        /// The checkpoint's step.
        step: u64,
    },
    /// A numeric solver of a higher layer failed; its own typed error is kept (downcast it).
    #[error("{what}: {err}")]
    Solver {
        /// What was being solved, and for which layer.
        what: String,
        /// The solver's error.
        err: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The tensor backend could not do an operation.
    #[error("{op}: {problem}")]
    Backend {
        /// The operation.
        op: &'static str,
        /// What went wrong.
        problem: String,
    },
    /// An error about a file, as read or written there.
    #[error("{}: {err}", .path.display())]
    WithPath {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong with it.
        err: Box<Error>,
    },
    /// An error about one frame of several.
    #[error("frame {frame}: {err}")]
    WithFrame {
        /// The frame's name (its file name).
        frame: String,
        /// What went wrong with it.
        err: Box<Error>,
    },
    /// An error about one key of a config or record.
    #[error("{key}: {err}")]
    WithKey {
        /// The key, dotted (`train.batch`).
        key: String,
        /// What went wrong with it.
        err: Box<Error>,
    },
    /// An error about one pin of several (1-based, as the user gave them).
    #[error("pin {pin}: {err}")]
    WithPin {
        /// The pin's number, from 1.
        pin: usize,
        /// What went wrong with it.
        err: Box<Error>,
    },
    /// Several independent problems, all reported at once (every bad layer of an import, every
    /// bad frame of an evaluation).
    #[error("{}", display_many(.0))]
    Partial(Vec<Error>),
}

fn nearest_text(nearest: &Option<(String, f32)>) -> String {
    nearest
        .as_ref()
        .map_or_else(String::new, |(layer, d)| format!(" (nearest layer {layer:?} is {d:.1} px away)"))
}

fn checkpoint_text(checkpoint: &Option<PathBuf>) -> String {
    checkpoint
        .as_ref()
        .map_or_else(|| "none was written yet".to_string(), |p| p.display().to_string())
}

fn display_many(errors: &[Error]) -> String {
    let lines: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
    format!("{} problems:\n  {}", errors.len(), lines.join("\n  "))
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, err: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            err,
        }
    }

    /// A content error in `path`.
    pub fn format(path: impl AsRef<Path>, problem: impl Into<String>) -> Self {
        Error::Format {
            path: path.as_ref().to_path_buf(),
            problem: problem.into(),
        }
    }

    /// An image file that cannot be decoded, encoded or used.
    pub fn image(path: impl AsRef<Path>, problem: impl Into<String>) -> Self {
        Error::Image {
            path: path.as_ref().to_path_buf(),
            problem: problem.into(),
        }
    }

    /// A problem with layer `layer` defined in or stored at `path`.
    pub fn layer(path: impl AsRef<Path>, layer: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::Layer {
            path: path.as_ref().to_path_buf(),
            layer: layer.into(),
            problem: problem.into(),
        }
    }

    /// A setting `name` whose `value` is not `expected`.
    pub fn setting(name: impl Into<String>, value: impl fmt::Display, expected: impl Into<String>) -> Self {
        Error::Setting {
            name: name.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }

    /// `what` is `found` where `expected` was needed.
    pub fn mismatch(what: impl Into<String>, found: impl fmt::Display, expected: impl fmt::Display) -> Self {
        Error::Mismatch {
            what: what.into(),
            found: found.to_string(),
            expected: expected.to_string(),
        }
    }

    /// Geometry `what` that cannot be used because of `problem`.
    pub fn geometry(what: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::Geometry {
            what: what.into(),
            problem: problem.into(),
        }
    }

    /// `what` needs `amount` `unit`s, more than `limit`.
    pub fn limit(what: impl Into<String>, amount: u64, limit: u64, unit: &'static str) -> Self {
        Error::Limit {
            what: what.into(),
            amount,
            limit,
            unit,
        }
    }

    /// The backend failed at `op`.
    pub fn backend(op: &'static str, problem: impl fmt::Debug) -> Self {
        Error::Backend {
            op,
            problem: format!("{problem:?}"),
        }
    }

    /// This error, said about the file or folder `path`.
    #[must_use]
    pub fn with_path(self, path: impl AsRef<Path>) -> Self {
        Error::WithPath {
            path: path.as_ref().to_path_buf(),
            err: Box::new(self),
        }
    }

    /// This error, said about frame `frame`.
    #[must_use]
    pub fn with_frame(self, frame: impl Into<String>) -> Self {
        Error::WithFrame {
            frame: frame.into(),
            err: Box::new(self),
        }
    }

    /// This error, said about key `key`.
    #[must_use]
    pub fn with_key(self, key: impl Into<String>) -> Self {
        Error::WithKey {
            key: key.into(),
            err: Box::new(self),
        }
    }

    /// This error, said about pin number `pin` (from 1).
    #[must_use]
    pub fn with_pin(self, pin: usize) -> Self {
        Error::WithPin { pin, err: Box::new(self) }
    }

    /// The error inside every wrapper (the first of a [`Error::Partial`]).
    pub fn innermost(&self) -> &Error {
        match self {
            Error::WithPath { err, .. } | Error::WithFrame { err, .. } | Error::WithKey { err, .. } | Error::WithPin { err, .. } => {
                err.innermost()
            }
            Error::Partial(errors) => errors.first().map_or(self, Error::innermost),
            other => other,
        }
    }

    /// Collapses a list of errors: none → `Ok(())`, one → itself, several → [`Error::Partial`].
    pub fn collect(mut errors: Vec<Error>) -> Result<()> {
        match errors.len() {
            0 => Ok(()),
            1 => Err(errors.pop().expect("length checked")),
            _ => Err(Error::Partial(errors)),
        }
    }
}

/// Adds context to a library `Result` where it becomes known.
pub trait Context<T> {
    /// The error, if any, said about the file or folder `path`.
    fn at_path(self, path: impl AsRef<Path>) -> Result<T>;
    /// The error, if any, said about frame `frame`.
    fn at_frame(self, frame: impl Into<String>) -> Result<T>;
    /// The error, if any, said about key `key`.
    fn at_key(self, key: impl Into<String>) -> Result<T>;
}

impl<T> Context<T> for Result<T> {
    fn at_path(self, path: impl AsRef<Path>) -> Result<T> {
        self.map_err(|e| e.with_path(path))
    }

    fn at_frame(self, frame: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.with_frame(frame))
    }

    fn at_key(self, key: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.with_key(key))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrappers_read_outside_in_and_keep_the_cause_typed() {
        let e = Error::setting("batch", 0, "at least 1").with_key("train").with_path("run.toml");
        assert_eq!(e.to_string(), "run.toml: train: batch = 0 (at least 1)");
        assert!(matches!(e.innermost(), Error::Setting { name, .. } if name == "batch"));
        let many = Error::collect(vec![
            Error::geometry("triangle 3", "zero area").with_frame("a.png"),
            Error::limit("canvas", 400, 100, "Mpx"),
        ])
        .unwrap_err();
        assert_eq!(
            many.to_string(),
            "2 problems:\n  frame a.png: triangle 3: zero area\n  canvas is 400 Mpx, above the limit of 100 Mpx"
        );
        assert!(Error::collect(Vec::new()).is_ok());
    }
}
