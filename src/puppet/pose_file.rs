//! `vertices.json`: one pose of a puppet — every vertex position in the global numbering
//! ([`super::Puppet::vertex_offsets`]), in reference-frame pixels. Written by `puppet fit`, read
//! by `puppet render --pose`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::Puppet;
use crate::error::{Error, Result};
use crate::user_file;

/// A pose on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// Vertex positions `[x, y]` in reference-frame pixels, global numbering.
    pub vertices: Vec<[f32; 2]>,
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
        if pose.vertices.len() != puppet.vertex_count() {
            return Err(Error::format(
                path,
                format!(
                    "{} vertices, but the puppet has {} (a pose of another puppet?)",
                    pose.vertices.len(),
                    puppet.vertex_count()
                ),
            ));
        }
        if let Some(i) = pose.vertices.iter().position(|v| !v[0].is_finite() || !v[1].is_finite()) {
            return Err(Error::format(path, format!("vertex {i} is not finite")));
        }
        Ok(pose)
    }

    /// The pose as JSON bytes.
    pub fn to_json(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a list of number pairs serialises")
    }
}
