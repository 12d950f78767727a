//! The correspondence network of APES (apes-part-extraction.md §3.1): a gated U-Net that maps a
//! pose to one unit feature vector per pixel, so that the same point of the character in two
//! poses gets nearly the same vector and other points do not (trained with InfoNCE,
//! `parts::learn`). Pixels are matched between poses by their most similar feature.
//!
//! The paper gives a "gated U-Net" of 6.7 M parameters at 256²; its layers are not specified.
//! Ours: pix2pix-style 4×4 stride-2 convolutions down; up, nearest-neighbour doubling and 3×3
//! convolutions (no checkerboard), skips by concatenation, every block a gated convolution (Yu et al. 2019: half the channels are
//! features, half a sigmoid gate that lets the network switch features off where they do not
//! apply — here, off the character), instance-normalised features, LeakyReLU 0.2; a 3×3 head
//! over the last block and the input draws the features, normalised to unit length.
//!
//! Shapes: `[B, 4, S, S]` premultiplied RGBA → `[B, F, S, S]`.

use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{InstanceNorm, InstanceNormConfig, PaddingConfig2d};
use burn::tensor::{Device, Tensor};

use super::conv_op::{conv2d, conv2d_doubled};
use super::gate_op::gated_norm;

/// The blocks' kernel side (pix2pix's).
const KERNEL: usize = 4;
/// LeakyReLU's negative slope.
const SLOPE: f64 = 0.2;
/// Added under the square root of the feature norm, so an all-zero feature has a gradient.
const NORM_EPSILON: f64 = 1e-6;

/// Hyper-parameters of the correspondence network; saved beside its weights.
#[derive(Config, Debug, PartialEq)]
pub struct CorrespondenceNetConfig {
    /// Working size S: poses are letterboxed into S×S.
    #[config(default = 128)]
    pub input_size: usize,
    /// Channels of the first block; doubled per level up to `max_channels`.
    #[config(default = 16)]
    pub base_channels: usize,
    /// The channel ceiling.
    #[config(default = 64)]
    pub max_channels: usize,
    /// Downsamplings (S must divide by 2^depth).
    #[config(default = 5)]
    pub depth: usize,
    /// Length of each pixel's feature vector.
    #[config(default = 32)]
    pub features: usize,
}

/// A convolution whose output is features gated by a sigmoid of as many more channels.
#[derive(Module, Debug)]
struct GatedDown {
    conv: Conv2d,
    norm: InstanceNorm,
}

/// The way up: nearest-neighbour doubling, then a gated 3×3 convolution (no checkerboard, and
/// the convolution runs on the slice kernels of `conv_op`).
#[derive(Module, Debug)]
struct GatedUp {
    conv: Conv2d,
    norm: InstanceNorm,
}

/// The gated U-Net.
#[derive(Module, Debug)]
pub struct CorrespondenceNet {
    /// `downs[i]` takes level `i` (the input at 0) to level `i + 1`, half the size.
    downs: Vec<GatedDown>,
    /// `ups[i]` takes level `i + 1` (with its skip, below the innermost) to level `i`.
    ups: Vec<GatedUp>,
    /// Features from the last block and the input.
    head: Conv2d,
}

impl CorrespondenceNetConfig {
    fn channels(&self, level: usize) -> usize {
        (self.base_channels << level.min(16)).min(self.max_channels)
    }

    /// Checks the sizes (bounded, so a shape read from a file cannot ask for unbounded memory).
    ///
    /// # Errors
    /// [`crate::error::Error::Setting`] for a size out of range or a depth the input size
    /// cannot halve.
    pub fn validate(&self) -> crate::error::Result<()> {
        use crate::error::Error;
        if self.depth == 0 || self.depth > 8 || !self.input_size.is_multiple_of(1usize << self.depth) {
            return Err(Error::setting(
                "depth",
                self.depth,
                format!("1 to 8 halvings of input_size {}", self.input_size),
            ));
        }
        if !(8..=512).contains(&self.input_size) {
            return Err(Error::setting("input_size", self.input_size, "8 to 512"));
        }
        if !(1..=256).contains(&self.base_channels) {
            return Err(Error::setting("base_channels", self.base_channels, "1 to 256"));
        }
        if !(self.base_channels..=512).contains(&self.max_channels) {
            return Err(Error::setting("max_channels", self.max_channels, "base_channels to 512"));
        }
        if !(2..=256).contains(&self.features) {
            return Err(Error::setting("features", self.features, "2 to 256"));
        }
        Ok(())
    }

    /// A fresh network (Kaiming-uniform weights, Burn's default).
    pub fn init(&self, device: &Device) -> CorrespondenceNet {
        let downs = (0..self.depth)
            .map(|i| {
                let input = if i == 0 { 4 } else { self.channels(i - 1) };
                let output = self.channels(i);
                GatedDown {
                    conv: Conv2dConfig::new([input, 2 * output], [KERNEL, KERNEL])
                        .with_stride([2, 2])
                        .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                        .init(device),
                    norm: InstanceNormConfig::new(output).init(device),
                }
            })
            .collect();
        let ups = (0..self.depth)
            .map(|i| {
                let input = if i == self.depth - 1 {
                    self.channels(i)
                } else {
                    2 * self.channels(i)
                };
                let output = if i == 0 { self.base_channels } else { self.channels(i - 1) };
                GatedUp {
                    conv: Conv2dConfig::new([input, 2 * output], [3, 3])
                        .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                        .init(device),
                    norm: InstanceNormConfig::new(output).init(device),
                }
            })
            .collect();
        let head = Conv2dConfig::new([self.base_channels + 4, self.features], [3, 3])
            .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
            .init(device);
        CorrespondenceNet { downs, ups, head }
    }
}

impl CorrespondenceNet {
    /// Unit features `[B, F, S, S]` of poses `[B, 4, S, S]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        unit_length(self.raw_forward(x))
    }

    /// The features before their scaling to unit length (training scales only the pixels its
    /// loss samples).
    pub fn raw_forward(&self, x: Tensor<4>) -> Tensor<4> {
        let mut levels = vec![x.clone()];
        for down in &self.downs {
            let h = conv2d(&down.conv, levels.last().expect("the input").clone(), 2, 1);
            levels.push(gated_norm(h, &down.norm, SLOPE));
        }
        let depth = self.downs.len();
        let mut y = levels[depth].clone();
        for i in (0..depth).rev() {
            if i < depth - 1 {
                y = Tensor::cat(vec![y, levels[i + 1].clone()], 1);
            }
            y = gated_norm(conv2d_doubled(&self.ups[i].conv, y, 1), &self.ups[i].norm, SLOPE);
        }
        conv2d(&self.head, Tensor::cat(vec![y, x], 1), 1, 1)
    }
}

/// `f` with every vector along axis 1 (a pixel's features) scaled to unit length.
pub fn unit_length<const D: usize>(f: Tensor<D>) -> Tensor<D> {
    let norm = (f.clone().powi_scalar(2).sum_dim(1) + NORM_EPSILON).sqrt();
    f / norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::TensorData;

    #[test]
    fn features_are_unit_vectors_of_every_pixel() {
        let device = crate::backend::device();
        let config = CorrespondenceNetConfig::new().with_input_size(32).with_depth(3).with_features(8);
        config.validate().unwrap();
        let net = config.init(&device);
        let data: Vec<f32> = (0..2 * 4 * 32 * 32).map(|i| ((i * 37) % 101) as f32 / 100.0).collect();
        let x = Tensor::<4>::from_data(TensorData::new(data, [2, 4, 32, 32]), &device);
        let f = net.forward(x);
        assert_eq!(f.dims(), [2, 8, 32, 32]);
        let norms = f.powi_scalar(2).sum_dim(1).into_data().try_to_vec::<f32>().unwrap();
        assert!(norms.iter().all(|n| (n - 1.0).abs() < 1e-3), "{:?}", &norms[..4]);
    }

    #[test]
    fn sizes_the_depth_cannot_halve_are_refused() {
        assert!(CorrespondenceNetConfig::new().with_input_size(100).validate().is_err());
        assert!(CorrespondenceNetConfig::new().with_features(1).validate().is_err());
        assert!(CorrespondenceNetConfig::new().validate().is_ok());
    }
}
