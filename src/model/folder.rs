//! The layout of a model folder (DESIGN.md "Formats"), named once: every reader and writer of a
//! model folder takes its file names from here.
//!
//! ```text
//! net.json        the network's config (DeformationNetConfig)
//! weights.bpk     the network's weights (Burn burnpack record; the newest during training)
//! puppet/         the puppet it deforms (puppet.json + textures)
//! train.toml      the training config it was trained with
//! split.json      the frames it trained on and those it held out
//! log.csv         per-step losses; loss.png draws them
//! checkpoints/    the newest training checkpoint (weights, optimiser state, step)
//! ```

use std::path::{Path, PathBuf};

use crate::error::{Error, FolderKind, Result};

/// A model folder's paths.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelFolder {
    dir: PathBuf,
}

impl ModelFolder {
    /// The network config's file name.
    pub const NET: &'static str = "net.json";
    /// The weights' file name.
    pub const WEIGHTS: &'static str = "weights.bpk";
    /// The puppet's subfolder.
    pub const PUPPET: &'static str = "puppet";
    /// The training config's file name.
    pub const CONFIG: &'static str = "train.toml";
    /// The split record's file name.
    pub const SPLIT: &'static str = "split.json";
    /// The training log's file name.
    pub const LOG: &'static str = "log.csv";
    /// The loss plot's file name.
    pub const PLOT: &'static str = "loss.png";
    /// The sheet of poses the template draws itself for training (`[train.sampled]`).
    pub const SAMPLED: &'static str = "sampled.png";
    /// The sheet of the training frames beside the prior's fits of them (`[train.guide]`).
    pub const GUIDE: &'static str = "guide.png";
    /// The checkpoints' subfolder.
    pub const CHECKPOINTS: &'static str = "checkpoints";

    /// The paths of a model folder at `dir` (which need not exist yet).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        ModelFolder { dir: dir.into() }
    }

    /// The model folder at `dir`, checked to hold a network, its weights and its puppet.
    ///
    /// # Errors
    /// [`Error::WrongFolder`] saying what is missing (and, for a puppet folder, what it is).
    pub fn open(dir: &Path) -> Result<Self> {
        let folder = ModelFolder::new(dir);
        let problem = if !dir.is_dir() {
            Some(if dir.exists() { "not a folder" } else { "no such folder" }.to_string())
        } else if dir.join(crate::puppet::format::PUPPET_FILE).is_file() {
            Some("this is a puppet folder, not a trained model".to_string())
        } else {
            [Self::NET, Self::WEIGHTS]
                .iter()
                .find(|f| !dir.join(f).is_file())
                .map(|f| format!("no {f}"))
                .or_else(|| (!folder.puppet().is_dir()).then(|| format!("no {}/", Self::PUPPET)))
        };
        match problem {
            Some(problem) => Err(Error::WrongFolder {
                path: dir.to_path_buf(),
                expected: FolderKind::Model,
                problem,
            }),
            None => Ok(folder),
        }
    }

    /// The folder itself.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// `net.json`.
    pub fn net(&self) -> PathBuf {
        self.dir.join(Self::NET)
    }

    /// `weights.bpk`.
    pub fn weights(&self) -> PathBuf {
        self.dir.join(Self::WEIGHTS)
    }

    /// `puppet/`.
    pub fn puppet(&self) -> PathBuf {
        self.dir.join(Self::PUPPET)
    }

    /// `train.toml`.
    pub fn config(&self) -> PathBuf {
        self.dir.join(Self::CONFIG)
    }

    /// `split.json`.
    pub fn split(&self) -> PathBuf {
        self.dir.join(Self::SPLIT)
    }

    /// `log.csv`.
    pub fn log(&self) -> PathBuf {
        self.dir.join(Self::LOG)
    }

    /// `loss.png`.
    pub fn plot(&self) -> PathBuf {
        self.dir.join(Self::PLOT)
    }

    /// `sampled.png`.
    pub fn sampled(&self) -> PathBuf {
        self.dir.join(Self::SAMPLED)
    }

    /// `guide.png`.
    pub fn guide(&self) -> PathBuf {
        self.dir.join(Self::GUIDE)
    }

    /// `checkpoints/`.
    pub fn checkpoints(&self) -> PathBuf {
        self.dir.join(Self::CHECKPOINTS)
    }

    /// Every file and folder training writes here (for checks before anything is written).
    pub fn training_outputs(&self) -> Vec<PathBuf> {
        [
            Self::NET,
            Self::WEIGHTS,
            Self::PUPPET,
            Self::CONFIG,
            Self::SPLIT,
            Self::LOG,
            Self::PLOT,
            Self::CHECKPOINTS,
        ]
        .iter()
        .map(|f| self.dir.join(f))
        .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_that_is_not_a_model_says_what_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        let missing = |d: &Path| match ModelFolder::open(d).unwrap_err() {
            Error::WrongFolder { expected, problem, .. } => {
                assert_eq!(expected, FolderKind::Model);
                problem
            }
            other => panic!("{other}"),
        };
        assert_eq!(missing(&dir.path().join("nowhere")), "no such folder");
        assert_eq!(missing(dir.path()), "no net.json");
        std::fs::write(dir.path().join("puppet.json"), "{}").unwrap();
        assert!(missing(dir.path()).contains("puppet folder"));
        std::fs::remove_file(dir.path().join("puppet.json")).unwrap();
        for f in [ModelFolder::NET, ModelFolder::WEIGHTS] {
            std::fs::write(dir.path().join(f), "").unwrap();
        }
        assert_eq!(missing(dir.path()), "no puppet/");
        std::fs::create_dir(dir.path().join(ModelFolder::PUPPET)).unwrap();
        assert!(ModelFolder::open(dir.path()).is_ok());
    }
}
