//! The gated block activation of the correspondence network over plain slices: per image and
//! channel, the feature plane is instance-normalised (population variance), scaled and shifted
//! by the channel's affine, passed through a LeakyReLU, and multiplied by the sigmoid of the
//! matching gate plane. Layouts are Burn's: the block's convolution output `[B, 2C, H, W]` (the
//! first `C` channels features, the last `C` gates) in, `[B, C, H, W]` out. Planes are spread over
//! rayon's threads; the affine's gradients are summed per plane and then over images in image
//! order, so results do not depend on the thread count.

use rayon::prelude::*;

use super::conv_kernel::zeros;
use super::lanes::{exp, lane_sum};

/// The shape of one gated activation and its two constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gate {
    /// Images B.
    pub batch: usize,
    /// Output channels C (the input has 2C).
    pub channels: usize,
    /// Pixels per plane, H·W.
    pub pixels: usize,
    /// Added to the variance under the square root (Burn's `InstanceNorm::epsilon`).
    pub epsilon: f64,
    /// The LeakyReLU's slope below zero.
    pub slope: f32,
}

/// One plane's normalisation: its mean and 1/√(variance + ε).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlaneStats {
    mean: f32,
    inverse_deviation: f32,
}

/// What the backward pass returns: the gradients of the input `[B, 2C, H, W]`, of the scales
/// `[C]` and of the shifts `[C]`.
#[derive(Debug)]
pub struct GateGradients {
    /// Of the convolution output (features, then gates).
    pub input: Vec<f32>,
    /// Of the affine's scales γ.
    pub scale: Vec<f32>,
    /// Of the affine's shifts β.
    pub shift: Vec<f32>,
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + exp(-x))
}

impl Gate {
    /// The number of values in the input `[B, 2C, H, W]`.
    pub fn input_len(&self) -> usize {
        self.batch * 2 * self.channels * self.pixels
    }

    /// The mean and inverse deviation of one plane (sums in f64 over f32 blocks).
    fn stats(&self, x: &[f32]) -> PlaneStats {
        let n = x.len() as f64;
        let mean = (lane_sum(x, x, |v, _| v) / n) as f32;
        let variance = lane_sum(x, x, |v, _| (v - mean) * (v - mean)) / n;
        PlaneStats {
            mean,
            inverse_deviation: (1.0 / (variance + self.epsilon).sqrt()) as f32,
        }
    }

    /// The feature and gate planes of output plane `index` (image-major) in the input `h`.
    fn planes<'h>(&self, h: &'h [f32], index: usize) -> (&'h [f32], &'h [f32]) {
        let (image, channel) = (index / self.channels, index % self.channels);
        let p = self.pixels;
        let features = (image * 2 * self.channels + channel) * p;
        let gates = features + self.channels * p;
        (&h[features..][..p], &h[gates..][..p])
    }

    /// The activation of `h` `[B, 2C, H, W]` with scales `scale` and shifts `shift` `[C]`:
    /// `[B, C, H, W]`, and each plane's statistics for [`Self::backward`].
    pub fn forward(&self, h: &[f32], scale: &[f32], shift: &[f32]) -> (Vec<f32>, Vec<PlaneStats>) {
        let p = self.pixels;
        let mut y = zeros(self.batch * self.channels * p);
        let mut stats = vec![PlaneStats::default(); self.batch * self.channels];
        y.par_chunks_mut(p)
            .zip(stats.par_iter_mut())
            .enumerate()
            .for_each(|(index, (out, stat))| {
                let (features, gates) = self.planes(h, index);
                let channel = index % self.channels;
                *stat = self.stats(features);
                let (gamma, beta) = (scale[channel], shift[channel]);
                // Indexed over slices of one length, with the constants in locals (read through
                // `stat` or `self` in the loop, the writes to `out` might alias them, and the
                // loop stays scalar): the form the compiler vectorises.
                let PlaneStats { mean, inverse_deviation } = *stat;
                let slope = self.slope;
                let (out, features, gates) = (&mut out[..p], &features[..p], &gates[..p]);
                for i in 0..p {
                    let a = gamma * (features[i] - mean) * inverse_deviation + beta;
                    let l = if a > 0.0 { a } else { slope * a };
                    out[i] = l * sigmoid(gates[i]);
                }
            });
        (y, stats)
    }

    /// The gradients for `upstream` `[B, C, H, W]` at the input `h`, with the forward pass's
    /// `stats`.
    pub fn backward(&self, h: &[f32], scale: &[f32], shift: &[f32], stats: &[PlaneStats], upstream: &[f32]) -> GateGradients {
        let (c, p) = (self.channels, self.pixels);
        let mut input = zeros(self.input_len());
        let sums: Vec<(f64, f64)> = input
            .par_chunks_mut(2 * c * p)
            .enumerate()
            .flat_map_iter(|(image, dh)| {
                let (d_features, d_gates) = dh.split_at_mut(c * p);
                d_features
                    .par_chunks_mut(p)
                    .zip(d_gates.par_chunks_mut(p))
                    .enumerate()
                    .map(|(channel, (dx, dg))| {
                        let index = image * c + channel;
                        self.plane_backward(
                            index,
                            h,
                            (scale[channel], shift[channel]),
                            stats[index],
                            &upstream[index * p..][..p],
                            (dx, dg),
                        )
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut d_scale = vec![0f32; c];
        let mut d_shift = vec![0f32; c];
        for (channel, (ds, db)) in d_scale.iter_mut().zip(&mut d_shift).enumerate() {
            let (mut sx, mut sa) = (0f64, 0f64);
            for image in 0..self.batch {
                let (da, da_xhat) = sums[image * c + channel];
                sa += da;
                sx += da_xhat;
            }
            *ds = sx as f32;
            *db = sa as f32;
        }
        GateGradients {
            input,
            scale: d_scale,
            shift: d_shift,
        }
    }

    /// One plane's backward pass: writes the feature and gate gradients and returns the plane's
    /// `(Σ ∂L/∂a, Σ ∂L/∂a · x̂)`, where `a = γ·x̂ + β` — the shift's and the scale's gradients.
    fn plane_backward(
        &self,
        index: usize,
        h: &[f32],
        (gamma, beta): (f32, f32),
        stat: PlaneStats,
        upstream: &[f32],
        (dx, dg): (&mut [f32], &mut [f32]),
    ) -> (f64, f64) {
        let (features, gates) = self.planes(h, index);
        let PlaneStats { mean, inverse_deviation } = stat;
        let normalised = |x: f32| (x - mean) * inverse_deviation;
        // First pass: ∂L/∂a into dx, the gate gradient into dg (indexed over slices of one
        // length, constants in locals, so it vectorises).
        let (p, slope) = (self.pixels, self.slope);
        let (dx, dg, features, gates, upstream) = (&mut dx[..p], &mut dg[..p], &features[..p], &gates[..p], &upstream[..p]);
        for i in 0..p {
            let a = gamma * normalised(features[i]) + beta;
            let (l, dl_da) = if a > 0.0 { (a, 1.0) } else { (slope * a, slope) };
            let s = sigmoid(gates[i]);
            dg[i] = upstream[i] * l * s * (1.0 - s);
            dx[i] = upstream[i] * s * dl_da;
        }
        let sum_da = lane_sum(dx, dx, |da, _| da);
        let sum_da_xhat = lane_sum(dx, features, |da, x| da * normalised(x));
        // Second pass: through the normalisation, dx = σ⁻¹·γ·(∂L/∂a − mean ∂L/∂a − x̂·mean(∂L/∂a·x̂)).
        let n = self.pixels as f64;
        let (mean_da, mean_da_xhat) = ((sum_da / n) as f32, (sum_da_xhat / n) as f32);
        let factor = gamma * inverse_deviation;
        for (d, &x) in dx.iter_mut().zip(features) {
            *d = factor * (*d - mean_da - normalised(x) * mean_da_xhat);
        }
        (sum_da, sum_da_xhat)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gate() -> Gate {
        Gate {
            batch: 2,
            channels: 3,
            pixels: 12,
            epsilon: 1e-5,
            slope: 0.2,
        }
    }

    fn input(g: &Gate) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let h = (0..g.input_len()).map(|i| ((i * 37 % 101) as f32 / 50.0 - 1.0) * 1.5).collect();
        let scale = vec![0.8, 1.3, -0.6];
        let shift = vec![0.1, -0.4, 0.3];
        (h, scale, shift)
    }

    #[test]
    fn the_sigmoid_saturates() {
        assert!((0.0..1e-38).contains(&sigmoid(-1000.0)) && sigmoid(1000.0) == 1.0);
    }

    /// A weighted sum of the outputs, in f64, as the loss of the finite differences.
    fn loss(g: &Gate, h: &[f32], scale: &[f32], shift: &[f32], weights: &[f32]) -> f64 {
        let (y, _) = g.forward(h, scale, shift);
        y.iter().zip(weights).map(|(&a, &w)| f64::from(a) * f64::from(w)).sum()
    }

    #[test]
    fn the_forward_pass_matches_the_definition() {
        let g = gate();
        let (h, scale, shift) = input(&g);
        let (y, _) = g.forward(&h, &scale, &shift);
        let p = g.pixels;
        for image in 0..g.batch {
            for c in 0..g.channels {
                let x = &h[(image * 2 * g.channels + c) * p..][..p];
                let gates = &h[(image * 2 * g.channels + g.channels + c) * p..][..p];
                let mean = x.iter().sum::<f32>() / p as f32;
                let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / p as f32;
                for k in 0..p {
                    let a = scale[c] * (x[k] - mean) / (var + 1e-5).sqrt() + shift[c];
                    let l = if a > 0.0 { a } else { 0.2 * a };
                    let expected = l / (1.0 + (-gates[k]).exp());
                    let got = y[(image * g.channels + c) * p + k];
                    assert!((got - expected).abs() < 1e-5, "{got} {expected}");
                }
            }
        }
    }

    /// Every gradient against central differences of a weighted sum of the outputs.
    #[test]
    fn gradients_match_finite_differences() {
        let g = gate();
        let (h, scale, shift) = input(&g);
        let weights: Vec<f32> = (0..g.batch * g.channels * g.pixels)
            .map(|i| ((i * 13 % 29) as f32 / 14.0) - 1.0)
            .collect();
        let (_, stats) = g.forward(&h, &scale, &shift);
        let grads = g.backward(&h, &scale, &shift, &stats, &weights);
        let step = 2e-3f32;
        // The central difference of the loss in entry `i` of input `which` (0 = h, 1 = scale,
        // 2 = shift), against the analytic gradient.
        let check = |which: usize, i: usize, analytic: f32| {
            let at = |delta: f32| {
                let mut inputs = [h.clone(), scale.clone(), shift.clone()];
                inputs[which][i] += delta;
                loss(&g, &inputs[0], &inputs[1], &inputs[2], &weights)
            };
            let numeric = (at(step) - at(-step)) / (2.0 * f64::from(step));
            let tolerance = 2e-3 + 1e-2 * numeric.abs();
            assert!(
                (f64::from(analytic) - numeric).abs() < tolerance,
                "input {which} entry {i}: {analytic} vs {numeric}"
            );
        };
        for i in (0..h.len()).step_by(5) {
            check(0, i, grads.input[i]);
        }
        for c in 0..g.channels {
            check(1, c, grads.scale[c]);
            check(2, c, grads.shift[c]);
        }
    }

    /// The same values on one thread and on four.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let g = Gate { batch: 3, ..gate() };
        let (h, scale, shift) = input(&g);
        let upstream: Vec<f32> = (0..g.batch * g.channels * g.pixels).map(|i| (i % 7) as f32 - 3.0).collect();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| {
                let (y, stats) = g.forward(&h, &scale, &shift);
                let grads = g.backward(&h, &scale, &shift, &stats, &upstream);
                (y, grads.input, grads.scale, grads.shift)
            })
        };
        assert_eq!(run(1), run(4));
    }
}
