//! A file written while frames arrive — through a temporary sibling, renamed into place only
//! when finished, so an interrupted animation never leaves a truncated file under its name.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};

/// The temporary sibling a streamed file is written to; removed unless [`TempFile::commit`]ed.
pub(super) struct TempFile {
    sink: FileSink,
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl TempFile {
    /// Creates the temporary sibling of `path` (and `path`'s folder if missing).
    pub(super) fn create(path: &Path) -> Result<Self> {
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
        let name = path
            .file_name()
            .map_or_else(|| "animation".into(), |n| n.to_string_lossy().into_owned());
        let tmp = parent.join(format!(".{name}.tmp{}", std::process::id()));
        let file = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        Ok(TempFile {
            sink: FileSink {
                file: Arc::new(file),
                failure: Arc::new(Mutex::new(None)),
            },
            tmp,
            path: path.to_path_buf(),
            committed: false,
        })
    }

    /// The file's final name.
    pub(super) fn path(&self) -> &Path {
        &self.path
    }

    /// A writer into the temporary file; encoders that finish on drop (and so cannot report a
    /// failed write) write through it, and [`TempFile::commit`] reports the failure instead.
    pub(super) fn sink(&self) -> FileSink {
        self.sink.clone()
    }

    /// Syncs the temporary file and renames it to its final name, once every encoder writing to
    /// it has finished.
    ///
    /// # Errors
    /// [`Error::Io`] for the first write that failed, or a failed sync or rename.
    pub(super) fn commit(mut self) -> Result<PathBuf> {
        let failure = self.sink.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        if let Some(e) = failure {
            return Err(Error::io(&self.tmp, e));
        }
        self.sink.file.sync_all().map_err(|e| Error::io(&self.tmp, e))?;
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        self.committed = true;
        Ok(self.path.clone())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// A writer into a [`TempFile`] which remembers the first write that failed.
#[derive(Clone)]
pub(super) struct FileSink {
    file: Arc<std::fs::File>,
    failure: Arc<Mutex<Option<std::io::Error>>>,
}

impl std::io::Write for FileSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        (&*self.file).write(buf).inspect_err(|e| self.remember(e))
    }

    fn flush(&mut self) -> std::io::Result<()> {
        (&*self.file).flush().inspect_err(|e| self.remember(e))
    }
}

impl FileSink {
    fn remember(&self, e: &std::io::Error) {
        let mut failure = self.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if failure.is_none() {
            *failure = Some(std::io::Error::new(e.kind(), e.to_string()));
        }
    }
}
