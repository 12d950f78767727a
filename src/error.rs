//! The library's error type: every variant says where (file, layer, frame) and what is wrong.
//!
//! Messages follow STYLE.md: lowercase, no final period, `where: what is wrong (what was expected)`.

use std::path::{Path, PathBuf};

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in the library, each carrying its location.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {error}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said (part of the message, not a separate cause, so it prints once).
        error: std::io::Error,
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
    /// Several independent problems, all reported at once (e.g. every bad layer of an import).
    #[error("{}", display_many(.0))]
    Many(Vec<Error>),
    /// Invalid options or arguments, not tied to a file.
    #[error("{0}")]
    Invalid(String),
}

fn display_many(errors: &[Error]) -> String {
    let lines: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
    format!("{} problems:\n  {}", errors.len(), lines.join("\n  "))
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            error: source,
        }
    }

    /// A content error in `path`.
    pub fn format(path: impl AsRef<Path>, problem: impl Into<String>) -> Self {
        Error::Format {
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

    /// Collapses a list of errors: none → `Ok(())`, one → itself, several → [`Error::Many`].
    pub fn collect(mut errors: Vec<Error>) -> Result<()> {
        match errors.len() {
            0 => Ok(()),
            1 => Err(errors.pop().expect("length checked")),
            _ => Err(Error::Many(errors)),
        }
    }
}
