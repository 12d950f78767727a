//! Reading a user's file within a size limit, so that a huge file, a file that grows while it is
//! read, or a FIFO cannot make the library spend unbounded memory (DESIGN.md "Rules of the
//! house": bad input gets a clear error naming the file).
//!
//! The limits are per kind of file, each far above what real files of that kind hold (the sizes
//! measured on `data/` are given beside each) and far below what would strain a machine:
//!
//! | limit | files | real sizes |
//! |---|---|---|
//! | [`CONFIG`] 1 MiB | `character.toml`, training configs, `train.toml`, eval-rig edits, `net.json`, `rig_truth.json`, a checkpoint's `state.json` and `latest` | under 4 KB |
//! | [`DATA`] 256 MiB | `puppet.json`, `truth.json`, pose files, points files, `split.json`, `log.csv`, the output manifest | `truth.json` of 16 frames: 208 KB; the robot's `puppet.json`: 254 KB, 3.7 MB after two rounds of subdivision (about 86 bytes a vertex) |
//!
//! Images, `.ora` archives, `.psd` files and network weights have limits derived from what they must hold:
//! the pixel limits (`ImageLimits::max_file_bytes`, `ora::max_file_bytes`, `psd::max_file_bytes`) and the network's
//! parameter count (`bundle::max_weights_bytes`).

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// The limit of hand-written configuration files (TOML and small JSON): 1 MiB.
pub const CONFIG: u64 = 1 << 20;
/// The limit of machine-written data files (puppets, poses, ground truth, logs): 256 MiB.
pub const DATA: u64 = 256 << 20;

/// The bytes of the file `path`, refused if it holds more than `limit` bytes.
///
/// The length is checked from the file's metadata before anything is read, and the read itself
/// stops one byte past the limit (a file that grows meanwhile, or a FIFO whose metadata says 0).
///
/// # Errors
/// [`Error::Io`] naming `path` if it cannot be opened or read; [`Error::Limit`] naming `path` and
/// the limit if it is larger.
pub fn read_bytes(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let declared = file.metadata().map_err(|e| Error::io(path, e))?.len();
    check(path, declared, limit)?;
    let mut bytes = Vec::with_capacity(declared as usize);
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| Error::io(path, e))?;
    check(path, bytes.len() as u64, limit)?;
    Ok(bytes)
}

/// The text of the file `path` (UTF-8), refused if it holds more than `limit` bytes.
///
/// # Errors
/// As [`read_bytes`]; [`Error::Format`] naming `path` if it is not UTF-8.
pub fn read_text(path: &Path, limit: u64) -> Result<String> {
    String::from_utf8(read_bytes(path, limit)?).map_err(|e| {
        Error::format(
            path,
            format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()),
        )
    })
}

/// The file `path` opened for reading, if it is a regular file of at most `limit` bytes — for
/// readers that seek rather than read it whole (zip archives).
///
/// # Errors
/// [`Error::Io`] naming `path` if it cannot be opened; [`Error::Format`] if it is not a regular
/// file; [`Error::Limit`] if it is larger than `limit`.
pub fn open(path: &Path, limit: u64) -> Result<File> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::format(path, "not a regular file"));
    }
    check(path, meta.len(), limit)?;
    Ok(file)
}

fn check(path: &Path, size: u64, limit: u64) -> Result<()> {
    if size > limit {
        return Err(Error::limit("the file", size, limit, "bytes").with_path(path));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_within_the_limit_is_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        std::fs::write(&path, "name = \"a\"\n").unwrap();
        assert_eq!(read_text(&path, 11).unwrap(), "name = \"a\"\n");
        assert_eq!(read_bytes(&path, 11).unwrap().len(), 11);
        assert!(open(&path, 11).is_ok());
    }

    #[test]
    fn a_file_over_the_limit_is_refused_naming_it_and_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        std::fs::write(&path, vec![b'#'; 12]).unwrap();
        for err in [read_text(&path, 11).unwrap_err(), open(&path, 11).unwrap_err()] {
            assert!(matches!(err.innermost(), Error::Limit { amount: 12, limit: 11, .. }), "{err}");
            assert_eq!(
                err.to_string(),
                format!("{}: the file is 12 bytes, above the limit of 11 bytes", path.display())
            );
        }
    }

    #[test]
    fn text_that_is_not_utf8_is_a_format_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("latin1.toml");
        std::fs::write(&path, b"name = \"caf\xe9\"").unwrap();
        let err = read_text(&path, CONFIG).unwrap_err();
        assert!(matches!(err, Error::Format { .. }), "{err}");
        assert!(
            err.to_string().contains("latin1.toml") && err.to_string().contains("offset 11"),
            "{err}"
        );
    }

    #[test]
    fn a_folder_is_not_opened_as_a_file() {
        let dir = tempfile::tempdir().unwrap();
        assert!(open(dir.path(), CONFIG).is_err());
        assert!(read_bytes(Path::new("/nonexistent/x"), CONFIG).is_err());
    }
}
