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
use std::sync::{Arc, Mutex, Weak};

use crate::error::{Error, Result};

/// The lock file's name inside a locked folder.
pub const LOCK_FILE: &str = ".puppet-lock";

/// Bytes of the holder's description read back for a refusal: enough for a long command line,
/// bounded whatever the file holds.
const DESCRIPTION_LIMIT: u64 = 4096;

/// An exclusive hold on an output folder, released when the last hold on it in this process is
/// dropped (and by the system when the process ends). Within one process holds are shared: a
/// library call that locks the folder its caller already holds (`auto` running the demo's
/// pipeline into its own output) goes on; only other processes are kept out.
#[derive(Debug, Clone)]
pub struct FolderLock {
    held: Arc<Held>,
}

/// The system's lock on one folder's lock file, shared by this process's holds on it.
#[derive(Debug)]
struct Held {
    file: File,
    path: PathBuf,
    /// The folder, when this lock created it (removed again on release if still empty).
    created: Option<PathBuf>,
}

/// The folders this process holds, by absolute path.
static HELD: Mutex<Vec<(PathBuf, Weak<Held>)>> = Mutex::new(Vec::new());

impl FolderLock {
    /// Locks `dir` for this process, creating it if it does not exist.
    ///
    /// # Errors
    /// [`Error::InUse`] naming the holder when another process holds the folder;
    /// [`Error::Io`] naming the folder or the lock file when either cannot be made or locked.
    pub fn acquire(dir: &Path) -> Result<Self> {
        let key = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
        let mut held = HELD.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        held.retain(|(_, weak)| weak.strong_count() > 0);
        if let Some(shared) = held.iter().find(|(k, _)| *k == key).and_then(|(_, weak)| weak.upgrade()) {
            return Ok(FolderLock { held: shared });
        }
        let created = (!dir.exists()).then(|| dir.to_path_buf());
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let lock = Held::acquire(&dir.join(LOCK_FILE), created.clone());
        match lock {
            Ok(lock) => {
                let lock = Arc::new(lock);
                held.push((key, Arc::downgrade(&lock)));
                Ok(FolderLock { held: lock })
            }
            Err(e) => {
                if let Some(made) = &created {
                    // Only an empty folder goes: the refusal leaves the disk as it found it.
                    let _ = std::fs::remove_dir(made);
                }
                Err(e)
            }
        }
    }

    /// The locked folder.
    pub fn dir(&self) -> &Path {
        self.held.path.parent().unwrap_or(&self.held.path)
    }
}

impl Held {
    fn acquire(path: &Path, created: Option<PathBuf>) -> Result<Self> {
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
            return Ok(Held {
                file,
                path: path.to_path_buf(),
                created,
            });
        }
    }
}

impl Drop for Held {
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

    /// Another process holding `dir`'s lock (util-linux's flock(1), the same system lock), until
    /// the returned child is killed.
    fn held_elsewhere(dir: &Path) -> std::process::Child {
        // --no-fork: flock execs the command itself, so killing it releases the lock (a forked
        // child would keep the locked file open).
        let child = std::process::Command::new("flock")
            .arg("--no-fork")
            .arg(dir.join(LOCK_FILE))
            .args(["sleep", "60"])
            .spawn()
            .expect("flock(1) runs");
        let start = std::time::Instant::now();
        while !dir.join(LOCK_FILE).exists() {
            assert!(start.elapsed().as_secs() < 10, "flock did not create the lock file");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        // flock creates the file, then locks it.
        std::thread::sleep(std::time::Duration::from_millis(200));
        child
    }

    #[test]
    fn a_folder_another_process_holds_is_refused_and_free_once_it_exits() {
        let dir = tempfile::tempdir().unwrap();
        let mut other = held_elsewhere(dir.path());
        let refused = FolderLock::acquire(dir.path()).unwrap_err();
        assert!(matches!(refused, Error::InUse { .. }), "{refused}");
        assert!(refused.to_string().contains(&dir.path().display().to_string()), "{refused}");
        other.kill().unwrap();
        other.wait().unwrap();
        // What a killed holder leaves: the file, but no lock (the system dropped it).
        let lock = FolderLock::acquire(dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join(LOCK_FILE)).unwrap();
        assert!(text.starts_with(&format!("pid {}:", std::process::id())), "{text}");
        drop(lock);
        assert!(!dir.path().join(LOCK_FILE).exists());
    }

    #[test]
    fn holds_within_one_process_are_shared_and_the_last_releases() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let first = FolderLock::acquire(&out).unwrap();
        let nested = FolderLock::acquire(&out).unwrap();
        assert_eq!(first.dir(), out);
        drop(first);
        assert!(out.join(LOCK_FILE).exists(), "the nested hold keeps it");
        std::fs::write(out.join("output.txt"), b"kept").unwrap();
        drop(nested);
        assert!(!out.join(LOCK_FILE).exists());
        assert_eq!(std::fs::read(out.join("output.txt")).unwrap(), b"kept");
        let made = dir.path().join("empty");
        drop(FolderLock::acquire(&made).unwrap());
        assert!(!made.exists(), "a folder the lock made, still empty, goes with it");
    }
}
