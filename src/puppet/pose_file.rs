//! `vertices.json`: one pose of a puppet — every vertex position in the global numbering
//! ([`super::Puppet::vertex_offsets`]), in reference-frame pixels. Written by `puppet fit`,
//! `inbetween` and `pose`, read by `puppet render --pose` and `puppet export`; a folder of them,
//! in natural order of names, is an animation ([`load_poses`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::Puppet;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::user_file;

/// A pose on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// Vertex positions `[x, y]` in reference-frame pixels, global numbering.
    pub vertices: Vec<[f32; 2]>,
}

/// The most pose files [`load_poses`] reads from one folder (an hour at 24 frames a second).
pub const MAX_POSES: usize = 86_400;

/// The poses at `path`: one pose file, or every pose file in a folder in natural order of names
/// (`step_2` before `step_10`). In a folder, JSON files of other kinds — a JSON object without a
/// `vertices` key, such as the sprite atlas `fit` writes beside its poses — are passed over and
/// reported as `warn`ings; hidden files are not read.
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Format`] naming the file for a pose file that is not a
/// pose of `puppet` or a file that is not JSON, or for a folder without pose files;
/// [`Error::Limit`] past [`MAX_POSES`].
pub fn load_poses(path: &Path, puppet: &Puppet, progress: &dyn Progress) -> Result<Vec<Vec<[f32; 2]>>> {
    if !path.is_dir() {
        return Ok(vec![PoseFile::load(path, puppet)?.vertices]);
    }
    let mut names = Vec::new();
    for entry in std::fs::read_dir(path).map_err(|e| Error::io(path, e))? {
        let name = entry.map_err(|e| Error::io(path, e))?.file_name().to_string_lossy().into_owned();
        if name.ends_with(".json") && !name.starts_with('.') {
            names.push(name);
            if names.len() > MAX_POSES {
                return Err(Error::limit("pose files in a folder", names.len() as u64, MAX_POSES as u64, "files").with_path(path));
            }
        }
    }
    names.sort_by(|a, b| super::sequence::natural_cmp(a, b));
    let mut poses = Vec::new();
    for name in &names {
        let file = path.join(name);
        let bytes = user_file::read_bytes(&file, user_file::DATA)?;
        let value: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| Error::format(&file, format!("not JSON: {e}")))?;
        if value.get("vertices").is_none() {
            progress.warn(&format!("{}: not a pose file (no \"vertices\"), passed over", file.display()));
            continue;
        }
        let pose: PoseFile = serde_json::from_value(value).map_err(|e| Error::format(&file, format!("not a pose file: {e}")))?;
        poses.push(pose.checked(&file, puppet)?.vertices);
    }
    if poses.is_empty() {
        return Err(Error::format(path, "no pose files (*.json with \"vertices\") in this folder"));
    }
    Ok(poses)
}

impl PoseFile {
    /// Reads a pose and checks it fits `puppet` (vertex count, finite coordinates).
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable, [`Error::Limit`] if larger than [`user_file::DATA`],
    /// [`Error::Format`] for bad JSON or a pose of another puppet.
    pub fn load(path: &Path, puppet: &Puppet) -> Result<Self> {
        let bytes = user_file::read_bytes(path, user_file::DATA)?;
        Self::parse(&bytes, path, puppet)
    }

    /// Parses the bytes of the pose file `path` and checks them against `puppet`.
    ///
    /// # Errors
    /// As [`PoseFile::load`].
    pub fn parse(bytes: &[u8], path: &Path, puppet: &Puppet) -> Result<Self> {
        let pose: PoseFile = serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("not a pose file: {e}")))?;
        pose.checked(path, puppet)
    }

    /// The pose, if it fits `puppet` (vertex count, finite coordinates).
    fn checked(self, path: &Path, puppet: &Puppet) -> Result<Self> {
        if self.vertices.len() != puppet.vertex_count() {
            return Err(Error::format(
                path,
                format!(
                    "{} vertices, but the puppet has {} (a pose of another puppet?)",
                    self.vertices.len(),
                    puppet.vertex_count()
                ),
            ));
        }
        if let Some(i) = self.vertices.iter().position(|v| !v[0].is_finite() || !v[1].is_finite()) {
            return Err(Error::format(path, format!("vertex {i} is not finite")));
        }
        Ok(self)
    }

    /// The pose as JSON bytes.
    pub fn to_json(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a list of number pairs serialises")
    }
}
