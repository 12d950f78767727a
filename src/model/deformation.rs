//! The deformation network of neural-puppet.md §3.2, Figure 3: an encoder of three convolutions
//! (kernel 5, padding 2, stride 2) and three fully connected layers to a 512-d latent `z`, and a
//! decoder of three fully connected layers to per-vertex offsets plus a global 2D bias, added to
//! the rest vertices.
//!
//! Shapes: `[B, 4, S, S]` (premultiplied RGBA at the working size S) → `z [B, Z]` →
//! offsets `[B, V, 2]`, in working-frame pixels.

use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{Initializer, Linear, LinearConfig, PaddingConfig2d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};

/// The encoder's convolutions (paper, Figure 3): kernel side, stride and zero padding.
const KERNEL: usize = 5;
const STRIDE: usize = 2;
const PADDING: usize = 2;

/// Hyper-parameters of [`DeformationNet`]; saved with every model (STYLE.md: config is the
/// constructor and the record of a run).
#[derive(Config, Debug)]
pub struct DeformationNetConfig {
    /// Number of template vertices V.
    pub vertices: usize,
    /// Working resolution S (square input S×S; frames are letterboxed into it).
    #[config(default = 128)]
    pub input_size: usize,
    /// Channels of the three convolutions.
    #[config(default = "[32, 64, 128]")]
    pub channels: [usize; 3],
    /// Widths of the encoder's first two fully connected layers (the third outputs `latent`).
    #[config(default = "[1024, 512]")]
    pub encoder_hidden: [usize; 2],
    /// Latent size Z (paper: 512).
    #[config(default = 512)]
    pub latent: usize,
    /// Widths of the decoder's first two fully connected layers.
    #[config(default = "[512, 1024]")]
    pub decoder_hidden: [usize; 2],
    /// Network outputs are multiplied by this many pixels, so unit-scale activations mean
    /// displacements of a good fraction of the frame (keeps Adam's step sizes sensible).
    #[config(default = 16.0)]
    pub offset_scale: f32,
}

/// The encoder-decoder.
#[derive(Module, Debug)]
pub struct DeformationNet {
    convs: Vec<Conv2d>,
    encoder_fcs: Vec<Linear>,
    decoder_fcs: Vec<Linear>,
    offset_scale: f32,
    vertices: usize,
}

impl DeformationNetConfig {
    /// Builds the network with fresh weights; the last decoder layer starts at zero so an untrained
    /// network predicts the rest pose.
    ///
    /// # Panics
    /// If `input_size` is not a multiple of 8 (a caller bug: configs are validated first).
    pub fn init(&self, device: &Device) -> DeformationNet {
        assert!(
            self.input_size % 8 == 0 && self.input_size > 0,
            "input size {} is not a positive multiple of 8",
            self.input_size
        );
        let conv = |i: usize, o: usize| {
            Conv2dConfig::new([i, o], [KERNEL, KERNEL])
                .with_stride([STRIDE, STRIDE])
                .with_padding(PaddingConfig2d::Explicit(PADDING, PADDING, PADDING, PADDING))
                .init(device)
        };
        let [c1, c2, c3] = self.channels;
        let flat = c3 * (self.input_size / 8).pow(2);
        let linear = |i: usize, o: usize| LinearConfig::new(i, o).init(device);
        let [e1, e2] = self.encoder_hidden;
        let [d1, d2] = self.decoder_hidden;
        let out = 2 * self.vertices + 2;
        // Zero-initialised through the config (not by mapping the Param afterwards, which would
        // leave it untracked by autodiff), so the untrained network predicts the rest pose.
        let last = LinearConfig::new(d2, out).with_initializer(Initializer::Zeros).init(device);
        DeformationNet {
            convs: vec![conv(4, c1), conv(c1, c2), conv(c2, c3)],
            encoder_fcs: vec![linear(flat, e1), linear(e1, e2), linear(e2, self.latent)],
            decoder_fcs: vec![linear(self.latent, d1), linear(d1, d2), last],
            offset_scale: self.offset_scale,
            vertices: self.vertices,
        }
    }
}

impl DeformationNet {
    /// Encodes frames: `[B, 4, S, S]` → `z [B, Z]`.
    pub fn encode(&self, images: Tensor<4>) -> Tensor<2> {
        let mut x = images;
        for conv in &self.convs {
            x = relu(super::conv_op::conv2d(conv, x, STRIDE, PADDING));
        }
        let mut h: Tensor<2> = x.flatten(1, 3);
        for (i, fc) in self.encoder_fcs.iter().enumerate() {
            h = fc.forward(h);
            if i + 1 < self.encoder_fcs.len() {
                h = relu(h);
            }
        }
        h
    }

    /// Decodes latents into displacements from the rest pose: `z [B, Z]` → `[B, V, 2]` pixels
    /// (per-vertex offsets plus the global bias, already summed).
    pub fn decode(&self, z: Tensor<2>) -> Tensor<3> {
        let mut h = z;
        for (i, fc) in self.decoder_fcs.iter().enumerate() {
            h = fc.forward(h);
            if i + 1 < self.decoder_fcs.len() {
                h = relu(h);
            }
        }
        let batch = h.dims()[0];
        let h = h.mul_scalar(self.offset_scale);
        let offsets: Tensor<3> = h.clone().narrow(1, 0, 2 * self.vertices).reshape([batch, self.vertices, 2]);
        let bias: Tensor<3> = h.narrow(1, 2 * self.vertices, 2).reshape([batch, 1, 2]);
        offsets + bias
    }

    /// Predicted vertex positions: rest `[V, 2]` plus the decoded displacements → `[B, V, 2]`.
    pub fn vertices(&self, z: Tensor<2>, rest: &Tensor<2>) -> Tensor<3> {
        self.decode(z) + rest.clone().unsqueeze::<3>()
    }

    /// Moves the network out, leaving one without layers in its place, so an optimiser can take
    /// the only reference to each weight and update it in place (a clone would share every
    /// buffer and make the optimiser copy all 36 M weights first).
    pub fn take(&mut self) -> DeformationNet {
        let empty = DeformationNet {
            convs: Vec::new(),
            encoder_fcs: Vec::new(),
            decoder_fcs: Vec::new(),
            offset_scale: self.offset_scale,
            vertices: self.vertices,
        };
        std::mem::replace(self, empty)
    }

    /// Number of template vertices the decoder predicts.
    pub fn vertex_count(&self) -> usize {
        self.vertices
    }
}

/// Rest vertices as a `[V, 2]` tensor on `device`.
pub fn rest_tensor(rest: &[[f32; 2]], device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(rest.as_flattened().to_vec(), [rest.len(), 2]), device)
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    #[test]
    fn untrained_network_predicts_the_rest_pose_with_the_documented_shapes() {
        let device = crate::backend::device();
        let config = DeformationNetConfig::new(5)
            .with_input_size(16)
            .with_encoder_hidden([32, 16])
            .with_latent(8)
            .with_decoder_hidden([8, 16]);
        let net = config.init(&device);
        let images = Tensor::<4>::random([3, 4, 16, 16], Distribution::Uniform(0.0, 1.0), &device);
        let z = net.encode(images);
        assert_eq!(z.dims(), [3, 8]);
        let rest: Vec<[f32; 2]> = (0..5).map(|i| [i as f32, 2.0 * i as f32]).collect();
        let v = net.vertices(z, &rest_tensor(&rest, &device));
        assert_eq!(v.dims(), [3, 5, 2]);
        let values: Vec<f32> = v.into_data().try_to_vec::<f32>().unwrap();
        for b in 0..3 {
            assert_eq!(&values[b * 10..b * 10 + 10], rest.as_flattened());
        }
    }
}
