//! Strided, zero-padded 2-D convolution over plain slices — the encoder's hot layers (issue 5's
//! speed goal). Layouts are Burn's: activations `[B, C, H, W]`, weights `[O, C, K, K]`, bias
//! `[O]`, all row-major. Each image is unfolded (im2col) into a `[C·K·K, Ho·Wo]` patch matrix
//! and multiplied by the weights with faer; images are spread over rayon's threads. Gradient
//! sums over the batch are taken per image and added in image order, so results do not depend
//! on the thread count or on scheduling (training stays reproducible).

use std::cell::Cell;

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;

/// The shape of one convolution: input `channels × height × width`, `out_channels` square
/// kernels of side `kernel`, moved by `stride`, over an input padded with `padding` zeros. With
/// `upsample` > 1 the convolution reads its input enlarged that many times by nearest neighbour
/// (each pixel an `upsample × upsample` block; a U-Net's way up) without the enlarged image
/// being made, and its input gradient sums each block back into its pixel (the U-Net's 3×3 case
/// runs faster in `conv_phases`).
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
    /// The nearest-neighbour enlargement of the input the kernels see (1: none).
    pub upsample: usize,
}

impl ConvGeometry {
    /// Output height Ho.
    pub fn out_height(&self) -> usize {
        (self.seen_height() + 2 * self.padding - self.kernel) / self.stride + 1
    }

    /// Output width Wo.
    pub fn out_width(&self) -> usize {
        (self.seen_width() + 2 * self.padding - self.kernel) / self.stride + 1
    }

    /// The height of the (enlarged) input the kernels move over.
    fn seen_height(&self) -> usize {
        self.height * self.upsample
    }

    /// The width of the (enlarged) input the kernels move over.
    fn seen_width(&self) -> usize {
        self.width * self.upsample
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

    /// The (enlarged) input index that output pixel `out` reads at kernel offset `offset` along
    /// an axis of `size` such pixels, or `None` in the padding.
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
        for (row, dst) in col.chunks_exact_mut(self.out_pixels()).enumerate() {
            self.patch_row(x, row, dst);
        }
    }

    /// Row `row` = (c, i, j) of the patch matrix of the images `x` `[G, C, H, W]` side by side:
    /// `dst` `[G·Ho·Wo]` gets the input under kernel tap (i, j) of channel c.
    fn patch_row(&self, x: &[f32], row: usize, dst: &mut [f32]) {
        let (wo, k) = (self.out_width(), self.kernel);
        let (c, i, j) = (row / (k * k), row / k % k, row % k);
        let (lo, hi) = self.inside(j, self.seen_width(), wo);
        let plane_len = self.height * self.width;
        for (image, dst) in dst.chunks_exact_mut(self.out_pixels()).enumerate() {
            let plane = &x[(image * self.channels + c) * plane_len..][..plane_len];
            for (oy, line) in dst.chunks_exact_mut(wo).enumerate() {
                let Some(y) = self.source(i, self.seen_height(), oy) else {
                    line.fill(0.0);
                    continue;
                };
                let src = &plane[y / self.upsample * self.width..][..self.width];
                line[..lo].fill(0.0);
                line[hi..].fill(0.0);
                let first = lo * self.stride + j - self.padding;
                match (self.upsample, self.stride) {
                    (1, stride) => gather(&mut line[lo..hi], &src[first..], stride),
                    (upsample, stride) => {
                        for (k, v) in line[lo..hi].iter_mut().enumerate() {
                            *v = src[(first + k * stride) / upsample];
                        }
                    }
                }
            }
        }
    }

    /// The adjoint of [`Self::im2col`]: adds each entry of `col` to the input pixel it came from.
    fn col2im(&self, col: &[f32], dx: &mut [f32]) {
        let (wo, k) = (self.out_width(), self.kernel);
        for (row, src) in col.chunks_exact(self.out_pixels()).enumerate() {
            let (c, i, j) = (row / (k * k), row / k % k, row % k);
            let plane = &mut dx[c * self.height * self.width..][..self.height * self.width];
            let (lo, hi) = self.inside(j, self.seen_width(), wo);
            for (oy, line) in src.chunks_exact(wo).enumerate() {
                let Some(y) = self.source(i, self.seen_height(), oy) else {
                    continue;
                };
                let dst = &mut plane[y / self.upsample * self.width..][..self.width];
                let first = lo * self.stride + j - self.padding;
                match (self.upsample, self.stride) {
                    (1, 1) => {
                        // Contiguous: the form that vectorises (a step-by iterator does not).
                        let line = &line[lo..hi];
                        for (d, &v) in dst[first..][..line.len()].iter_mut().zip(line) {
                            *d += v;
                        }
                    }
                    (1, stride) => {
                        for (d, &v) in dst[first..].iter_mut().step_by(stride).zip(&line[lo..hi]) {
                            *d += v;
                        }
                    }
                    (upsample, stride) => {
                        for (k, &v) in line[lo..hi].iter().enumerate() {
                            dst[(first + k * stride) / upsample] += v;
                        }
                    }
                }
            }
        }
    }

    /// Whether a layer has more output channels than pixels per image, so one partial weight
    /// gradient per image (`B·O·C·K·K` values) would outweigh the batch's patch matrices
    /// (`B·C·K·K·Ho·Wo`): its weight gradient then puts the patch matrices side by side (the deep
    /// layers of pix2pix's networks: a few pixels, millions of weights).
    fn side_by_side(&self) -> bool {
        self.out_channels > self.out_pixels()
    }

    /// Images per side-by-side group, so the patch matrix stays under [`MAX_PATCH_VALUES`].
    fn group(&self) -> usize {
        (MAX_PATCH_VALUES / (self.patch() * self.out_pixels()).max(1)).max(1)
    }

    /// The side-by-side patch matrix of the images `x` `[G, C, H, W]`, rows filled in parallel.
    fn unfold(&self, x: &[f32]) -> Vec<f32> {
        let columns = x.len() / self.input_len() * self.out_pixels();
        let mut col = zeros(self.patch() * columns);
        col.par_chunks_mut(columns)
            .enumerate()
            .for_each(|(row, dst)| self.patch_row(x, row, dst));
        col
    }

    /// `Y = W·col + b` for a batch `x` `[B, C, H, W]`; returns `[B, O, Ho, Wo]`.
    pub fn forward(&self, x: &[f32], weight: &[f32], bias: &[f32]) -> Vec<f32> {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let mut y = zeros(x.len() / self.input_len() * self.output_len());
        y.par_chunks_mut(self.output_len())
            .zip(x.par_chunks(self.input_len()))
            .for_each(|(yb, xb)| {
                with_patches(n * p, |col| {
                    self.im2col(xb, col);
                    let w = MatRef::from_row_major_slice(weight, o, n);
                    let cols = MatRef::from_row_major_slice(col, n, p);
                    matmul(MatMut::from_row_major_slice_mut(yb, o, p), Accum::Replace, w, cols, 1.0, Par::Seq);
                });
                for (row, &b) in yb.chunks_exact_mut(p).zip(bias) {
                    row.iter_mut().for_each(|v| *v += b);
                }
            });
        y
    }

    /// The weight and bias gradients for upstream `dy` `[B, O, Ho, Wo]` at input `x`:
    /// `dW = Σ dY·colᵀ` `[O, C, K, K]` and `db = Σ dY` `[O]`.
    pub fn weight_gradient(&self, x: &[f32], dy: &[f32]) -> (Vec<f32>, Vec<f32>) {
        if self.side_by_side() {
            self.weight_gradient_side_by_side(x, dy, self.group())
        } else {
            self.weight_gradient_per_image(x, dy)
        }
    }

    /// [`Self::weight_gradient`] as one partial `[O, C·K·K]` per image, each image's unfolding
    /// and product on its own thread, summed in image order.
    fn weight_gradient_per_image(&self, x: &[f32], dy: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let batch = x.len() / self.input_len();
        let mut parts = zeros(batch * (self.weight_len() + o));
        parts
            .par_chunks_mut(self.weight_len() + o)
            .zip(x.par_chunks(self.input_len()))
            .zip(dy.par_chunks(self.output_len()))
            .for_each(|((part, xb), dyb)| {
                let (dw, db) = part.split_at_mut(self.weight_len());
                with_patches(n * p, |col| {
                    self.im2col(xb, col);
                    let g = MatRef::from_row_major_slice(dyb, o, p);
                    let cols_t = MatRef::from_row_major_slice(col, n, p).transpose();
                    matmul(MatMut::from_row_major_slice_mut(dw, o, n), Accum::Replace, g, cols_t, 1.0, Par::Seq);
                });
                for (d, row) in db.iter_mut().zip(dyb.chunks_exact(p)) {
                    *d = row.iter().sum();
                }
            });
        let mut sums = vec![0f32; self.weight_len() + o];
        for part in parts.chunks_exact(self.weight_len() + o) {
            sums.iter_mut().zip(part).for_each(|(s, v)| *s += v);
        }
        let bias = sums.split_off(self.weight_len());
        (sums, bias)
    }

    /// [`Self::weight_gradient`] with the batch's patch matrices side by side: one product whose
    /// inner dimension runs over every image (a partial per image would write and sum the whole
    /// weight gradient once per image).
    fn weight_gradient_side_by_side(&self, x: &[f32], dy: &[f32], group: usize) -> (Vec<f32>, Vec<f32>) {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let mut dw = vec![0f32; self.weight_len()];
        let mut db = vec![0f32; o];
        let groups = x.chunks(group * self.input_len()).zip(dy.chunks(group * self.output_len()));
        for (k, (xg, dyg)) in groups.enumerate() {
            let columns = xg.len() / self.input_len() * p;
            let col = self.unfold(xg);
            let g = by_channel(dyg, o, p);
            product(
                MatMut::from_row_major_slice_mut(&mut dw, o, n),
                MatRef::from_row_major_slice(&g, o, columns),
                MatRef::from_row_major_slice(&col, n, columns).transpose(),
                if k == 0 { Accum::Replace } else { Accum::Add },
            );
            db.iter_mut()
                .zip(g.chunks_exact(columns))
                .for_each(|(d, row)| *d += row.iter().sum::<f32>());
        }
        (dw, db)
    }

    /// The input gradient for upstream `dy` `[B, O, Ho, Wo]` and `weight`: `dx = col2im(Wᵀ·dY)`
    /// `[B, C, H, W]` — also the forward pass of the transposed convolution with these weights.
    pub fn input_gradient(&self, weight: &[f32], dy: &[f32]) -> Vec<f32> {
        let (o, p, n) = (self.out_channels, self.out_pixels(), self.patch());
        let mut dx = zeros(dy.len() / self.output_len() * self.input_len());
        dx.par_chunks_mut(self.input_len())
            .zip(dy.par_chunks(self.output_len()))
            .for_each(|(dxb, dyb)| {
                with_patches(n * p, |dcol| {
                    let w_t = MatRef::from_row_major_slice(weight, o, n).transpose();
                    let g = MatRef::from_row_major_slice(dyb, o, p);
                    matmul(MatMut::from_row_major_slice_mut(dcol, n, p), Accum::Replace, w_t, g, 1.0, Par::Seq);
                    self.col2im(dcol, dxb);
                })
            });
        dx
    }
}

thread_local! {
    /// This thread's patch matrix, kept between calls (see [`with_patches`]).
    static PATCHES: Cell<Vec<f32>> = const { Cell::new(Vec::new()) };
}

/// Runs `f` on a patch matrix of `len` values lent by this thread's buffer. Every user
/// overwrites all of it (the unfolding writes the padding's zeros too; the products replace), so
/// the buffer is neither cleared nor freed between calls: a fresh zeroed matrix per image and call
/// cost a large share of a training step in page faults and memset (benches/README.md "parts").
/// A thread keeps the largest matrix it has lent, one image's worth. A nested call (none today)
/// would find the buffer taken and allocate its own.
fn with_patches<R>(len: usize, f: impl FnOnce(&mut [f32]) -> R) -> R {
    let mut buffer = PATCHES.take();
    if buffer.len() < len {
        buffer.resize(len, 0.0);
    }
    let result = f(&mut buffer[..len]);
    PATCHES.set(buffer);
    result
}

/// `len` zeros written by rayon's threads: a large buffer zeroed on the calling thread alone
/// (page faults and memset) left the other core idle for a share of a training step
/// (benches/README.md "parts").
pub fn zeros(len: usize) -> Vec<f32> {
    let mut values = Vec::with_capacity(len);
    values.par_extend(rayon::iter::repeat_n(0f32, len));
    values
}

/// The most values a patch matrix of several images may hold (64 MiB of f32): a larger batch is
/// unfolded in groups of images.
const MAX_PATCH_VALUES: usize = 1 << 24;

/// Output columns (else rows) per sequential block of [`product`].
const BLOCK_COLUMNS: usize = 64;
/// Output rows per sequential block of [`product`] when it is too narrow to split by columns.
const BLOCK_ROWS: usize = 48;

/// `dst = lhs·rhs` (or `+=`), in fixed blocks of `dst`'s columns (or, when it is narrow, rows)
/// spread over rayon's threads. Each block is one sequential product over the whole inner
/// dimension, and the blocks depend only on the shapes, so the result does not depend on the
/// thread count.
fn product(dst: MatMut<'_, f32>, lhs: MatRef<'_, f32>, rhs: MatRef<'_, f32>, accum: Accum) {
    let (rows, cols) = (dst.nrows(), dst.ncols());
    if cols >= 2 * BLOCK_COLUMNS {
        let mid = (cols / BLOCK_COLUMNS).div_ceil(2) * BLOCK_COLUMNS;
        let (left, right) = dst.split_at_col_mut(mid);
        let (rhs_left, rhs_right) = rhs.split_at_col(mid);
        rayon::join(|| product(left, lhs, rhs_left, accum), || product(right, lhs, rhs_right, accum));
    } else if rows >= 2 * BLOCK_ROWS {
        let mid = (rows / BLOCK_ROWS).div_ceil(2) * BLOCK_ROWS;
        let (top, bottom) = dst.split_at_row_mut(mid);
        let (lhs_top, lhs_bottom) = lhs.split_at_row(mid);
        rayon::join(|| product(top, lhs_top, rhs, accum), || product(bottom, lhs_bottom, rhs, accum));
    } else {
        matmul(dst, accum, lhs, rhs, 1.0, Par::Seq);
    }
}

/// `[G, O, P]` → `[O, G·P]`: each channel's pixels of every image in one row.
fn by_channel(values: &[f32], channels: usize, pixels: usize) -> Vec<f32> {
    let images = values.len() / (channels * pixels);
    let mut out = zeros(values.len());
    out.par_chunks_mut(images * pixels).enumerate().for_each(|(channel, row)| {
        for (image, dst) in row.chunks_exact_mut(pixels).enumerate() {
            dst.copy_from_slice(&values[(image * channels + channel) * pixels..][..pixels]);
        }
    });
    out
}

/// `dst[k] = src[k·stride]`: one line of a patch row. The common strides get loops whose bounds
/// the compiler can see, so it drops the bounds checks and vectorises the copy (the generic
/// `step_by` loop was a quarter of an appearance training step).
fn gather(dst: &mut [f32], src: &[f32], stride: usize) {
    fn strided<const S: usize>(dst: &mut [f32], src: &[f32]) {
        let src = &src[..(dst.len().max(1) - 1) * S + 1];
        for (k, v) in dst.iter_mut().enumerate() {
            *v = src[k * S];
        }
    }
    match stride {
        _ if dst.is_empty() => {}
        1 => dst.copy_from_slice(&src[..dst.len()]),
        2 => strided::<2>(dst, src),
        _ => dst.iter_mut().zip(src.iter().step_by(stride)).for_each(|(v, &x)| *v = x),
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
            upsample: 1,
        }
    }

    /// A 3×3 convolution over the input doubled by nearest neighbour (the U-Net's way up).
    fn doubled() -> ConvGeometry {
        ConvGeometry {
            kernel: 3,
            stride: 1,
            padding: 1,
            upsample: 2,
            ..geometry()
        }
    }

    /// An enlargement and a stride the fast paths do not take.
    fn tripled() -> ConvGeometry {
        ConvGeometry { upsample: 3, ..geometry() }
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
                                    let (seen_height, seen_width) = (g.height * g.upsample, g.width * g.upsample);
                                    if yy < g.padding || xx < g.padding || yy - g.padding >= seen_height || xx - g.padding >= seen_width {
                                        continue;
                                    }
                                    let (sy, sx) = ((yy - g.padding) / g.upsample, (xx - g.padding) / g.upsample);
                                    let xi = ((bi * g.channels + c) * g.height + sy) * g.width + sx;
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
        assert_eq!((doubled().out_height(), doubled().out_width()), (18, 14));
        for g in [geometry(), other, wide, doubled(), tripled()] {
            let (x, w, b) = (values(2 * g.input_len(), 1), values(g.weight_len(), 2), values(4, 3));
            let got = g.forward(&x, &w, &b);
            let want = direct(&g, &x, &w, &b);
            let worst = got.iter().zip(&want).map(|(a, b)| (*a as f64 - b).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-5, "{g:?}: max error {worst}");
        }
    }

    #[test]
    fn gradients_match_central_differences_of_a_weighted_sum() {
        for g in [geometry(), doubled(), tripled()] {
            assert_gradients_match_central_differences(g);
        }
    }

    fn assert_gradients_match_central_differences(g: ConvGeometry) {
        let (x, w, b) = (values(2 * g.input_len(), 4), values(g.weight_len(), 5), values(4, 6));
        let upstream = values(2 * g.output_len(), 7);
        let loss = |x: &[f32], w: &[f32], b: &[f32]| -> f64 { direct(&g, x, w, b).iter().zip(&upstream).map(|(y, u)| y * *u as f64).sum() };
        let (dw, db) = g.weight_gradient(&x, &upstream);
        let dx = g.input_gradient(&w, &upstream);
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
            worst = worst.max((want - dw[i] as f64).abs());
        }
        for i in 0..b.len() {
            let want = fd(&|d| {
                let mut b = b.clone();
                b[i] += d;
                loss(&x, &w, &b)
            });
            worst = worst.max((want - db[i] as f64).abs());
        }
        assert!(worst < 1e-3, "{g:?}: max error {worst}");
    }

    /// The two weight-gradient layouts agree (whichever one a shape picks), in one group or one
    /// group per image; and every result is the same to the bit on one thread as on several
    /// (the blocks and sums depend only on the shapes).
    #[test]
    fn both_layouts_agree_and_results_do_not_depend_on_the_thread_count() {
        // 24 output channels over 20 pixels; 200 weights per output channel, so the product
        // splits into blocks.
        let g = ConvGeometry {
            channels: 8,
            out_channels: 24,
            ..geometry()
        };
        assert!(g.side_by_side(), "more output channels than pixels");
        let (x, w, b) = (values(3 * g.input_len(), 8), values(g.weight_len(), 9), values(24, 10));
        let upstream = values(3 * g.output_len(), 11);
        let per_image = g.weight_gradient_per_image(&x, &upstream);
        for group in [1, 2, 3] {
            let side = g.weight_gradient_side_by_side(&x, &upstream, group);
            let worst = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
            assert!(
                worst(&per_image.0, &side.0) < 1e-4 && worst(&per_image.1, &side.1) < 1e-4,
                "group {group}"
            );
        }
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| {
                let y = g.forward(&x, &w, &b);
                let (dw, db) = g.weight_gradient(&x, &upstream);
                let dx = g.input_gradient(&w, &upstream);
                [y, dw, db, dx, g.weight_gradient_per_image(&x, &upstream).0]
            })
        };
        assert_eq!(run(1), run(3));
    }
}
