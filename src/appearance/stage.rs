//! A trained appearance stage on disk and in memory: `appearance/` inside the model folder it
//! was trained for, and the generator that redraws that model's renders.
//!
//! ```text
//! appearance/net.json        the networks' config (AppearanceNetConfig)
//! appearance/generator.bpk   G's weights (the newest during training)
//! appearance/critic.bpk      D's weights
//! appearance/stage.json      what it was trained for (the puppet) and on (the fitted frames)
//! appearance/train.toml      its training config
//! appearance/fits.json       the training and held-out frames' fits (a cache)
//! appearance/log.csv, loss.png, sheet.png, checkpoints/
//! ```

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use crate::atomic_file::write_atomic;
use crate::error::{Error, FolderKind, Result};
use crate::model::appearance::{AppearanceNetConfig, Generator};
use crate::model::bundle::{load_weights, max_weights_bytes};
use crate::model::{Letterbox, Model};
use crate::picture::Picture;
use crate::puppet::Puppet;
use crate::render::render_crisp;
use crate::user_file;

/// The paths of a model folder's appearance stage.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StageFolder {
    dir: PathBuf,
}

impl StageFolder {
    /// The stage's subfolder of a model folder.
    pub const DIR: &'static str = "appearance";

    /// The stage of the model folder `model_dir` (which need not exist yet).
    pub fn of_model(model_dir: &Path) -> Self {
        StageFolder {
            dir: model_dir.join(Self::DIR),
        }
    }

    /// The stage's folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// A file of the stage.
    pub fn file(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// `net.json`.
    pub fn net(&self) -> PathBuf {
        self.file("net.json")
    }

    /// `generator.bpk`.
    pub fn generator(&self) -> PathBuf {
        self.file("generator.bpk")
    }

    /// `critic.bpk`.
    pub fn critic(&self) -> PathBuf {
        self.file("critic.bpk")
    }

    /// `stage.json`.
    pub fn record(&self) -> PathBuf {
        self.file("stage.json")
    }

    /// `train.toml`.
    pub fn config(&self) -> PathBuf {
        self.file("train.toml")
    }

    /// `fits.json`.
    pub fn fits(&self) -> PathBuf {
        self.file("fits.json")
    }

    /// `log.csv`.
    pub fn log(&self) -> PathBuf {
        self.file("log.csv")
    }

    /// `loss.png`.
    pub fn plot(&self) -> PathBuf {
        self.file("loss.png")
    }

    /// `sheet.png`: render, generated and drawn side by side.
    pub fn sheet(&self) -> PathBuf {
        self.file("sheet.png")
    }
}

/// What a stage was trained for: enough of the puppet to refuse a stage copied into the folder
/// of another model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageRecord {
    /// The puppet's frame size.
    pub frame_size: [u32; 2],
    /// The model's working size S.
    pub input_size: usize,
    /// The puppet's layer names, back to front.
    pub layers: Vec<String>,
    /// The puppet's vertex count.
    pub vertices: usize,
}

impl StageRecord {
    /// The record of a stage for `model`.
    pub fn of(model: &Model) -> Self {
        StageRecord {
            frame_size: [model.puppet.width, model.puppet.height],
            input_size: model.letterbox.size as usize,
            layers: model.puppet.layers.iter().map(|l| l.name.clone()).collect(),
            vertices: model.puppet.vertex_count(),
        }
    }

    /// Writes it as `stage.json`.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn save(&self, folder: &StageFolder) -> Result<()> {
        let json = serde_json::to_vec_pretty(self).map_err(|e| Error::format(folder.record(), e.to_string()))?;
        write_atomic(&folder.record(), &json)
    }
}

/// A trained generator ready to redraw renders of its model.
#[derive(Clone, Debug)]
pub struct AppearanceStage {
    /// The networks' config.
    pub config: AppearanceNetConfig,
    /// G, on the inference device.
    pub generator: Generator,
    letterbox: Letterbox,
}

impl AppearanceStage {
    /// Loads the stage of the model in `model_dir` (`model` is that model, loaded).
    ///
    /// # Errors
    /// [`Error::WrongFolder`] if the model has no trained stage (naming what is missing) or the
    /// stage was trained for another puppet; [`Error::Io`]/[`Error::Format`]/[`Error::Limit`]
    /// naming a file that cannot be read, does not parse or does not fit.
    pub fn load(model_dir: &Path, model: &Model, device: &Device) -> Result<Self> {
        let folder = StageFolder::of_model(model_dir);
        let wrong = |problem: String| Error::WrongFolder {
            path: folder.dir().to_path_buf(),
            expected: FolderKind::Appearance,
            problem,
        };
        if !folder.dir().is_dir() {
            return Err(wrong("the model has no appearance stage; train one first".into()));
        }
        for file in [folder.net(), folder.generator(), folder.record()] {
            if !file.is_file() {
                let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                return Err(wrong(format!("no {name} (its training has not written the generator yet)")));
            }
        }
        let record: StageRecord = read_json(&folder.record())?;
        let expected = StageRecord::of(model);
        if record != expected {
            return Err(wrong(format!(
                "trained for another puppet ({} layers, {} vertices, {}×{} frames; this model's: {} layers, {} vertices, {}×{})",
                record.layers.len(),
                record.vertices,
                record.frame_size[0],
                record.frame_size[1],
                expected.layers.len(),
                expected.vertices,
                expected.frame_size[0],
                expected.frame_size[1]
            )));
        }
        let config: AppearanceNetConfig = read_json(&folder.net())?;
        check_net(&config, expected.input_size).map_err(|problem| Error::format(folder.net(), problem))?;
        let empty = config.init_generator(device);
        let bytes = user_file::read_bytes(&folder.generator(), max_weights_bytes(&empty))?;
        let generator = load_weights(empty, bytes, &folder.generator())?;
        Ok(AppearanceStage {
            config,
            generator,
            letterbox: model.letterbox,
        })
    }

    /// A stage from networks in memory (for training and tests).
    pub fn new(config: AppearanceNetConfig, generator: Generator, letterbox: Letterbox) -> Self {
        AppearanceStage {
            config,
            generator,
            letterbox,
        }
    }

    /// Redraws renders (straight-alpha pictures at the frame size) as the generator draws them.
    pub fn redraw(&self, renders: &[&Picture], device: &Device) -> Vec<Picture> {
        if renders.is_empty() {
            return Vec::new();
        }
        let s = self.letterbox.size as usize;
        let mut out = Vec::with_capacity(renders.len());
        // Batches bound the activations' memory.
        for chunk in renders.chunks(16) {
            let planes: Vec<f32> = chunk.iter().flat_map(|r| self.letterbox.premultiplied_planes(r)).collect();
            let x = Tensor::<4>::from_data(TensorData::new(planes, [chunk.len(), 4, s, s]), device);
            let y: Vec<f32> = self
                .generator
                .clone()
                .valid()
                .forward(x)
                .into_data()
                .convert::<f32>()
                .try_into_vec::<f32>()
                .unwrap_or_default();
            out.extend(y.chunks_exact(4 * s * s).map(|p| self.letterbox.frame_picture(p)));
        }
        out
    }

    /// Renders `poses` (frame pixels) of `puppet` crisply and redraws them: (render, generated)
    /// for each.
    ///
    /// # Errors
    /// As [`render_crisp`].
    pub fn render_and_redraw(&self, puppet: &Puppet, poses: &[Vec<[f32; 2]>], device: &Device) -> Result<Vec<(Picture, Picture)>> {
        let renders = poses
            .iter()
            .map(|p| render_crisp(puppet, p, puppet.width, puppet.height))
            .collect::<Result<Vec<_>>>()?;
        let generated = self.redraw(&renders.iter().collect::<Vec<_>>(), device);
        Ok(renders.into_iter().zip(generated).collect())
    }
}

/// The widest networks a stage may ask for (pix2pix's full size is 64 / 512): a hostile
/// `net.json` must not make the loader allocate without bound.
const MAX_CHANNELS: usize = 2048;

/// What is wrong with a stored network config for a model of working size `input_size`, if
/// anything.
fn check_net(config: &AppearanceNetConfig, input_size: usize) -> std::result::Result<(), String> {
    if config.input_size != input_size || config.depth() == 0 {
        return Err(format!("input_size {} does not fit the model's {input_size}", config.input_size));
    }
    if config.base_channels == 0 || config.max_channels < config.base_channels || config.max_channels > MAX_CHANNELS {
        return Err(format!(
            "channels {} to {} (expected 1 ≤ base ≤ max ≤ {MAX_CHANNELS})",
            config.base_channels, config.max_channels
        ));
    }
    if !(0.0..1.0).contains(&config.dropout) {
        return Err(format!("dropout {} (expected 0 ≤ p < 1)", config.dropout));
    }
    Ok(())
}

/// Reads a JSON file of the stage.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let bytes = user_file::read_bytes(path, user_file::DATA)?;
    serde_json::from_slice(&bytes).map_err(|e| Error::format(path, e.to_string()))
}
