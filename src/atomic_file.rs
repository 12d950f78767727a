//! Writing outputs without losing a user's work: every file is written atomically (a temporary
//! sibling, then a rename, the temporary removed if anything fails), and [`Outputs`] refuses to
//! replace a file that this program did not write, or to write one name twice in a run.
//!
//! What puppet wrote is recorded per folder in a small manifest, [`MANIFEST`] (a line per file:
//! its name, size and modification time; a folder puppet made: its name), so running a command
//! again may replace its own earlier outputs — but not a user's file of the same name, nor an
//! output the user has since edited — unless the caller says to (`force`).

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{Error, Result};
use crate::folder_lock::{FolderLock, LOCK_FILE};

/// The manifest of the files puppet wrote into a folder.
pub const MANIFEST: &str = ".puppet-outputs";

/// Writes `bytes` to `path` atomically, creating the parent folder if needed; on failure no
/// temporary file is left behind and `path` is unchanged.
///
/// # Errors
/// [`Error::Io`] naming `path` (or its folder) if any step fails.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let parent = parent_of(path);
    std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    let name = path
        .file_name()
        .ok_or_else(|| Error::io(path, std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file path")))?;
    let tmp = parent.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    let result = std::fs::write(&tmp, bytes)
        .map_err(|e| Error::io(&tmp, e))
        .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e)));
    if result.is_err() {
        // Best effort: the temporary may not exist (the write itself failed to create it).
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn parent_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// The outputs of one command: each path is claimed before anything is written, so a command
/// that would replace a file it did not write, or write two outputs to one name, fails before
/// it changes anything on disk.
#[derive(Debug, Default)]
pub struct Outputs {
    force: bool,
    claimed: Mutex<HashSet<PathBuf>>,
    written: Mutex<HashSet<PathBuf>>,
    /// The folders this command fills, held until it is done.
    locks: Mutex<Vec<FolderLock>>,
}

impl Outputs {
    /// Outputs that may replace only files puppet wrote, or (`force`) any file.
    pub fn new(force: bool) -> Self {
        Outputs {
            force,
            claimed: Mutex::new(HashSet::new()),
            written: Mutex::new(HashSet::new()),
            locks: Mutex::new(Vec::new()),
        }
    }

    /// Whether this run may replace files puppet did not write.
    pub fn forced(&self) -> bool {
        self.force
    }

    /// Claims `path` for this command.
    ///
    /// # Errors
    /// [`Error::WouldOverwrite`] if `path` was claimed before in this run, or as
    /// [`Outputs::check`].
    pub fn claim(&self, path: &Path) -> Result<()> {
        let key = absolute(path);
        let mut claimed = self.claimed.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if claimed.contains(&key) {
            return Err(Error::WouldOverwrite {
                path: path.to_path_buf(),
                reason: "two outputs of this command have this name".into(),
            });
        }
        self.check(path)?;
        claimed.insert(key);
        Ok(())
    }

    /// Checks that this command may write `path`, without claiming it: for a command that looks
    /// at everything it will write before it starts, while the parts that write claim their own.
    ///
    /// # Errors
    /// [`Error::WouldOverwrite`] if `path` exists and is not in its folder's manifest (unless
    /// forced), or is a folder; [`Error::Io`] if the manifest cannot be read.
    pub fn check(&self, path: &Path) -> Result<()> {
        if path.is_dir() {
            return Err(Error::WouldOverwrite {
                path: path.to_path_buf(),
                reason: "is a folder, where this command writes a file".into(),
            });
        }
        if path.exists() && !self.force && !written_by_puppet(path)? {
            return Err(Error::WouldOverwrite {
                path: path.to_path_buf(),
                reason: "exists and was not written by puppet".into(),
            });
        }
        Ok(())
    }

    /// Claims a folder this command fills: it may exist if puppet made it (its manifest lists it in
    /// the parent folder) or is empty, or (`force`) in any case. The folder is locked for as long
    /// as these outputs live ([`FolderLock`]): another command filling it meanwhile is refused.
    ///
    /// # Errors
    /// [`Error::WouldOverwrite`] otherwise; [`Error::InUse`] while another process fills it.
    pub fn claim_folder(&self, dir: &Path) -> Result<()> {
        if dir.exists() && !dir.is_dir() {
            return Err(Error::WouldOverwrite {
                path: dir.to_path_buf(),
                reason: "is a file, where this command writes a folder".into(),
            });
        }
        // Locked first, so a folder another command is filling is refused as in use, not as
        // someone else's; on refusal the lock goes again (with a folder it made).
        let existed = dir.exists();
        let Some(lock) = self.lock_folder(dir)? else {
            // Claimed before by this command.
            return Ok(());
        };
        if existed && !self.force {
            let mut entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
            let empty = entries.all(|e| e.is_ok_and(|e| e.file_name() == LOCK_FILE));
            if !(empty || written_by_puppet(dir)?) {
                self.unlock(&lock);
                return Err(Error::WouldOverwrite {
                    path: dir.to_path_buf(),
                    reason: "exists and was not made by puppet".into(),
                });
            }
        }
        Ok(())
    }

    /// Locks a folder this command writes files into, for as long as these outputs live
    /// ([`FolderLock`]), without claiming the folder itself (its other files stay the user's).
    /// The folder's absolute path if this call took the lock, `None` if these outputs held it.
    ///
    /// # Errors
    /// [`Error::InUse`] while another process writes into it; [`Error::Io`] if it cannot be made.
    pub fn lock_folder(&self, dir: &Path) -> Result<Option<PathBuf>> {
        let mut locks = self.locks.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let key = absolute(dir);
        if locks.iter().any(|held| absolute(held.dir()) == key) {
            return Ok(None);
        }
        locks.push(FolderLock::acquire(dir)?);
        Ok(Some(key))
    }

    /// Releases the lock [`Outputs::lock_folder`] took on `key`.
    fn unlock(&self, key: &Path) {
        let mut locks = self.locks.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        locks.retain(|held| absolute(held.dir()) != key);
    }

    /// Writes `bytes` to `path` atomically (claiming it first unless this run already has),
    /// and records it in the manifest.
    ///
    /// # Errors
    /// As [`Outputs::claim`] and [`write_atomic`]; [`Error::WouldOverwrite`] if this run wrote
    /// `path` already.
    pub fn write(&self, path: &Path, bytes: &[u8]) -> Result<()> {
        let key = absolute(path);
        let claimed = self
            .claimed
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .contains(&key);
        if !claimed {
            self.claim(path)?;
        }
        if !self.written.lock().unwrap_or_else(std::sync::PoisonError::into_inner).insert(key) {
            return Err(Error::WouldOverwrite {
                path: path.to_path_buf(),
                reason: "two outputs of this command have this name".into(),
            });
        }
        write_atomic(path, bytes)?;
        record(path)
    }
}

/// Records that puppet wrote `path` (a file as it is now, or a folder it made) in its folder's
/// manifest.
///
/// # Errors
/// [`Error::Io`] naming the manifest, or `path` if it cannot be examined.
pub fn record(path: &Path) -> Result<()> {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Ok(());
    };
    let manifest = parent_of(path).join(MANIFEST);
    let mut entries = read_manifest(&manifest)?;
    let stamp = stamp(path)?;
    if entries.get(&name) != Some(&stamp) {
        entries.insert(name, stamp);
        let text: String = entries
            .iter()
            .map(|(n, s)| if s.is_empty() { format!("{n}\n") } else { format!("{n}\t{s}\n") })
            .collect();
        write_atomic(&manifest, text.as_bytes())?;
    }
    Ok(())
}

/// Whether `path` is listed in its folder's manifest and, for a file, unchanged since.
///
/// # Errors
/// [`Error::Io`] if the manifest exists but cannot be read.
pub fn written_by_puppet(path: &Path) -> Result<bool> {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Ok(false);
    };
    let entries = read_manifest(&parent_of(path).join(MANIFEST))?;
    Ok(entries
        .get(&name)
        .is_some_and(|recorded| stamp(path).is_ok_and(|now| now == *recorded)))
}

/// A file's size and modification time (`"<bytes>\t<ns>"`); empty for a folder, whose contents
/// puppet manages itself.
fn stamp(path: &Path) -> Result<String> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Ok(String::new());
    }
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    Ok(format!("{}\t{modified}", meta.len()))
}

/// The manifest's entries: name → stamp (none if there is no manifest).
fn read_manifest(manifest: &Path) -> Result<BTreeMap<String, String>> {
    match crate::user_file::read_text(manifest, crate::user_file::DATA) {
        Ok(text) => Ok(text
            .lines()
            .filter(|l| !l.is_empty())
            .map(|l| match l.split_once('\t') {
                Some((name, stamp)) => (name.to_string(), stamp.to_string()),
                None => (l.to_string(), String::new()),
            })
            .collect()),
        Err(Error::Io { err, .. }) if err.kind() == std::io::ErrorKind::NotFound => Ok(BTreeMap::new()),
        Err(e) => Err(e),
    }
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Output stems for `sources` that never collide: each file's stem, prefixed by as many of its
/// parent folders' names (joined with `_`) as it takes to tell it from the others (two frames
/// `walk-7/frame_000.png` and `walk-9/frame_000.png` become `walk-7_frame_000` and
/// `walk-9_frame_000`); a numeric suffix settles what the folders cannot.
pub fn unique_stems(sources: &[PathBuf]) -> Vec<String> {
    let parts: Vec<Vec<String>> = sources
        .iter()
        .map(|p| {
            let abs = absolute(p);
            let mut parts: Vec<String> = abs
                .parent()
                .into_iter()
                .flat_map(|d| d.components().rev())
                .filter_map(|c| match c {
                    std::path::Component::Normal(n) => Some(n.to_string_lossy().into_owned()),
                    _ => None,
                })
                .collect();
            parts.insert(
                0,
                p.file_stem().map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned()),
            );
            parts
        })
        .collect();
    let name = |k: usize, depth: usize| -> String {
        let p = &parts[k];
        let mut used: Vec<&str> = p.iter().take(depth + 1).map(String::as_str).collect();
        used.reverse();
        used.join("_")
    };
    let mut depth = vec![0usize; sources.len()];
    loop {
        let names: Vec<String> = (0..sources.len()).map(|k| name(k, depth[k])).collect();
        let mut grew = false;
        for k in 0..sources.len() {
            let clash = names.iter().enumerate().any(|(j, n)| j != k && *n == names[k]);
            if clash && depth[k] + 1 < parts[k].len() {
                depth[k] += 1;
                grew = true;
            }
        }
        if !grew {
            let mut seen = HashSet::new();
            return names
                .into_iter()
                .map(|n| {
                    let mut unique = n.clone();
                    let mut k = 2;
                    while !seen.insert(unique.clone()) {
                        unique = format!("{n}_{k}");
                        k += 1;
                    }
                    unique
                })
                .collect();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_no_temporary_and_the_target_unchanged() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("dirs");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(target.join("keep"), b"k").unwrap();
        assert!(write_atomic(&target, b"x").is_err(), "a folder cannot be replaced by a file");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["dirs"], "no .dirs.tmp left behind");
        assert_eq!(std::fs::read(target.join("keep")).unwrap(), b"k");
    }

    #[test]
    fn outputs_replace_only_what_puppet_wrote_and_never_one_name_twice() {
        let dir = tempfile::tempdir().unwrap();
        let mine = dir.path().join("a.png");
        let users = dir.path().join("b.png");
        std::fs::write(&users, b"user").unwrap();
        let run = Outputs::new(false);
        run.claim(&mine).unwrap();
        run.write(&mine, b"1").unwrap();
        assert!(
            matches!(run.claim(&mine), Err(Error::WouldOverwrite { .. })),
            "claimed twice in one run"
        );
        assert!(
            matches!(run.write(&mine, b"x"), Err(Error::WouldOverwrite { .. })),
            "written twice in one run"
        );
        assert!(matches!(run.claim(&users), Err(Error::WouldOverwrite { .. })));
        assert_eq!(std::fs::read(&users).unwrap(), b"user");
        let again = Outputs::new(false);
        again.write(&mine, b"2").unwrap();
        assert_eq!(std::fs::read(&mine).unwrap(), b"2", "a later run replaces puppet's own output");
        Outputs::new(true).write(&users, b"forced").unwrap();
        assert_eq!(std::fs::read(&users).unwrap(), b"forced");
        let manifest = std::fs::read_to_string(dir.path().join(MANIFEST)).unwrap();
        let names: Vec<&str> = manifest.lines().map(|l| l.split('\t').next().unwrap()).collect();
        assert_eq!(names, ["a.png", "b.png"]);
        // An output the user edited since is theirs now.
        std::fs::write(&mine, b"edited by hand").unwrap();
        assert!(matches!(Outputs::new(false).claim(&mine), Err(Error::WouldOverwrite { .. })));
    }

    #[test]
    fn folders_are_claimed_only_if_empty_or_made_by_puppet() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("model");
        let claim = |dir: &Path| Outputs::new(false).claim_folder(dir);
        claim(&out).unwrap();
        assert!(!out.exists(), "a folder made only to lock it goes when the command is done");
        std::fs::create_dir(&out).unwrap();
        claim(&out).unwrap();
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        assert!(matches!(claim(&out), Err(Error::WouldOverwrite { .. })));
        assert!(!out.join(LOCK_FILE).exists(), "a refusal leaves no lock behind");
        record(&out).unwrap();
        claim(&out).unwrap();
        std::fs::write(dir.path().join("file"), b"").unwrap();
        assert!(matches!(claim(&dir.path().join("file")), Err(Error::WouldOverwrite { .. })));
    }

    #[test]
    fn a_claimed_folder_is_locked_until_its_command_is_done() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("model");
        let first = Outputs::new(false);
        first.claim_folder(&out).unwrap();
        first.claim_folder(&out).unwrap();
        assert!(out.join(LOCK_FILE).exists(), "held while the command runs");
        std::fs::write(out.join("a.png"), b"1").unwrap();
        drop(first);
        assert!(!out.join(LOCK_FILE).exists(), "and released when it is done");
    }

    #[test]
    fn stems_carry_enough_of_the_source_to_be_unique() {
        let paths: Vec<PathBuf> = [
            "/x/walk-7/frames/frame_000.png",
            "/x/walk-9/frames/frame_000.png",
            "/x/walk-9/frames/frame_001.png",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        assert_eq!(
            unique_stems(&paths),
            ["walk-7_frames_frame_000", "walk-9_frames_frame_000", "frame_001"]
        );
        let same = vec![PathBuf::from("/a.png"), PathBuf::from("/a.png")];
        assert_eq!(unique_stems(&same), ["a", "a_2"]);
    }
}
