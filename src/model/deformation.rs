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

/// The most weights a deformation network may have (1 GiB as f32), so a config read from a file
/// cannot ask for more memory than that.
pub const MAX_PARAMETERS: usize = 1 << 28;

impl DeformationNetConfig {
    /// How many weights (and biases) the network has; `None` if the count overflows.
    pub fn parameter_count(&self) -> Option<usize> {
        let conv = |i: usize, o: usize| i.checked_mul(o)?.checked_mul(KERNEL * KERNEL)?.checked_add(o);
        let linear = |i: usize, o: usize| i.checked_mul(o)?.checked_add(o);
        let [c1, c2, c3] = self.channels;
        let [e1, e2] = self.encoder_hidden;
        let [d1, d2] = self.decoder_hidden;
        let flat = c3.checked_mul((self.input_size / 8).checked_pow(2)?)?;
        let out = self.vertices.checked_mul(2)?.checked_add(2)?;
        [
            conv(4, c1),
            conv(c1, c2),
            conv(c2, c3),
            linear(flat, e1),
            linear(e1, e2),
            linear(e2, self.latent),
            linear(self.latent, d1),
            linear(d1, d2),
            linear(d2, out),
        ]
        .into_iter()
        .try_fold(0usize, |sum, n| sum.checked_add(n?))
    }

    /// Checks the sizes before a network is built: every width positive, the input size a
    /// positive multiple of 8, a finite positive offset scale, at most [`MAX_PARAMETERS`] weights.
    ///
    /// # Errors
    /// [`crate::error::Error::Setting`] naming the first key out of range.
    pub fn validate(&self) -> crate::error::Result<()> {
        use crate::error::Error;
        if self.input_size == 0 || !self.input_size.is_multiple_of(8) {
            return Err(Error::setting("input_size", self.input_size, "a positive multiple of 8"));
        }
        let widths = [
            ("vertices", self.vertices),
            ("channels", self.channels.into_iter().min().unwrap_or(0)),
            ("encoder_hidden", self.encoder_hidden.into_iter().min().unwrap_or(0)),
            ("latent", self.latent),
            ("decoder_hidden", self.decoder_hidden.into_iter().min().unwrap_or(0)),
        ];
        if let Some((key, width)) = widths.into_iter().find(|&(_, w)| w == 0) {
            return Err(Error::setting(key, width, "positive widths"));
        }
        if !(self.offset_scale.is_finite() && self.offset_scale > 0.0) {
            return Err(Error::setting("offset_scale", self.offset_scale, "a positive number"));
        }
        match self.parameter_count() {
            Some(n) if n <= MAX_PARAMETERS => Ok(()),
            n => Err(Error::setting(
                "weights",
                n.map_or("more than usize can count".into(), |n| n.to_string()),
                format!("at most {MAX_PARAMETERS}: a smaller input_size, fewer channels or narrower layers"),
            )),
        }
    }

    /// Builds the network with fresh weights; the last decoder layer starts at zero so an untrained
    /// network predicts the rest pose.
    ///
    /// # Panics
    /// If `input_size` is not a multiple of 8 (a caller bug: configs are validated first).
    pub fn init(&self, device: &Device) -> DeformationNet {
        assert!(
            self.input_size.is_multiple_of(8) && self.input_size > 0,
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
    fn the_parameter_count_is_the_built_networks_and_a_config_out_of_range_is_refused() {
        let device = crate::backend::device();
        let config = DeformationNetConfig::new(7)
            .with_input_size(24)
            .with_channels([3, 5, 6])
            .with_encoder_hidden([9, 4])
            .with_latent(5)
            .with_decoder_hidden([6, 8]);
        assert_eq!(config.parameter_count(), Some(config.init(&device).num_params()));
        config.validate().unwrap();
        // The default network for a puppet of 1,000 vertices at 128² fits; at 1024² it does not.
        DeformationNetConfig::new(1000).validate().unwrap();
        let wide = DeformationNetConfig::new(1000).with_input_size(1024);
        assert!(wide.parameter_count().unwrap() > MAX_PARAMETERS);
        let refused = |c: DeformationNetConfig, key: &str| {
            let e = c.validate().unwrap_err();
            assert!(matches!(&e, crate::error::Error::Setting { name, .. } if name == key), "{key}: {e}");
        };
        refused(wide, "weights");
        refused(DeformationNetConfig::new(1000).with_input_size(1 << 40), "weights");
        refused(DeformationNetConfig::new(10).with_input_size(20), "input_size");
        refused(DeformationNetConfig::new(0), "vertices");
        refused(DeformationNetConfig::new(10).with_channels([4, 0, 4]), "channels");
        refused(DeformationNetConfig::new(10).with_latent(0), "latent");
        refused(DeformationNetConfig::new(10).with_decoder_hidden([0, 3]), "decoder_hidden");
        refused(DeformationNetConfig::new(10).with_offset_scale(f32::NAN), "offset_scale");
    }

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
