//! One writer per output folder: a command that fills a folder holds [`FolderLock`] on it for
//! as long as it writes, so a second command on the same folder (a second `train` of one
//! config, a `train --resume` beside the running run) is refused at once, naming the process
//! that holds it, instead of interleaving its files with the first's.
//!
//! The lock is the operating system's advisory lock on [`LOCK_FILE`] inside the folder
//! ([`std::fs::File::try_lock`]): the system releases it when its holder exits, however it
//! exits, so a run that was killed never blocks the next one. The file itself holds the
//! holder's process id and command line, for the refusal's message; it is removed when the lock
//! is released.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The lock file's name inside a locked folder.
pub const LOCK_FILE: &str = ".puppet-lock";

/// Bytes of the holder's description read back for a refusal: enough for a long command line,
/// bounded whatever the file holds.
const DESCRIPTION_LIMIT: u64 = 4096;

/// An exclusive hold on an output folder, released when dropped (and by the system when the
/// process ends).
#[derive(Debug)]
pub struct FolderLock {
    file: File,
    path: PathBuf,
    /// The folder, when this lock created it (removed again on release if still empty).
    created: Option<PathBuf>,
}

impl FolderLock {
    /// Locks `dir` for this process, creating it if it does not exist.
    ///
    /// # Errors
    /// [`Error::InUse`] naming the holder when another process holds the folder;
    /// [`Error::Io`] naming the folder or the lock file when either cannot be made or locked.
    pub fn acquire(dir: &Path) -> Result<Self> {
        let created = (!dir.exists()).then(|| dir.to_path_buf());
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let path = dir.join(LOCK_FILE);
        let lock = Self::try_acquire(&path, created.clone());
        if lock.is_err() {
            if let Some(made) = &created {
                // Only an empty folder goes: the refusal leaves the disk as it found it.
                let _ = std::fs::remove_dir(made);
            }
        }
        lock
    }

    fn try_acquire(path: &Path, created: Option<PathBuf>) -> Result<Self> {
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
                .map_err(|e| Error::io(path, e))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    return Err(Error::InUse {
                        path: path.parent().unwrap_or(path).to_path_buf(),
                        holder: holder(&mut file),
                    })
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(path, e)),
            }
            // The holder before us may have removed the file between our open and our lock:
            // then we hold a lock on a file nobody else can find, and must lock the new one.
            if !same_file(&file, path) {
                continue;
            }
            file.set_len(0).map_err(|e| Error::io(path, e))?;
            file.rewind().map_err(|e| Error::io(path, e))?;
            let command: Vec<String> = std::env::args().collect();
            writeln!(file, "pid {}: {}", std::process::id(), command.join(" ")).map_err(|e| Error::io(path, e))?;
            return Ok(FolderLock {
                file,
                path: path.to_path_buf(),
                created,
            });
        }
    }

    /// The locked folder.
    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(&self.path)
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // Removed while still locked, so a process that opened it meanwhile sees it gone (above).
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
        if let Some(made) = &self.created {
            let _ = std::fs::remove_dir(made);
        }
    }
}

/// The holder's description as it wrote it ("pid N: command line"), or a placeholder.
fn holder(file: &mut File) -> String {
    let mut text = String::new();
    let read = file.take(DESCRIPTION_LIMIT).read_to_string(&mut text);
    match read.ok().map(|_| text.trim()) {
        Some(line) if !line.is_empty() => line.to_string(),
        _ => "another process".to_string(),
    }
}

/// Whether the open `file` is the one at `path` now.
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

/// Whether the open `file` is the one at `path` now (elsewhere: the file still exists).
#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_a_folder_is_refused_naming_the_holder() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let first = FolderLock::acquire(&out).unwrap();
        let refused = FolderLock::acquire(&out).unwrap_err();
        let message = refused.to_string();
        assert!(matches!(refused, Error::InUse { .. }), "{message}");
        assert!(message.contains(&format!("pid {}", std::process::id())), "{message}");
        assert!(message.contains(&out.display().to_string()), "{message}");
        assert_eq!(first.dir(), out);
        drop(first);
        assert!(!out.exists(), "the folder the lock made, still empty, goes with it");
        let again = FolderLock::acquire(&out).unwrap();
        std::fs::write(out.join("output.txt"), b"kept").unwrap();
        drop(again);
        assert_eq!(std::fs::read(out.join("output.txt")).unwrap(), b"kept");
        assert!(!out.join(LOCK_FILE).exists());
    }

    #[test]
    fn a_refused_lock_leaves_a_folder_it_did_not_make() {
        let dir = tempfile::tempdir().unwrap();
        let _held = FolderLock::acquire(dir.path()).unwrap();
        assert!(FolderLock::acquire(dir.path()).is_err());
        assert!(dir.path().join(LOCK_FILE).exists(), "the holder's file stays");
    }

    #[test]
    fn a_stale_lock_file_without_a_holder_does_not_block() {
        let dir = tempfile::tempdir().unwrap();
        // What a killed run leaves: the file, but no lock (the system dropped it with the process).
        std::fs::write(dir.path().join(LOCK_FILE), b"pid 999999: puppet train gone.toml\n").unwrap();
        let lock = FolderLock::acquire(dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join(LOCK_FILE)).unwrap();
        assert!(text.starts_with(&format!("pid {}:", std::process::id())), "{text}");
        drop(lock);
    }
}
