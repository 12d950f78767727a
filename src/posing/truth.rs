//! The truth of a posed frame beyond its vertices: which layer is in front at each pixel, and
//! which vertices the frame shows. Both come from the renderer itself — each layer drawn alone
//! gives its coverage — so the labels and the visibility agree with the pixels of the frame.

use crate::error::Result;
use crate::geom::triangle::barycentric;
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

/// A point of a puppet's surface: barycentric weights over three vertices of one layer's
/// triangle, so it can be found on any pose of the puppet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The layer it lies on.
    pub layer: u16,
    /// The triangle's corners, global numbering.
    pub corners: [u32; 3],
    /// Their weights (sum 1).
    pub weights: [f32; 3],
}

impl SurfacePoint {
    /// Where the point is on `pose` (global numbering).
    pub fn on(&self, pose: &[[f32; 2]]) -> [f32; 2] {
        let mut p = [0.0f32; 2];
        for (&v, &w) in self.corners.iter().zip(&self.weights) {
            p[0] += w * pose[v as usize][0];
            p[1] += w * pose[v as usize][1];
        }
        p
    }
}

/// For each pixel of a `width × height` frame of `pose` (global numbering, pixels), row-major,
/// the point of the surface drawn at its centre: on the front layer `labels` names there, in
/// the triangle of that layer holding the centre. `None` off the character, and on the few
/// outline pixels whose coverage passes one half while their centre lies outside every triangle.
pub fn surface_points(puppet: &Puppet, pose: &[[f32; 2]], labels: &[u16], width: u32, height: u32) -> Vec<Option<SurfacePoint>> {
    let (w, h) = (width as usize, height as usize);
    let offsets = puppet.vertex_offsets();
    let mut out: Vec<Option<SurfacePoint>> = vec![None; w * h];
    for (l, layer) in puppet.layers.iter().enumerate() {
        for t in &layer.mesh.triangles {
            let corners = t.map(|i| (offsets[l] + i as usize) as u32);
            let at = corners.map(|v| pose[v as usize]);
            let span = |c: usize| {
                let lo = at.iter().map(|p| p[c]).fold(f32::INFINITY, f32::min);
                let hi = at.iter().map(|p| p[c]).fold(f32::NEG_INFINITY, f32::max);
                (lo - 0.5).floor().max(0.0) as usize..((hi - 0.5).ceil().max(-1.0) + 1.0) as usize
            };
            let (xs, ys) = (span(0), span(1));
            for y in ys.start..ys.end.min(h) {
                for x in xs.start..xs.end.min(w) {
                    let i = y * w + x;
                    if usize::from(labels[i]) != l || out[i].is_some() {
                        continue;
                    }
                    let Some(weights) = barycentric(at, [x as f32 + 0.5, y as f32 + 0.5]) else {
                        continue;
                    };
                    if weights.iter().all(|&b| b >= -1e-4) {
                        out[i] = Some(SurfacePoint {
                            layer: l as u16,
                            corners,
                            weights,
                        });
                    }
                }
            }
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
    fn each_pixel_is_bound_to_the_point_of_the_front_layer_drawn_at_its_centre() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let (w, h) = (puppet.width, puppet.height);
        let labels = LayerCoverage::new(&puppet).unwrap().labels(&rest, w, h).unwrap();
        let surface = surface_points(&puppet, &rest, &labels, w, h);
        let mut bound = 0;
        for (i, point) in surface.iter().enumerate() {
            let centre = [(i % w as usize) as f32 + 0.5, (i / w as usize) as f32 + 0.5];
            match point {
                Some(point) => {
                    bound += 1;
                    assert_eq!(point.layer, labels[i], "pixel {i} is bound to a layer not in front there");
                    let at = point.on(&rest);
                    assert!(
                        (at[0] - centre[0]).abs() < 1e-3 && (at[1] - centre[1]).abs() < 1e-3,
                        "pixel {i} bound at {at:?}"
                    );
                    assert!((point.weights.iter().sum::<f32>() - 1.0).abs() < 1e-4);
                }
                None => assert!(
                    labels[i] == NO_LAYER || is_outline(&labels, i, w as usize),
                    "pixel {i} inside a layer is unbound"
                ),
            }
        }
        let covered = labels.iter().filter(|&&l| l != NO_LAYER).count();
        assert!(bound as f64 > 0.95 * covered as f64, "{bound} of {covered} covered pixels bound");
        // Moved, the point goes with the pose: a shifted pose puts every bound point shifted.
        let shifted: Vec<[f32; 2]> = rest.iter().map(|p| [p[0] + 3.0, p[1] - 2.0]).collect();
        for point in surface.iter().flatten().take(50) {
            let (a, b) = (point.on(&rest), point.on(&shifted));
            assert!((b[0] - a[0] - 3.0).abs() < 1e-4 && (b[1] - a[1] + 2.0).abs() < 1e-4);
        }
    }

    /// Whether pixel `i` of a `w`-wide label image borders another label (an outline pixel,
    /// whose coverage may pass one half while its centre lies outside every triangle).
    fn is_outline(labels: &[u16], i: usize, w: usize) -> bool {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let h = (labels.len() / w) as i64;
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (qx, qy) = (x + dx, y + dy);
                !(0..w as i64).contains(&qx) || !(0..h).contains(&qy) || labels[(qy * w as i64 + qx) as usize] != labels[i]
            })
        })
    }

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
