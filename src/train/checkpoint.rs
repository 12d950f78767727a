//! Training checkpoints: the weights, the optimiser state and the step, written so that a run
//! killed at any moment leaves the previous checkpoint intact (issue 5: atomic checkpoints,
//! `--resume` loses at most `checkpoint_every` steps).
//!
//! Layout: `checkpoints/step-000100/{weights.bpk, optimizer.bpk, state.json}` (the appearance
//! stage stores its two networks and two optimisers under their own names) and
//! `checkpoints/latest` naming the newest complete one. A checkpoint folder is written under a
//! temporary name and renamed when complete; `latest` is then replaced atomically; older
//! folders are removed last.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::user_file;

/// The checkpoints folder inside a model folder.
pub const CHECKPOINT_DIR: &str = "checkpoints";
const LATEST: &str = "latest";
/// A checkpoint's weights.
pub const WEIGHTS: &str = "weights.bpk";
/// A checkpoint's optimiser state.
pub const OPTIMIZER: &str = "optimizer.bpk";
const STATE: &str = "state.json";
/// A config's key naming the run folder, never compared on resume: a moved run folder is the
/// same run.
pub const OUTPUT: &str = "output";

/// What a checkpoint records besides the tensors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointState {
    /// Optimiser steps done.
    pub step: u64,
    /// Seconds of training so far (for the log's clock after a resume).
    pub elapsed: f64,
    /// The training config as JSON, to refuse resuming a different run.
    pub config: serde_json::Value,
}

/// A checkpoint whose state is read; its tensors are read on demand ([`Checkpoint::file`]), when
/// the network they must fit, and so their size, is known.
#[derive(Debug)]
pub struct Checkpoint {
    /// Its state.
    pub state: CheckpointState,
    /// Its folder.
    pub dir: PathBuf,
}

impl Checkpoint {
    /// The bytes of the checkpoint's file `name` (e.g. [`WEIGHTS`]), at most `limit` of them.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file if unreadable, [`Error::Limit`] if it is larger.
    pub fn file(&self, name: &str, limit: u64) -> Result<Vec<u8>> {
        user_file::read_bytes(&self.dir.join(name), limit)
    }
}

/// The newest complete checkpoint's folder under `model_dir`, if any.
///
/// # Errors
/// [`Error::Io`]/[`Error::Format`] if `latest` exists but cannot be read or names nothing.
pub fn latest(model_dir: &Path) -> Result<Option<PathBuf>> {
    let pointer = model_dir.join(CHECKPOINT_DIR).join(LATEST);
    if !pointer.exists() {
        return Ok(None);
    }
    let name = user_file::read_text(&pointer, user_file::CONFIG)?;
    let dir = model_dir.join(CHECKPOINT_DIR).join(name.trim());
    if !dir.join(STATE).is_file() {
        return Err(Error::format(
            &pointer,
            format!("names checkpoint {:?}, which is missing", name.trim()),
        ));
    }
    Ok(Some(dir))
}

/// Writes a checkpoint for `state.step` holding `files` (name, bytes) and makes it the latest in
/// `dir`'s checkpoints folder, then removes older ones.
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn save(dir: &Path, state: &CheckpointState, files: &[(&str, &[u8])]) -> Result<PathBuf> {
    let root = dir.join(CHECKPOINT_DIR);
    let name = format!("step-{:06}", state.step);
    let partial = root.join(format!(".{name}.partial"));
    let done = root.join(&name);
    if partial.exists() {
        std::fs::remove_dir_all(&partial).map_err(|e| Error::io(&partial, e))?;
    }
    std::fs::create_dir_all(&partial).map_err(|e| Error::io(&partial, e))?;
    let json = serde_json::to_vec_pretty(state).map_err(|e| Error::format(partial.join(STATE), e.to_string()))?;
    for &(file, bytes) in files.iter().chain([(STATE, json.as_slice())].iter()) {
        std::fs::write(partial.join(file), bytes).map_err(|e| Error::io(partial.join(file), e))?;
    }
    if done.exists() {
        std::fs::remove_dir_all(&done).map_err(|e| Error::io(&done, e))?;
    }
    std::fs::rename(&partial, &done).map_err(|e| Error::io(&done, e))?;
    write_atomic(&root.join(LATEST), name.as_bytes())?;
    // Older checkpoints go only after `latest` points at the new one.
    let entries = std::fs::read_dir(&root).map_err(|e| Error::io(&root, e))?;
    for entry in entries.flatten() {
        let path = entry.path();
        let stale = entry.file_name().to_string_lossy().starts_with("step-") && path != done;
        if stale && path.is_dir() {
            std::fs::remove_dir_all(&path).map_err(|e| Error::io(&path, e))?;
        }
    }
    Ok(done)
}

/// Reads the state of the checkpoint folder `dir`.
///
/// # Errors
/// [`Error::Io`]/[`Error::Format`] naming the file that is missing or unreadable;
/// [`Error::Limit`] if `state.json` is larger than [`user_file::CONFIG`].
pub fn load(dir: &Path) -> Result<Checkpoint> {
    let state_path = dir.join(STATE);
    let state: CheckpointState = serde_json::from_slice(&user_file::read_bytes(&state_path, user_file::CONFIG)?)
        .map_err(|e| Error::format(&state_path, format!("invalid checkpoint state: {e}")))?;
    Ok(Checkpoint {
        state,
        dir: dir.to_path_buf(),
    })
}

/// Whether a run into `dir` whose newest checkpoint is `previous` may go on: a fresh run needs
/// no checkpoint, a resume needs one.
///
/// # Errors
/// [`Error::RunExists`] for a checkpoint when not resuming; [`Error::Resume`] for a resume
/// without one.
pub fn check_run(dir: &Path, previous: Option<&Checkpoint>, resume: bool) -> Result<()> {
    match (previous, resume) {
        (Some(c), false) => Err(Error::RunExists {
            path: dir.to_path_buf(),
            step: c.state.step,
        }),
        (None, true) => Err(Error::Resume {
            path: dir.to_path_buf(),
            problem: "there is no checkpoint to resume from".into(),
        }),
        _ => Ok(()),
    }
}

/// Checks that a resumed run's `config` (as JSON) is its checkpoint's, but for the keys in
/// `may_change` and [`OUTPUT`].
///
/// # Errors
/// [`Error::Resume`] naming the keys that differ.
pub fn check_same_config(dir: &Path, checkpoint: &Checkpoint, config: &serde_json::Value, may_change: &[&str]) -> Result<()> {
    let ignored: Vec<&str> = may_change.iter().copied().chain([OUTPUT]).collect();
    let changed = changed_keys(&checkpoint.state.config, config, &ignored);
    if changed.is_empty() {
        return Ok(());
    }
    Err(Error::Resume {
        path: dir.to_path_buf(),
        problem: format!(
            "the config differs from the checkpoint's in {} (only {} may change)",
            changed.join(", "),
            may_change.join(", ")
        ),
    })
}

/// The dotted keys whose values differ between two configs (a null value counts as absent, so an
/// option added after a checkpoint was written and left unset still matches it), but those
/// `ignored` (for training: `output`, as a moved run folder is the same run, and `train.steps`,
/// as a resume may extend the run).
pub fn changed_keys(a: &serde_json::Value, b: &serde_json::Value, ignored: &[&str]) -> Vec<String> {
    fn walk(prefix: &str, a: Option<&serde_json::Value>, b: Option<&serde_json::Value>, ignored: &[&str], out: &mut Vec<String>) {
        if let (Some(serde_json::Value::Object(x)), Some(serde_json::Value::Object(y))) = (a, b) {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                walk(&key, x.get(k), y.get(k), ignored, out);
            }
        } else if a.filter(|v| !v.is_null()) != b.filter(|v| !v.is_null()) && !ignored.contains(&prefix) {
            out.push(prefix.to_string());
        }
    }
    let mut out = Vec::new();
    walk("", Some(a), Some(b), ignored, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn save_replaces_the_previous_checkpoint_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        assert!(latest(dir.path()).unwrap().is_none());
        let state = |step| CheckpointState {
            step,
            elapsed: 1.5,
            config: serde_json::json!({"seed": 3}),
        };
        save(dir.path(), &state(10), &[(WEIGHTS, b"w10"), (OPTIMIZER, b"o10")]).unwrap();
        let second = save(dir.path(), &state(20), &[(WEIGHTS, b"w20"), (OPTIMIZER, b"o20")]).unwrap();
        assert_eq!(latest(dir.path()).unwrap(), Some(second.clone()));
        let c = load(&second).unwrap();
        assert_eq!(
            (c.file(WEIGHTS, 3).unwrap(), c.file(OPTIMIZER, 3).unwrap()),
            (b"w20".to_vec(), b"o20".to_vec())
        );
        assert!(matches!(c.file(WEIGHTS, 2).unwrap_err().innermost(), Error::Limit { .. }));
        assert_eq!(c.state, state(20));
        let names: Vec<_> = std::fs::read_dir(dir.path().join(CHECKPOINT_DIR))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "latest + step-000020 only: {names:?}");
    }

    #[test]
    fn a_dangling_latest_pointer_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join(CHECKPOINT_DIR)).unwrap();
        std::fs::write(dir.path().join(CHECKPOINT_DIR).join(LATEST), "step-000005").unwrap();
        let err = latest(dir.path()).unwrap_err().to_string();
        assert!(err.contains("latest") && err.contains("step-000005"), "{err}");
    }

    #[test]
    fn changed_keys_ignore_the_output_and_the_step_count() {
        let a = serde_json::json!({"output": "/a", "seed": 1, "train": {"steps": 10, "batch": 4}, "loss": {"arap": 1.0}});
        let b = serde_json::json!({"output": "/b", "seed": 1, "train": {"steps": 20, "batch": 8}, "loss": {"arap": 2.0}});
        let ignored = ["output", "train.steps"];
        assert_eq!(changed_keys(&a, &b, &ignored), ["loss.arap", "train.batch"]);
        assert!(changed_keys(&a, &a, &ignored).is_empty());
        // A key added later with no value (an unset option) reads as absent, so older
        // checkpoints still resume.
        let c = serde_json::json!({"output": "/a", "seed": 1, "train": {"steps": 10, "batch": 4, "end": null}, "loss": {"arap": 1.0}});
        assert!(changed_keys(&a, &c, &ignored).is_empty());
        assert_eq!(
            changed_keys(&c, &serde_json::json!({"train": {"end": 1.0}}), &[]),
            ["loss", "output", "seed", "train.batch", "train.end", "train.steps"]
        );
    }
}
