//! The truth of a posed frame beyond its vertices: which layer is in front at each pixel, and
//! which vertices the frame shows. Both come from the renderer itself — each layer drawn alone
//! gives its coverage — so the labels and the visibility agree with the pixels of the frame.

use crate::error::Result;
use crate::puppet::Puppet;
use crate::render::{Background, Params, SoftRasterizer};

/// The label of a pixel no layer covers.
pub const NO_LAYER: u16 = u16::MAX;

/// Coverage above which a layer is drawn at a pixel (the alpha threshold of the project's
/// silhouettes, DESIGN.md "Metrics").
const COVERED: f32 = 0.5;

/// One rasterizer per layer of a puppet, for the per-pixel front layer.
pub struct LayerCoverage {
    /// Each layer alone, as a one-layer puppet's rasterizer.
    layers: Vec<SoftRasterizer>,
    /// Where each layer starts in the global numbering, and the total last.
    offsets: Vec<usize>,
}

impl LayerCoverage {
    /// The per-layer rasterizers of `puppet`.
    ///
    /// # Errors
    /// As [`SoftRasterizer::new`], naming the layer.
    pub fn new(puppet: &Puppet) -> Result<Self> {
        let layers = puppet
            .layers
            .iter()
            .map(|layer| {
                SoftRasterizer::new(&Puppet {
                    width: puppet.width,
                    height: puppet.height,
                    layers: vec![layer.clone()],
                    root: 0,
                    joints: Vec::new(),
                    rig: None,
                })
            })
            .collect::<Result<_>>()?;
        Ok(LayerCoverage {
            layers,
            offsets: puppet.vertex_offsets(),
        })
    }

    /// The front layer at each pixel of a `width × height` frame of `pose` (global numbering,
    /// pixels), row-major: the frontmost layer whose crisp coverage exceeds one half, or
    /// [`NO_LAYER`].
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`] (a coordinate not finite, an empty frame).
    pub fn labels(&self, pose: &[[f32; 2]], width: u32, height: u32) -> Result<Vec<u16>> {
        let (w, h) = (width as usize, height as usize);
        let mut labels = vec![NO_LAYER; w * h];
        let params = Params::crisp(Background::Transparent);
        for (l, raster) in self.layers.iter().enumerate() {
            let flat: Vec<f32> = pose[self.offsets[l]..self.offsets[l + 1]].iter().flatten().copied().collect();
            let frame = raster.forward(&flat, 1, w, h, &params)?;
            // Back to front: a later layer that covers a pixel is in front of what is there.
            for (label, &m) in labels.iter_mut().zip(&frame.mask) {
                if m > COVERED {
                    *label = l as u16;
                }
            }
        }
        Ok(labels)
    }
}

/// Whether each vertex of `pose` (global numbering, pixels) shows in the frame whose front
/// layers are `labels` (`width × height`, row-major): inside the frame, and no layer drawn in
/// front of its own covers the pixel it lies on.
pub fn visible(pose: &[[f32; 2]], offsets: &[usize], labels: &[u16], width: u32, height: u32) -> Vec<bool> {
    let mut out = Vec::with_capacity(pose.len());
    for l in 0..offsets.len().saturating_sub(1) {
        for p in &pose[offsets[l]..offsets[l + 1]] {
            let (x, y) = (p[0].floor(), p[1].floor());
            let inside = x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32;
            out.push(
                inside && {
                    let front = labels[y as usize * width as usize + x as usize];
                    front == NO_LAYER || usize::from(front) <= l
                },
            );
        }
    }
    out
}

/// A colour for layer `l` that tells it from its neighbours in order: hues a golden angle apart,
/// full saturation, alternating lightness.
pub fn label_colour(l: usize) -> [f32; 3] {
    let hue = (l as f32 * 0.618_034).fract() * 6.0;
    let x = 1.0 - (hue % 2.0 - 1.0).abs();
    let [r, g, b] = match hue as u32 {
        0 => [1.0, x, 0.0],
        1 => [x, 1.0, 0.0],
        2 => [0.0, 1.0, x],
        3 => [0.0, x, 1.0],
        4 => [x, 0.0, 1.0],
        _ => [1.0, 0.0, x],
    };
    let v = if l.is_multiple_of(2) { 1.0 } else { 0.6 };
    [r * v, g * v, b * v]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::layered_puppet;

    #[test]
    fn the_rest_labels_put_the_front_arm_over_the_torso_and_visibility_follows() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let labels = LayerCoverage::new(&puppet)
            .unwrap()
            .labels(&rest, puppet.width, puppet.height)
            .unwrap();
        let at = |x: usize, y: usize| labels[y * puppet.width as usize + x];
        // arm_front (layer 3) spans x 24..43, y 20..25 over the torso (layer 1, x 16..32).
        assert_eq!(at(28, 22), 3);
        assert_eq!(at(20, 30), 1);
        assert_eq!(at(1, 1), NO_LAYER);
        let offsets = puppet.vertex_offsets();
        let shown = visible(&rest, &offsets, &labels, puppet.width, puppet.height);
        // A torso vertex under the front arm is hidden; the front arm's own are shown.
        let torso_under_arm = (offsets[1]..offsets[2]).find(|&v| {
            let p = rest[v];
            p[0] > 25.0 && p[0] < 31.0 && p[1] > 20.5 && p[1] < 24.5
        });
        if let Some(v) = torso_under_arm {
            assert!(!shown[v], "torso vertex {v} at {:?} is under the arm", rest[v]);
        }
        assert!(
            (offsets[3]..offsets[4]).all(|v| shown[v]),
            "the front layer shows everywhere in the frame"
        );
        let outside = visible(&[[-1.0, 3.0]], &[0, 1], &labels, puppet.width, puppet.height);
        assert_eq!(outside, [false]);
    }

    #[test]
    fn neighbouring_layers_get_different_colours() {
        let colours: Vec<[f32; 3]> = (0..12).map(label_colour).collect();
        for (k, pair) in colours.windows(2).enumerate() {
            assert_ne!(pair[0], pair[1], "layers {k} and {}", k + 1);
        }
    }
}
