//! Fit refinement: after the encoder's one-pass fit, a few Adam steps on each frame's latent z
//! that lower the training objective (eq. 4: L_rec + λ1·ARAP + λ2·joints) for that frame alone —
//! analysis by synthesis through the decoder and the soft rasterizer, the same machinery §4.2
//! uses for dragged poses. The network's weights do not change; the result stays on the decoder's
//! manifold. `--refine N` on `puppet fit`, `eval`, `inbetween`, `pose` and `correspond`, and the
//! demo, use it.

use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};

use super::config::LossWeights;
use super::loss::Objective;
use super::trainer::{rest_coverage, CONFIG_FILE};
use crate::error::{Error, Result};
use crate::model::deformation::rest_tensor;
use crate::model::Model;
use crate::picture::Picture;
use crate::render::burn_op::soft_raster;
use crate::render::soft_raster::{Background, Params, SoftRasterizer};

/// Refinement steps unless asked otherwise: on the synthetic walker (README) 50 steps take the
/// held-out L2 from 4947 to 3340 and 100 to 3253, against a floor of 3213.
pub const DEFAULT_STEPS: usize = 50;

/// How to refine fits.
#[derive(Clone, Debug, PartialEq)]
pub struct RefineOptions {
    /// Adam steps on the latents (0 = the encoder's fit unchanged).
    pub steps: usize,
    /// Adam's step size in latent units.
    pub learning_rate: f32,
    /// Soft-rasterizer σ (px² of the working square); the end of a training schedule suits.
    pub sigma: f32,
    /// The objective's weights (the paper's by default; frames over a background want `masked`).
    pub weights: LossWeights,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            steps: DEFAULT_STEPS,
            learning_rate: 0.02,
            sigma: 0.5,
            weights: LossWeights::default(),
        }
    }
}

impl RefineOptions {
    /// `steps` refinement steps with the loss weights and the final σ the model in `dir` was
    /// trained with (its `train.toml`; a model trained on frames over a background must refine
    /// with the masked loss too), or the defaults if the folder has no `train.toml`.
    ///
    /// # Errors
    /// [`Error::Format`] naming `train.toml` if it cannot be read or its `[loss]` or
    /// `train.sigma` do not parse.
    pub fn for_model(dir: &Path, steps: usize) -> Result<Self> {
        let path = dir.join(CONFIG_FILE);
        let mut options = RefineOptions {
            steps,
            ..RefineOptions::default()
        };
        if !path.is_file() {
            return Ok(options);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| Error::format(&path, e.to_string()))?;
        let config: toml::Value = toml::from_str(&text).map_err(|e| Error::format(&path, e.to_string()))?;
        if let Some(loss) = config.get("loss") {
            options.weights = loss.clone().try_into().map_err(|e| Error::format(&path, format!("[loss]: {e}")))?;
        }
        if let Some(sigma) = config.get("train").and_then(|t| t.get("sigma")) {
            let [_, end]: [f32; 2] = sigma
                .clone()
                .try_into()
                .map_err(|e| Error::format(&path, format!("train.sigma: {e}")))?;
            options.sigma = end;
        }
        Ok(options)
    }

    /// No refinement: the encoder's one-pass fit, as the paper evaluates it.
    pub fn encoder_only() -> Self {
        RefineOptions {
            steps: 0,
            ..RefineOptions::default()
        }
    }
}

/// Fits `frames` (the puppet's size): encoder, then `options.steps` Adam steps per latent.
/// Returns the template vertices of each frame in frame pixels.
///
/// # Errors
/// As [`fit_latents`].
pub fn refined_fit(model: &Model, frames: &[&Picture], options: &RefineOptions, device: &Device) -> Result<Vec<Vec<[f32; 2]>>> {
    let z = fit_latents(model, frames, options, device)?;
    Ok(model.to_frame_vertices(model.decode(z, device)))
}

/// The latents `[B, Z]` of `frames`: the encoder's, then `options.steps` Adam steps each.
///
/// # Errors
/// As [`Model::input`]; [`Error::Invalid`] for a non-positive σ or step size.
pub fn fit_latents(model: &Model, frames: &[&Picture], options: &RefineOptions, device: &Device) -> Result<Tensor<2>> {
    if !(options.sigma > 0.0 && options.learning_rate > 0.0) {
        return Err(Error::Invalid(format!(
            "refine: σ {} and step size {} must be positive",
            options.sigma, options.learning_rate
        )));
    }
    let images = model.input(frames, device)?;
    let z0 = model.net.encode(images.clone());
    if options.steps == 0 || frames.is_empty() {
        return Ok(z0);
    }
    let size = model.letterbox.size as usize;
    let raster = std::sync::Arc::new(SoftRasterizer::new(&model.puppet)?);
    let rest_points = model.rest_work_points();
    let rest_area = rest_coverage(&raster, &rest_points, size)?;
    let objective = Objective::new(&model.puppet, &rest_points, size, rest_area, options.weights.clone())?;
    let rest = rest_tensor(&rest_points, device);
    let params = Params {
        sigma: options.sigma,
        background: Background::Transparent,
        ..Params::default()
    };
    let shape = z0.dims();
    let mut z = to_vec(z0);
    let mut adam = LatentAdam::new(z.len());
    for _ in 0..options.steps {
        let zt = Tensor::<2>::from_data(TensorData::new(z.clone(), shape), device)
            .autodiff()
            .require_grad();
        let vertices = model.net.vertices(zt.clone(), &rest);
        let rendered = soft_raster(vertices.clone(), &raster, size, size, params)?;
        // The objective is a batch mean, so each frame's latent sees only its own frame's terms
        // (scaled by 1/B, which Adam's normalisation removes).
        let total = objective.evaluate(vertices, &rendered, images.clone(), device)?.total;
        let grads = total.backward();
        let g = zt
            .grad(&grads)
            .ok_or_else(|| Error::Invalid("refine: no gradient reached the latent".into()))?;
        adam.step(&mut z, &to_vec(g), options.learning_rate);
    }
    Ok(Tensor::<2>::from_data(TensorData::new(z, shape), device))
}

fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().convert::<f32>().try_into_vec::<f32>().unwrap_or_default()
}

/// Adam (PyTorch's defaults, ε = 1e-8) over a flat vector of latents.
struct LatentAdam {
    m: Vec<f32>,
    v: Vec<f32>,
    t: i32,
}

impl LatentAdam {
    fn new(n: usize) -> Self {
        LatentAdam {
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
        }
    }

    fn step(&mut self, x: &mut [f32], g: &[f32], lr: f32) {
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        self.t += 1;
        let (c1, c2) = (1.0 - B1.powi(self.t), 1.0 - B2.powi(self.t));
        for (((x, m), v), &g) in x.iter_mut().zip(&mut self.m).zip(&mut self.v).zip(g) {
            *m = B1 * *m + (1.0 - B1) * g;
            *v = B2 * *v + (1.0 - B2) * g * g;
            *x -= lr * (*m / c1) / ((*v / c2).sqrt() + 1e-8);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_follow_the_models_training_objective_and_name_a_bad_config() {
        let dir = tempfile::tempdir().unwrap();
        let defaults = RefineOptions::for_model(dir.path(), 7).unwrap();
        assert_eq!(
            defaults,
            RefineOptions {
                steps: 7,
                ..RefineOptions::default()
            }
        );
        let config = "puppet = \"p\"\n[train]\nsigma = [2.0, 0.25]\n[loss]\narap = 10.0\nmasked = true\n";
        std::fs::write(dir.path().join(CONFIG_FILE), config).unwrap();
        let o = RefineOptions::for_model(dir.path(), 7).unwrap();
        assert_eq!((o.steps, o.sigma, o.weights.arap, o.weights.masked), (7, 0.25, 10.0, true));
        assert_eq!(o.weights.joints, LossWeights::default().joints, "unset weights keep their defaults");
        std::fs::write(dir.path().join(CONFIG_FILE), "[loss]\narap = \"strong\"\n").unwrap();
        let err = RefineOptions::for_model(dir.path(), 7).unwrap_err().to_string();
        assert!(err.contains(CONFIG_FILE) && err.contains("[loss]"), "{err}");
    }
}
