//! Strided, zero-padded 2-D convolution over plain slices — the encoder's hot layers (issue 5's
//! speed goal). Layouts are Burn's: activations `[B, C, H, W]`, weights `[O, C, K, K]`, bias
//! `[O]`, all row-major. Each image is unfolded (im2col) into a `[C·K·K, Ho·Wo]` patch matrix
//! and multiplied by the weights with faer; images are spread over rayon's threads. Gradient
//! sums over the batch are taken per image and added in image order, so results do not depend
//! on the thread count or on scheduling (training stays reproducible).

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;

/// The shape of one convolution: input `channels × height × width`, `out_channels` square
/// kernels of side `kernel`, moved by `stride`, over an input padded with `padding` zeros.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConvGeometry {
    /// Input channels C.
    pub channels: usize,
    /// Input height H.
    pub height: usize,
    /// Input width W.
    pub width: usize,
    /// Output channels O.
    pub out_channels: usize,
    /// Kernel side K.
    pub kernel: usize,
    /// Stride, both axes.
    pub stride: usize,
    /// Zero padding on every side.
    pub padding: usize,
}

/// The gradients of a convolution's loss w.r.t. its input (if asked for), weights and bias.
#[derive(Debug)]
pub struct ConvGradients {
    /// `[B, C, H, W]`, or `None` when the input needs no gradient (the network's input image).
    pub input: Option<Vec<f32>>,
    /// `[O, C, K, K]`.
    pub weight: Vec<f32>,
    /// `[O]`.
    pub bias: Vec<f32>,
}

impl ConvGeometry {
    /// Output height Ho.
    pub fn out_height(&self) -> usize {
        (self.height + 2 * self.padding - self.kernel) / self.stride + 1
    }

    /// Output width Wo.
    pub fn out_width(&self) -> usize {
        (self.width + 2 * self.padding - self.kernel) / self.stride + 1
    }

    /// Values in one input image.
    pub fn input_len(&self) -> usize {
        self.channels * self.height * self.width
    }

    /// Values in one output image.
    pub fn output_len(&self) -> usize {
        self.out_channels * self.out_pixels()
    }

    /// Values in the weight tensor.
    pub fn weight_len(&self) -> usize {
        self.out_channels * self.patch()
    }

    /// Rows of the patch matrix: C·K·K.
    fn patch(&self) -> usize {
        self.channels * self.kernel * self.kernel
    }

    fn out_pixels(&self) -> usize {
        self.out_height() * self.out_width()
    }

    /// The input index that output pixel `out` reads at kernel offset `offset` along an axis of
    /// `size` input pixels, or `None` in the padding.
    fn source(&self, offset: usize, size: usize, out: usize) -> Option<usize> {
        (out * self.stride + offset).checked_sub(self.padding).filter(|&i| i < size)
    }

    /// The output pixels `lo..hi` (of `outputs`) that read inside an axis of `size` input pixels
    /// at kernel offset `offset`; the others read the padding.
    fn inside(&self, offset: usize, size: usize, outputs: usize) -> (usize, usize) {
        let lo = self.padding.saturating_sub(offset).div_ceil(self.stride).min(outputs);
        let hi = (size + self.padding)
            .checked_sub(offset)
            .map_or(0, |end| end.div_ceil(self.stride))
            .clamp(lo, outputs);
        (lo, hi)
    }

    /// Unfolds one image `x` `[C, H, W]` into `col` `[C·K·K, Ho·Wo]` (row (c, i, j) holds the
    /// input under kernel tap (i, j) of channel c at every output pixel).
    fn im2col(&self, x: &[f32], col: &mut [f32]) {
        let (ho, wo, k) = (self.out_height(), self.out_width(), self.kernel);
        for (row, dst) in col.chunks_exact_mut(ho * wo).enumerate() {
            let (c, i, j) = (row / (k * k), row / k % k, row % k);
            let plane = &x[c * self.height * self.width..][..self.height * self.width];
            for (oy, line) in dst.chunks_exact_mut(wo).enumerate() {
                let Some(y) = self.source(i, self.height, oy) else {
                    line.fill(0.0);
                    continue;
                };
                let src = &plane[y * self.width..][..self.width];
                let (lo, hi) = self.inside(j, self.width, wo);
                line[..lo].fill(0.0);
                line[hi..].fill(0.0);
                let first = lo * self.stride + j - self.padding;
                for (v, &x) in line[lo..hi].iter_mut().zip(src[first..].iter().step_by(self.stride)) {
                    *v = x;
                }
            }
        }
    }

    /// The adjoint of [`Self::im2col`]: adds each entry of `col` to the input pixel it came from.
    fn col2im(&self, col: &[f32], dx: &mut [f32]) {
        let (ho, wo, k) = (self.out_height(), self.out_width(), self.kernel);
        for (row, src) in col.chunks_exact(ho * wo).enumerate() {
            let (c, i, j) = (row / (k * k), row / k % k, row % k);
            let plane = &mut dx[c * self.height * self.width..][..self.height * self.width];
            for (oy, line) in src.chunks_exact(wo).enumerate() {
                let Some(y) = self.source(i, self.height, oy) else { continue };
                let dst = &mut plane[y * self.width..][..self.width];
                let (lo, hi) = self.inside(j, self.width, wo);
                let first = lo * self.stride + j - self.padding;
                for (d, &v) in dst[first..].iter_mut().step_by(self.stride).zip(&line[lo..hi]) {
                    *d += v;
                }
            }
        }
    }

    /// `Y = W·col + b` for a batch `x` `[B, C, H, W]`; returns `[B, O, Ho, Wo]`.
    pub fn forward(&self, x: &[f32], weight: &[f32], bias: &[f32]) -> Vec<f32> {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let mut y = vec![0f32; x.len() / self.input_len() * self.output_len()];
        y.par_chunks_mut(self.output_len())
            .zip(x.par_chunks(self.input_len()))
            .for_each_init(
                || vec![0f32; n * p],
                |col, (yb, xb)| {
                    self.im2col(xb, col);
                    let w = MatRef::from_row_major_slice(weight, o, n);
                    let cols = MatRef::from_row_major_slice(col, n, p);
                    matmul(MatMut::from_row_major_slice_mut(yb, o, p), Accum::Replace, w, cols, 1.0, Par::Seq);
                    for (row, &b) in yb.chunks_exact_mut(p).zip(bias) {
                        row.iter_mut().for_each(|v| *v += b);
                    }
                },
            );
        y
    }

    /// Gradients for upstream `dy` `[B, O, Ho, Wo]` at input `x` and `weight`: `dW = Σ dY·colᵀ`,
    /// `db = Σ dY`, and (if `input`) `dx = col2im(Wᵀ·dY)`.
    pub fn backward(&self, x: &[f32], weight: &[f32], dy: &[f32], input: bool) -> ConvGradients {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let batch = x.len() / self.input_len();
        // One partial dW (and db) per image, summed in image order below.
        let mut parts = vec![0f32; batch * (self.weight_len() + o)];
        parts
            .par_chunks_mut(self.weight_len() + o)
            .zip(x.par_chunks(self.input_len()))
            .zip(dy.par_chunks(self.output_len()))
            .for_each_init(
                || vec![0f32; n * p],
                |col, ((part, xb), dyb)| {
                    self.im2col(xb, col);
                    let (dw, db) = part.split_at_mut(self.weight_len());
                    let g = MatRef::from_row_major_slice(dyb, o, p);
                    let cols_t = MatRef::from_row_major_slice(col, n, p).transpose();
                    matmul(MatMut::from_row_major_slice_mut(dw, o, n), Accum::Replace, g, cols_t, 1.0, Par::Seq);
                    for (d, row) in db.iter_mut().zip(dyb.chunks_exact(p)) {
                        *d = row.iter().sum();
                    }
                },
            );
        let mut sums = vec![0f32; self.weight_len() + o];
        for part in parts.chunks_exact(self.weight_len() + o) {
            sums.iter_mut().zip(part).for_each(|(s, v)| *s += v);
        }
        let bias = sums.split_off(self.weight_len());
        let input = input.then(|| {
            let mut dx = vec![0f32; x.len()];
            dx.par_chunks_mut(self.input_len())
                .zip(dy.par_chunks(self.output_len()))
                .for_each_init(
                    || vec![0f32; n * p],
                    |dcol, (dxb, dyb)| {
                        let w_t = MatRef::from_row_major_slice(weight, o, n).transpose();
                        let g = MatRef::from_row_major_slice(dyb, o, p);
                        matmul(MatMut::from_row_major_slice_mut(dcol, n, p), Accum::Replace, w_t, g, 1.0, Par::Seq);
                        self.col2im(dcol, dxb);
                    },
                );
            dx
        });
        ConvGradients { input, weight: sums, bias }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ConvGeometry {
        ConvGeometry {
            channels: 3,
            height: 9,
            width: 7,
            out_channels: 4,
            kernel: 5,
            stride: 2,
            padding: 2,
        }
    }

    /// Deterministic values in [-1, 1).
    fn values(n: usize, seed: u32) -> Vec<f32> {
        (0..n as u32)
            .map(|i| ((i.wrapping_mul(2654435761) ^ seed.wrapping_mul(40503)) % 2000) as f32 / 1000.0 - 1.0)
            .collect()
    }

    /// The convolution by its definition, in f64.
    fn direct(g: &ConvGeometry, x: &[f32], w: &[f32], b: &[f32]) -> Vec<f64> {
        let (ho, wo, k) = (g.out_height(), g.out_width(), g.kernel);
        let batch = x.len() / g.input_len();
        let mut y = vec![0f64; batch * g.output_len()];
        for bi in 0..batch {
            for o in 0..g.out_channels {
                for oy in 0..ho {
                    for ox in 0..wo {
                        let mut s = b[o] as f64;
                        for c in 0..g.channels {
                            for i in 0..k {
                                for j in 0..k {
                                    let (yy, xx) = (oy * g.stride + i, ox * g.stride + j);
                                    if yy < g.padding || xx < g.padding || yy - g.padding >= g.height || xx - g.padding >= g.width {
                                        continue;
                                    }
                                    let xi = ((bi * g.channels + c) * g.height + yy - g.padding) * g.width + xx - g.padding;
                                    s += x[xi] as f64 * w[((o * g.channels + c) * k + i) * k + j] as f64;
                                }
                            }
                        }
                        y[((bi * g.out_channels + o) * ho + oy) * wo + ox] = s;
                    }
                }
            }
        }
        y
    }

    #[test]
    fn forward_matches_the_definition_including_the_padded_border() {
        assert_eq!((geometry().out_height(), geometry().out_width()), (5, 4));
        let other = ConvGeometry {
            kernel: 3,
            stride: 1,
            padding: 1,
            ..geometry()
        };
        let wide = ConvGeometry {
            kernel: 3,
            stride: 3,
            padding: 0,
            ..geometry()
        };
        for g in [geometry(), other, wide] {
            let (x, w, b) = (values(2 * g.input_len(), 1), values(g.weight_len(), 2), values(4, 3));
            let got = g.forward(&x, &w, &b);
            let want = direct(&g, &x, &w, &b);
            let worst = got.iter().zip(&want).map(|(a, b)| (*a as f64 - b).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-5, "{g:?}: max error {worst}");
        }
    }

    #[test]
    fn gradients_match_central_differences_of_a_weighted_sum() {
        let g = geometry();
        let (x, w, b) = (values(2 * g.input_len(), 4), values(g.weight_len(), 5), values(4, 6));
        let upstream = values(2 * g.output_len(), 7);
        let loss = |x: &[f32], w: &[f32], b: &[f32]| -> f64 { direct(&g, x, w, b).iter().zip(&upstream).map(|(y, u)| y * *u as f64).sum() };
        let grads = g.backward(&x, &w, &upstream, true);
        let dx = grads.input.as_ref().expect("asked for");
        let h = 1e-2f32; // the loss is linear in each argument, so only rounding limits h
        let fd = |f: &dyn Fn(f32) -> f64| (f(h) - f(-h)) / (2.0 * h as f64);
        let mut worst = 0f64;
        for i in (0..x.len()).step_by(5) {
            let want = fd(&|d| {
                let mut x = x.clone();
                x[i] += d;
                loss(&x, &w, &b)
            });
            worst = worst.max((want - dx[i] as f64).abs());
        }
        for i in (0..w.len()).step_by(3) {
            let want = fd(&|d| {
                let mut w = w.clone();
                w[i] += d;
                loss(&x, &w, &b)
            });
            worst = worst.max((want - grads.weight[i] as f64).abs());
        }
        for i in 0..b.len() {
            let want = fd(&|d| {
                let mut b = b.clone();
                b[i] += d;
                loss(&x, &w, &b)
            });
            worst = worst.max((want - grads.bias[i] as f64).abs());
        }
        assert!(worst < 1e-3, "max error {worst}");
        assert!(g.backward(&x, &w, &upstream, false).input.is_none());
    }
}
