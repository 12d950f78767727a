//! The appearance stage's data: each frame of the model's split, fitted, rendered crisply, beside
//! the frame as drawn. Fits are cached in `appearance/fits.json`, keyed by the fit options and
//! the model's weights, so a resumed or repeated training does not fit again.

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::path::Path;

use burn::tensor::Device;
use serde::{Deserialize, Serialize};

use super::stage::{read_json, StageFolder};
use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::fit::frame::frame_check;
use crate::fit::{fit, FitOptions};
use crate::model::bundle::max_weights_bytes;
use crate::model::{Model, ModelFolder};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::sequence::Frames;
use crate::render::render_crisp;
use crate::train::trainer::SplitRecord;
use crate::user_file;

/// Renders of fitted frames beside the frames.
pub struct Pairs {
    /// Each frame's file name.
    pub names: Vec<String>,
    /// The crisp render of each frame's fit (the generator's input).
    pub renders: Vec<Picture>,
    /// The frames as drawn (the generator's target).
    pub frames: Vec<Picture>,
}

/// The training and the held-out pairs of a model.
pub struct SplitPairs {
    /// The frames the deformation network trained on (the stage trains on these too).
    pub train: Pairs,
    /// The frames it held out.
    pub held_out: Pairs,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FitCache {
    key: String,
    fits: BTreeMap<String, Vec<[f32; 2]>>,
}

/// Fits (with `options`, or from the cache) and renders every frame of the split of the model in
/// `model_dir`.
///
/// # Errors
/// [`Error::Format`] naming `split.json` if the model has none or a frame it names is gone;
/// whatever reading a frame or fitting reports, naming the file.
pub fn split_pairs(model_dir: &Path, model: &Model, options: &FitOptions, device: &Device, progress: &dyn Progress) -> Result<SplitPairs> {
    let folder = ModelFolder::new(model_dir);
    let split = SplitRecord::load(model_dir)?.ok_or_else(|| {
        Error::format(
            folder.split(),
            "missing: the appearance stage trains on the frames the model was trained on",
        )
    })?;
    let frames = Frames::load(&split.frames, &frame_check(model))?;
    let names = frames.names();
    let pick = |wanted: &[String]| -> Result<Vec<usize>> {
        wanted
            .iter()
            .map(|w| {
                names.iter().position(|n| n == w).ok_or_else(|| {
                    Error::format(
                        folder.split(),
                        format!("names frame {w:?}, which is not in {}", split.frames.display()),
                    )
                })
            })
            .collect()
    };
    let (train, test) = (pick(&split.train)?, pick(&split.test)?);
    let stage = StageFolder::of_model(model_dir);
    let key = format!(
        "{options:?} weights {:016x}",
        digest(&user_file::read_bytes(&folder.weights(), max_weights_bytes(&model.net))?)
    );
    let mut cache = match stage.fits().is_file() {
        true => read_json::<FitCache>(&stage.fits()).ok().filter(|c| c.key == key),
        false => None,
    }
    .unwrap_or(FitCache {
        key,
        fits: BTreeMap::new(),
    });
    let all: Vec<usize> = train.iter().chain(&test).copied().collect();
    let missing: Vec<usize> = all.iter().copied().filter(|&i| !cache.fits.contains_key(&names[i])).collect();
    if !missing.is_empty() {
        progress.stage("fit", missing.len() as u64);
        let pictures: Vec<&Picture> = missing.iter().map(|&i| &frames.frames[i]).collect();
        for (&i, pose) in missing.iter().zip(fit(model, &pictures, options, device, progress)?) {
            cache.fits.insert(names[i].clone(), pose);
        }
        std::fs::create_dir_all(stage.dir()).map_err(|e| Error::io(stage.dir(), e))?;
        let json = serde_json::to_vec(&cache).map_err(|e| Error::format(stage.fits(), e.to_string()))?;
        write_atomic(&stage.fits(), &json)?;
    }
    let pairs = |indices: &[usize]| -> Result<Pairs> {
        let renders = indices
            .iter()
            .map(|&i| render_crisp(&model.puppet, &cache.fits[&names[i]], model.puppet.width, model.puppet.height))
            .collect::<Result<Vec<_>>>()?;
        Ok(Pairs {
            names: indices.iter().map(|&i| names[i].clone()).collect(),
            renders,
            frames: indices.iter().map(|&i| frames.frames[i].clone()).collect(),
        })
    };
    Ok(SplitPairs {
        train: pairs(&train)?,
        held_out: pairs(&test)?,
    })
}

/// A digest of bytes for cache keys (not cryptographic; a collision only reuses stale fits).
fn digest(bytes: &[u8]) -> u64 {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    bytes.hash(&mut hasher);
    hasher.finish()
}
