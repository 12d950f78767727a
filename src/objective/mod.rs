//! The objective of neural-puppet.md §3.2 and appendix (eq. 1–4, 10, 11): the losses as Burn
//! tensor functions, the ARAP energy as a differentiable operation ([`arap_op`]), and
//! [`Objective`], which renders predicted vertices with the soft rasterizer and sums eq. 4 —
//! what training lowers over the network's weights and fitting over a frame's latent or
//! vertices.
//!
//! Units (see [`LossWeights`]): images premultiplied RGBA in [0, 1], eq. 1 a sum over pixels as
//! written; vertices in working pixels converted to NDC (÷ S/2) for ARAP and joints, so the
//! paper's λ1 = 2500, λ2 = 1e4 apply.

pub mod adversarial;
pub mod arap_op;
pub mod info_nce;

use std::sync::Arc;

use burn::tensor::{Device, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::geom::arap::ArapEnergy;
use crate::puppet::{LayerKind, Puppet};
use crate::render::burn_op::{soft_raster, Rendered};
use crate::render::soft_raster::{Background, Params, SoftRasterizer};
use arap_op::arap_loss;

/// Weights of eq. 4 (and eq. 10–11 for masked training).
///
/// Units, so the paper's numbers mean what they meant there (NMR: images in [0, 1], vertices in
/// normalised device coordinates where the image spans [−1, 1]): L_rec is eq. 1 as written, the
/// squared norm of the premultiplied-RGBA difference summed over the pixels and channels of an
/// image (eq. 10's masked variant is, as written, normalised by the silhouette's area); ARAP
/// (eq. 2) and the joint term (eq. 3) are sums over edges / joints of squared lengths in NDC,
/// i.e. working pixels divided by S/2; every term is averaged over the batch; the area term
/// (eq. 11) compares mask sums as fractions of the image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LossWeights {
    /// λ1, ARAP (paper: 2500).
    pub arap: f64,
    /// λ2, joints (paper: 1e4).
    pub joints: f64,
    /// Use the masked loss of eq. 10 and the area penalty of eq. 11 (frames over a background).
    pub masked: bool,
    /// Weight of eq. 11's area penalty (paper: 2e-3).
    pub area: f64,
}

impl Default for LossWeights {
    fn default() -> Self {
        LossWeights {
            arap: 2500.0,
            joints: 1e4,
            masked: false,
            area: 2e-3,
        }
    }
}

/// Eq. 1, `‖x − R(V, F, I^uv)‖²`: the squared norm over channels and pixels of each image,
/// averaged over the batch.
pub fn reconstruction(rendered: Tensor<4>, target: Tensor<4>) -> Tensor<1> {
    let [b, _, _, _] = rendered.dims();
    (rendered - target).powf_scalar(2.0).reshape([b as i32, -1]).sum_dim(1).mean()
}

/// Eq. 10: the squared difference between the frame seen through the rendered silhouette
/// `x ⊙ R(V, F, I¹)` and the render, normalised by the silhouette's area; RGB only (the frame is
/// opaque), averaged over the batch. `target_rgb` `[B, 3, H, W]`, `mask` `[B, 1, H, W]`.
pub fn masked_reconstruction(rendered: Tensor<4>, mask: Tensor<4>, target_rgb: Tensor<4>) -> Tensor<1> {
    let [b, _, _, _] = rendered.dims();
    let rgb = rendered.narrow(1, 0, 3);
    let diff = (target_rgb * mask.clone() - rgb)
        .powf_scalar(2.0)
        .reshape([b as i32, -1])
        .sum_dim(1);
    let area = mask.reshape([b as i32, -1]).sum_dim(1).add_scalar(1e-6);
    (diff / area).mean()
}

/// Eq. 11: `|Σ R(V_pred) − Σ R(V_init)|²`, each sum as a fraction of the image, batch mean.
pub fn area(mask: Tensor<4>, rest_area: f32) -> Tensor<1> {
    let [b, _, h, w] = mask.dims();
    let fraction = mask.reshape([b as i32, -1]).sum_dim(1).div_scalar((h * w) as f32);
    fraction.sub_scalar(rest_area).powf_scalar(2.0).mean()
}

/// Eq. 3, `Σ ‖p_i − q_i‖²` per batch item, `[B]`, for joint vertex index pairs `a[i]`, `b[i]`.
pub fn joint_loss(vertices: Tensor<3>, a: Tensor<1, Int>, b: Tensor<1, Int>) -> Tensor<1> {
    let [batch, _, _] = vertices.dims();
    let d = vertices.clone().select(1, a) - vertices.select(1, b);
    d.powf_scalar(2.0).reshape([batch as i32, -1]).sum_dim(1).squeeze_dim(1)
}

/// The triangles the ARAP term holds (global vertex indices; layers are disjoint components):
/// every layer's, or with an accessory rig only the body's — the rig shapes the accessories, and
/// their vertices are not the network's to move.
pub fn regularised_triangles(puppet: &Puppet) -> Vec<[u32; 3]> {
    let offsets = puppet.vertex_offsets();
    puppet
        .layers
        .iter()
        .zip(&offsets)
        .filter(|(layer, _)| puppet.rig.is_none() || layer.kind == LayerKind::Body)
        .flat_map(|(layer, &o)| layer.mesh.triangles.iter().map(move |t| t.map(|i| i + o as u32)))
        .collect()
}

/// One evaluation of eq. 4 (or its masked variant), the total and each term, batch means.
#[derive(Clone, Debug)]
pub struct LossTerms {
    /// The weighted sum that is minimised.
    pub total: Tensor<1>,
    /// L_rec (eq. 1) or L_rec^masked (eq. 10).
    pub rec: Tensor<1>,
    /// L_reg (eq. 2), NDC units, unweighted.
    pub arap: Tensor<1>,
    /// L_joints (eq. 3), NDC units, unweighted.
    pub joints: Tensor<1>,
    /// L_area (eq. 11), unweighted (zero unless masked).
    pub area: Tensor<1>,
}

/// Everything the losses need for one puppet at one working size: the rasterizer, the ARAP
/// energy of the rest pose, the joints, the rest silhouette's area, the weights.
#[derive(Clone, Debug)]
pub struct Objective {
    weights: LossWeights,
    raster: Arc<SoftRasterizer>,
    size: usize,
    arap: Arc<ArapEnergy<f32>>,
    joint_a: Vec<i64>,
    joint_b: Vec<i64>,
    ndc_scale: f32,
    rest_area: f32,
    /// What the reconstruction counts for in the total: 1, or k² for an unmasked objective at
    /// 1/k of the working size, whose sum over pixels has 1/k² as many terms.
    rec_scale: f32,
}

impl Objective {
    /// Prepares the rasterizer for `puppet`, the ARAP energy on the rest vertices `rest` (working
    /// pixels of an S×S square, S = `size`), the joint pairs, and the rest silhouette's area
    /// fraction (eq. 11).
    ///
    /// # Errors
    /// [`crate::Error::Geometry`] if the mesh is degenerate (see [`ArapEnergy::new`]) or a layer
    /// cannot be rasterized.
    pub fn new(puppet: &Puppet, rest: &[[f32; 2]], size: usize, weights: LossWeights) -> Result<Self> {
        let raster = Arc::new(SoftRasterizer::new(puppet)?);
        let half = size as f32 / 2.0;
        let ndc: Vec<[f32; 2]> = rest.iter().map(|p| [p[0] / half, p[1] / half]).collect();
        let arap = Arc::new(ArapEnergy::new(&ndc, &regularised_triangles(puppet))?);
        let (joint_a, joint_b) = puppet
            .joints
            .iter()
            .map(|j| (puppet.global_index(j.a) as i64, puppet.global_index(j.b) as i64))
            .unzip();
        let rest_area = rest_coverage(&raster, rest, size)?;
        Ok(Objective {
            weights,
            raster,
            size,
            arap,
            joint_a,
            joint_b,
            ndc_scale: 1.0 / half,
            rest_area,
            rec_scale: 1.0,
        })
    }

    /// The objective of `new(puppet, rest, size, weights)` evaluated at 1/`factor` of the working
    /// size: for vertices and targets scaled by 1/`factor`, each term counts as at full size
    /// (ARAP and joints are in NDC already; the masked reconstruction and the area are ratios; the
    /// plain reconstruction is a sum over pixels, so it counts `factor²` times).
    ///
    /// # Errors
    /// As [`Objective::new`]; [`crate::Error::Setting`] if `factor` does not divide `size`.
    pub fn downsampled(puppet: &Puppet, rest: &[[f32; 2]], size: usize, weights: LossWeights, factor: usize) -> Result<Self> {
        if factor == 0 || !size.is_multiple_of(factor) {
            return Err(crate::Error::setting(
                "objective downsampling",
                factor,
                format!("a divisor of the working size {size}"),
            ));
        }
        let f = factor as f32;
        let rest: Vec<[f32; 2]> = rest.iter().map(|p| [p[0] / f, p[1] / f]).collect();
        let masked = weights.masked;
        let objective = Objective::new(puppet, &rest, size / factor, weights)?;
        Ok(Objective {
            rec_scale: if masked { 1.0 } else { f * f },
            ..objective
        })
    }

    /// The rasterizer the objective renders with.
    pub fn raster(&self) -> &Arc<SoftRasterizer> {
        &self.raster
    }

    /// The weights.
    pub fn weights(&self) -> &LossWeights {
        &self.weights
    }

    /// Renders vertices `[B, V, 2]` (working pixels) on transparency at soft-rasterizer `sigma`
    /// (px² of the working square), differentiably.
    ///
    /// # Errors
    /// As [`soft_raster`].
    pub fn render(&self, vertices: Tensor<3>, sigma: f32) -> Result<Rendered> {
        let params = Params {
            sigma,
            background: Background::Transparent,
            ..Params::default()
        };
        soft_raster(vertices, &self.raster, self.size, self.size, params)
    }

    /// Eq. 4 of vertices `[B, V, 2]` (working pixels) rendered at `sigma` against `target`:
    /// premultiplied RGBA `[B, 4, S, S]` (or, masked, the opaque frame whose RGB is used).
    ///
    /// # Errors
    /// As [`Objective::render`] and [`Objective::score`].
    pub fn evaluate(&self, vertices: Tensor<3>, target: Tensor<4>, sigma: f32, device: &Device) -> Result<LossTerms> {
        let rendered = self.render(vertices.clone(), sigma)?;
        self.score(vertices, &rendered, target, device)
    }

    /// Eq. 4 for predicted vertices `[B, V, 2]` (working pixels), their render, and the target.
    ///
    /// # Errors
    /// Shape errors from the ARAP operation.
    pub fn score(&self, vertices: Tensor<3>, rendered: &Rendered, target: Tensor<4>, device: &Device) -> Result<LossTerms> {
        let ndc = vertices.mul_scalar(self.ndc_scale);
        let arap = arap_loss(ndc.clone(), &self.arap)?.mean();
        let joints = if self.joint_a.is_empty() {
            Tensor::zeros([1], device)
        } else {
            let index = |v: &[i64]| Tensor::<1, Int>::from_data(TensorData::new(v.to_vec(), [v.len()]), device);
            joint_loss(ndc, index(&self.joint_a), index(&self.joint_b)).mean()
        };
        let (rec, area_term) = if self.weights.masked {
            let rgb = target.narrow(1, 0, 3);
            (
                masked_reconstruction(rendered.image.clone(), rendered.mask.clone(), rgb),
                area(rendered.mask.clone(), self.rest_area),
            )
        } else {
            (reconstruction(rendered.image.clone(), target), Tensor::zeros([1], device))
        };
        let w = &self.weights;
        let total = rec.clone().mul_scalar(self.rec_scale)
            + arap.clone().mul_scalar(w.arap)
            + joints.clone().mul_scalar(w.joints)
            + area_term.clone().mul_scalar(if w.masked { w.area } else { 0.0 });
        Ok(LossTerms {
            total,
            rec,
            arap,
            joints,
            area: area_term,
        })
    }
}

/// Images `[B, C, H, W]` at 1/`factor` of their size, each pixel the mean of the `factor²` it
/// covers (`factor` divides H and W): targets for [`Objective::downsampled`].
pub fn downsample(images: Tensor<4>, factor: usize) -> Tensor<4> {
    let [b, c, h, w] = images.dims();
    images
        .reshape([b, c, h / factor, factor, w / factor, factor])
        .mean_dim(5)
        .mean_dim(3)
        .reshape([b, c, h / factor, w / factor])
}

/// The rest pose's silhouette area as a fraction of the S×S square (eq. 11's Σ R(V_init)).
fn rest_coverage(raster: &SoftRasterizer, rest: &[[f32; 2]], size: usize) -> Result<f32> {
    let flat: Vec<f32> = rest.iter().flatten().copied().collect();
    let f = raster.forward(&flat, 1, size, size, &Params::crisp(Background::Transparent))?;
    Ok(f.mask.iter().sum::<f32>() / (size * size) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tensor4(values: Vec<f32>, shape: [usize; 4]) -> Tensor<4> {
        Tensor::from_data(TensorData::new(values, shape), &crate::backend::device())
    }

    fn scalar(t: Tensor<1>) -> f32 {
        t.into_data().try_to_vec::<f32>().unwrap()[0]
    }

    #[test]
    fn terms_match_hand_computed_values() {
        let r = tensor4(vec![0.5, 0.0, 1.0, 0.25], [1, 1, 2, 2]);
        let x = tensor4(vec![0.0, 0.0, 0.5, 0.25], [1, 1, 2, 2]);
        assert!((scalar(reconstruction(r, x)) - (0.25 + 0.25)).abs() < 1e-7);

        // eq. 10 with one RGB pixel inside a half-covered mask: ((1·0.5 − 0.2)²·3) / (0.5 + 0)
        let rendered = tensor4(vec![0.2, 0.0, 0.2, 0.0, 0.2, 0.0, 0.5, 0.0], [1, 4, 1, 2]); // channel-major
        let mask = tensor4(vec![0.5, 0.0], [1, 1, 1, 2]);
        let target = tensor4(vec![1.0, 1.0, 1.0, 1.0, 1.0, 1.0], [1, 3, 1, 2]);
        let want = 3.0 * 0.3f32.powi(2) / 0.5;
        let got = scalar(masked_reconstruction(rendered, mask.clone(), target));
        assert!((got - want).abs() < 1e-4, "{got} vs {want}");
        assert!((scalar(area(mask, 0.5)) - (0.25f32 - 0.5).powi(2)).abs() < 1e-7);

        let device = crate::backend::device();
        let v = Tensor::<3>::from_data(TensorData::new(vec![0.0f32, 0.0, 3.0, 4.0, 1.0, 1.0], [1, 3, 2]), &device);
        let idx = |v: Vec<i64>| Tensor::<1, Int>::from_data(TensorData::new(v, [2]), &device);
        let j = joint_loss(v, idx(vec![0, 2]), idx(vec![1, 0]));
        assert!((scalar(j) - (25.0 + 2.0)).abs() < 1e-6);
    }

    #[test]
    fn a_downsampled_objective_counts_each_term_as_at_full_size() {
        let device = crate::backend::device();
        let puppet = crate::test_util::hinged_puppet();
        let size = 48;
        let rest: Vec<[f32; 2]> = puppet.layers.iter().flat_map(|l| l.mesh.vertices.iter().copied()).collect();
        let pose = |seed: u64| {
            let v: Vec<f32> = crate::test_util::jittered(&rest, seed, 1.5).iter().map(|&c| c as f32).collect();
            Tensor::<3>::from_data(TensorData::new(v, [1, rest.len(), 2]), &device)
        };
        let (drawn, guess) = (pose(1), pose(2));
        for masked in [false, true] {
            let weights = LossWeights {
                masked,
                ..LossWeights::default()
            };
            let full = Objective::new(&puppet, &rest, size, weights.clone()).unwrap();
            let half = Objective::downsampled(&puppet, &rest, size, weights, 2).unwrap();
            let target = full.render(drawn.clone(), 1.0).unwrap().image;
            let at_full = full.evaluate(guess.clone(), target.clone(), 1.0, &device).unwrap();
            let at_half = half
                .evaluate(guess.clone().mul_scalar(0.5), downsample(target, 2), 0.25, &device)
                .unwrap();
            let close = |a: Tensor<1>, b: Tensor<1>, tolerance: f32| {
                let (a, b) = (scalar(a), scalar(b));
                assert!((a - b).abs() <= tolerance * a.abs().max(1e-6), "masked {masked}: {a} vs {b}");
            };
            close(at_full.arap.clone(), at_half.arap.clone(), 1e-4);
            close(at_full.joints.clone(), at_half.joints.clone(), 1e-4);
            // The reconstruction is measured on a quarter of the pixels: equal only roughly.
            let scale = if masked { 1.0 } else { 4.0 };
            close(at_full.rec.clone(), at_half.rec.clone().mul_scalar(scale), 0.2);
            let w = LossWeights::default();
            let expected = at_half.rec.mul_scalar(scale)
                + at_half.arap.mul_scalar(w.arap)
                + at_half.joints.mul_scalar(w.joints)
                + at_half.area.mul_scalar(if masked { w.area } else { 0.0 });
            close(at_half.total, expected, 1e-5);
        }
        let err = Objective::downsampled(&puppet, &rest, size, LossWeights::default(), 5).unwrap_err();
        assert!(err.to_string().contains("divisor of the working size 48"), "{err}");
    }
}
