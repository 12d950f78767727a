//! A trained model on disk and in memory (DESIGN.md "Formats": Burn record + the config it was
//! trained with + the puppet it was trained for). The folder's layout is [`ModelFolder`]'s. The
//! network works in the letterboxed S×S square; this type converts to and from frame pixels.

use std::path::Path;

use burn::module::Module;
use burn::store::ModuleRecord;
use burn::tensor::{Bytes, Device, Tensor, TensorData};

use super::decoder::{Decoder, Expansion};
use super::deformation::{DeformationNet, DeformationNetConfig};
use super::folder::ModelFolder;
use super::letterbox::Letterbox;
use crate::atomic_file::write_atomic;
use crate::error::{Context, Error, Result};
use crate::picture::Picture;
use crate::puppet::{format, LayerKind, Puppet};
use crate::user_file;

/// Frames the encoder takes per pass in [`Model::encode`]: bounds the input's and the
/// activations' memory however many frames a command encodes (a fit reads every training frame).
pub const ENCODE_BATCH: usize = 16;

/// A deformation network together with the puppet it deforms.
#[derive(Clone, Debug)]
pub struct Model {
    /// The encoder-decoder.
    pub net: DeformationNet,
    /// Its hyper-parameters.
    pub config: DeformationNetConfig,
    /// The template it predicts vertices of.
    pub puppet: Puppet,
    /// Frame ↔ working-square map.
    pub letterbox: Letterbox,
    /// The network's outputs → every vertex (the rig places accessories).
    pub expansion: Expansion,
}

impl Model {
    /// A fresh (untrained) model for `puppet` on `device`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if the config's vertex count is not the puppet's, [`Error::Setting`] for
    /// a size out of range ([`DeformationNetConfig::validate`]).
    pub fn new(config: DeformationNetConfig, puppet: Puppet, device: &Device) -> Result<Self> {
        check_config(&config, &puppet)?;
        let letterbox = Letterbox::new(puppet.width, puppet.height, config.input_size as u32);
        Ok(Model {
            net: config.init(device),
            config,
            expansion: Expansion::new(&puppet, &letterbox),
            puppet,
            letterbox,
        })
    }

    /// Loads a model folder onto `device`.
    ///
    /// # Errors
    /// [`Error::WrongFolder`] if `dir` is not a model folder; [`Error::Io`]/[`Error::Format`]
    /// naming the file that is missing or wrong, including weights that do not fit the config or
    /// the puppet; [`Error::Limit`] naming a file larger than its limit ([`user_file::CONFIG`]
    /// for the network config, [`max_weights_bytes`] for the weights).
    pub fn load(dir: &Path, device: &Device) -> Result<Self> {
        let folder = ModelFolder::open(dir)?;
        let net_path = folder.net();
        let config = read_net_config(&user_file::read_bytes(&net_path, user_file::CONFIG)?, &net_path)?;
        let puppet = format::load(&folder.puppet())?;
        let mut model = Model::new(config, puppet, device).at_path(&net_path)?;
        let weights_path = folder.weights();
        let bytes = user_file::read_bytes(&weights_path, max_weights_bytes(&model.net))?;
        model.net = load_weights(model.net, bytes, &weights_path)?;
        Ok(model)
    }

    /// This model drawing `puppet`: the same body in another outfit ([`crate::rig::outfit`]). The
    /// network and its outputs are unchanged; `puppet`'s rig places its accessories.
    ///
    /// # Errors
    /// [`Error::Setting`] if the model moves its accessories itself (it was trained without
    /// the rig); [`Error::Mismatch`] if `puppet`'s body is not the model's.
    pub fn wearing(&self, puppet: Puppet) -> Result<Model> {
        if self.puppet.rig.is_none() && self.puppet.layers.iter().any(|l| l.kind == LayerKind::Accessory) {
            return Err(Error::setting(
                "model.rig",
                false,
                "true: a model trained without the rig moves its accessories itself, so they cannot be changed",
            ));
        }
        let body = |p: &Puppet| {
            let rest = p.rest_vertices();
            p.free_vertices().into_iter().map(|g| rest[g]).collect::<Vec<_>>()
        };
        let (theirs, ours) = (body(&puppet), body(&self.puppet));
        if theirs != ours || (puppet.width, puppet.height) != (self.puppet.width, self.puppet.height) {
            return Err(Error::mismatch(
                "the outfit's body",
                format!("{} vertices on {}×{}", theirs.len(), puppet.width, puppet.height),
                format!(
                    "the model's ({} vertices on {}×{}, at the same rest places)",
                    ours.len(),
                    self.puppet.width,
                    self.puppet.height
                ),
            ));
        }
        Ok(Model {
            net: self.net.clone(),
            config: self.config.clone(),
            expansion: Expansion::new(&puppet, &self.letterbox),
            puppet,
            letterbox: self.letterbox,
        })
    }

    /// A pose of `other`'s puppet (a model of the same body, e.g. the one this was made from by
    /// [`Model::wearing`]) as a pose of this model's puppet: the body kept, the accessories placed
    /// by this puppet's rig. A pose of this very model is kept as it is: a fit may have moved its
    /// accessories off the rig's placement ([`crate::fit::accessory_moves`]).
    pub fn pose_from(&self, other: &Model, pose: &[[f32; 2]]) -> Vec<[f32; 2]> {
        if std::ptr::eq(self, other) {
            return pose.to_vec();
        }
        self.expansion.expand_frame(&other.expansion.free_of(pose))
    }

    /// Writes the network config, the puppet and the weights into the model folder `dir` (each
    /// file atomically).
    ///
    /// # Errors
    /// [`Error::Io`] naming the file that could not be written.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let folder = ModelFolder::new(dir);
        let net_path = folder.net();
        let json = serde_json::to_string_pretty(&self.config).map_err(|e| Error::format(&net_path, e.to_string()))?;
        write_atomic(&net_path, json.as_bytes())?;
        format::save(&self.puppet, &folder.puppet())?;
        let weights_path = folder.weights();
        write_atomic(&weights_path, &weights_bytes(&self.net, &weights_path)?)
    }

    /// The rest vertices in working pixels.
    pub fn rest_work_points(&self) -> Vec<[f32; 2]> {
        self.puppet.rest_vertices().into_iter().map(|p| self.letterbox.to_work(p)).collect()
    }

    /// The decoder's tensors (rest pose of the free vertices, the rig's map) on `device`.
    pub fn decoder(&self, device: &Device) -> Decoder {
        self.expansion.decoder(device)
    }

    /// The network input for `frames`, `[B, 4, S, S]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if a frame is not the puppet's size (callers that know the file wrap
    /// it with the path).
    pub fn input(&self, frames: &[&Picture], device: &Device) -> Result<Tensor<4>> {
        let s = self.letterbox.size as usize;
        let mut data = Vec::with_capacity(frames.len() * 4 * s * s);
        for frame in frames {
            self.check_frame(frame)?;
            data.extend(self.letterbox.premultiplied_planes(frame));
        }
        Ok(Tensor::from_data(TensorData::new(data, [frames.len(), 4, s, s]), device))
    }

    /// Checks a frame has the puppet's size.
    ///
    /// # Errors
    /// [`Error::Mismatch`] naming both sizes.
    pub fn check_frame(&self, frame: &Picture) -> Result<()> {
        if (frame.width, frame.height) != (self.puppet.width, self.puppet.height) {
            return Err(Error::mismatch(
                "the frame",
                format!("{}×{}", frame.width, frame.height),
                format!("{}×{} (the puppet's frames)", self.puppet.width, self.puppet.height),
            ));
        }
        Ok(())
    }

    /// Encodes frames to latents `[B, Z]`, [`ENCODE_BATCH`] frames per pass of the encoder (the
    /// network normalises nothing across a batch, so the latents do not depend on it).
    ///
    /// # Errors
    /// As [`Model::input`].
    pub fn encode(&self, frames: &[&Picture], device: &Device) -> Result<Tensor<2>> {
        if frames.len() <= ENCODE_BATCH {
            return Ok(self.net.encode(self.input(frames, device)?));
        }
        let parts = frames
            .chunks(ENCODE_BATCH)
            .map(|chunk| Ok(self.net.encode(self.input(chunk, device)?)))
            .collect::<Result<Vec<_>>>()?;
        Ok(Tensor::cat(parts, 0))
    }

    /// Decodes latents to every vertex's position in working pixels, `[B, V, 2]`.
    pub fn decode(&self, z: Tensor<2>, device: &Device) -> Tensor<3> {
        self.decoder(device).vertices(&self.net, z)
    }

    /// Working-pixel vertex tensor `[B, V, 2]` → per-item vertex lists in frame pixels.
    pub fn to_frame_vertices(&self, vertices: Tensor<3>) -> Vec<Vec<[f32; 2]>> {
        let [batch, v, _] = vertices.dims();
        let flat: Vec<f32> = vertices.into_data().convert::<f32>().try_into_vec::<f32>().unwrap_or_default();
        (0..batch)
            .map(|b| {
                (0..v)
                    .map(|i| self.letterbox.to_frame([flat[(b * v + i) * 2], flat[(b * v + i) * 2 + 1]]))
                    .collect()
            })
            .collect()
    }

    /// The free vertices ([`Puppet::free_vertices`]) of per-item poses of every vertex, frame
    /// pixels → the working-pixel tensor `[B, Vb, 2]` (what [`Decoder::expand`] takes).
    pub fn to_work_free(&self, poses: &[Vec<[f32; 2]>], device: &Device) -> Tensor<3> {
        let work: Vec<f32> = poses
            .iter()
            .flat_map(|pose| self.expansion.free_of(pose))
            .flat_map(|p| self.letterbox.to_work(p))
            .collect();
        Tensor::from_data(TensorData::new(work, [poses.len(), self.expansion.free_count(), 2]), device)
    }

    /// Fits frames: the predicted template vertices of each, in frame pixels.
    ///
    /// # Errors
    /// As [`Model::input`].
    pub fn fit(&self, frames: &[&Picture], device: &Device) -> Result<Vec<Vec<[f32; 2]>>> {
        let z = self.encode(frames, device)?;
        Ok(self.to_frame_vertices(self.decode(z, device)))
    }
}

/// A network config (`net.json`) read from `path`, its sizes checked before any network is built
/// from it ([`DeformationNetConfig::validate`]).
///
/// # Errors
/// [`Error::Format`] naming `path` if the bytes are not a config or a size is out of range.
pub fn read_net_config(bytes: &[u8], path: &Path) -> Result<DeformationNetConfig> {
    let config: DeformationNetConfig =
        serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("invalid network config: {e}")))?;
    config
        .validate()
        .map_err(|e| Error::format(path, format!("invalid network config: {e}")))?;
    Ok(config)
}

fn check_config(config: &DeformationNetConfig, puppet: &Puppet) -> Result<()> {
    config.validate()?;
    let free = puppet.free_vertices().len();
    if config.vertices != free {
        let whose = if puppet.rig.is_some() {
            "the puppet's body vertices"
        } else {
            "the puppet's"
        };
        return Err(Error::mismatch(
            "the network's vertex count",
            config.vertices,
            format!("{free}, {whose} (a model for a different puppet?)"),
        ));
    }
    Ok(())
}

/// A network's weights as burnpack bytes (for model folders and checkpoints).
///
/// # Errors
/// [`Error::Format`] naming `path` if Burn cannot serialise them.
pub fn weights_bytes<M: Module>(net: &M, path: &Path) -> Result<Vec<u8>> {
    let bytes = net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| Error::format(path, format!("cannot encode weights: {e:?}")))?;
    Ok(bytes.to_vec())
}

/// The most bytes a weights file of `net` may hold: 8 bytes a parameter (f64 storage, twice what
/// f32 weights take) plus 1 MiB for the record's names and shapes.
pub fn max_weights_bytes<M: Module>(net: &M) -> u64 {
    8 * net.num_params() as u64 + (1 << 20)
}

/// Loads burnpack `bytes` read from `path` into `net`.
///
/// # Errors
/// [`Error::Format`] naming `path` if the bytes are not a record of this network.
pub fn load_weights<M: Module>(net: M, bytes: Vec<u8>, path: &Path) -> Result<M> {
    let record =
        ModuleRecord::from_bytes(Bytes::from_bytes_vec(bytes)).map_err(|e| Error::format(path, format!("not a weights file: {e:?}")))?;
    net.try_load_record(record)
        .map_err(|e| Error::format(path, format!("weights do not fit this network: {e:?}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::render_crisp;
    use crate::test_util::tiny_model;

    #[test]
    fn many_frames_encode_in_passes_to_the_latents_of_one_pass_each() {
        let (model, device) = tiny_model();
        let frames: Vec<Picture> = (0..ENCODE_BATCH + 5)
            .map(|k| {
                let mut pose = model.puppet.rest_vertices();
                pose.iter_mut().for_each(|p| p[0] += k as f32 * 0.7 - 6.0);
                render_crisp(&model.puppet, &pose, 48, 40).unwrap()
            })
            .collect();
        let refs: Vec<&Picture> = frames.iter().collect();
        let all: Vec<f32> = model.encode(&refs, &device).unwrap().into_data().try_to_vec::<f32>().unwrap();
        let one_by_one: Vec<f32> = refs
            .iter()
            .flat_map(|f| model.encode(&[*f], &device).unwrap().into_data().try_to_vec::<f32>().unwrap())
            .collect();
        assert_eq!(all.len(), one_by_one.len());
        for (a, b) in all.iter().zip(&one_by_one) {
            assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0), "{a} vs {b}");
        }
    }
}
