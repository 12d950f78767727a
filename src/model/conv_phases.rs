//! The 3×3 convolution (padding 1, stride 1) of an input doubled by nearest neighbour — a
//! U-Net's way up — as 2×2 convolutions of the input itself, one per output phase.
//!
//! Output pixel (2y + p, 2x + q) reads, at kernel tap (i, j), input pixel
//! (y + ⌊(p + i − 1)/2⌋, x + ⌊(q + j − 1)/2⌋): each phase (p, q) sees only 2×2 distinct input
//! pixels, so its nine taps fold into a 2×2 kernel whose entries are sums of taps. The four
//! phases' kernels are stacked as the output channels of one 2×2 convolution of the input with
//! padding 1, whose `(H + 1) × (W + 1)` outputs hold every phase (phase (p, q) from row p and
//! column q on). Per output pixel that is 4 multiply-adds per input channel instead of 9, over a
//! patch matrix of 16 values per input pixel instead of 36 (benches/README.md "parts").

use rayon::prelude::*;

use super::conv_kernel::{zeros, ConvGeometry};

/// Output phases: (p, q) for p, q in {0, 1}, index 2p + q.
const PHASES: usize = 4;

/// A convolution of a doubled input ([`ConvGeometry::upsample`] 2) in its phase form.
#[derive(Clone, Copy, Debug)]
pub struct DoubledConv {
    /// The doubled input's convolution.
    geometry: ConvGeometry,
    /// The 2×2 convolution of the input whose output channels are the four phases' (phase-major).
    phases: ConvGeometry,
}

/// The row (or column) of a phase's 2×2 kernel that tap `tap` of the 3×3 kernel folds into, for
/// output phase `phase` along that axis.
fn folded(phase: usize, tap: usize) -> usize {
    (phase + tap).div_ceil(2) - phase
}

impl DoubledConv {
    /// The phase form of `geometry`, when it is a 3×3, stride-1, padding-1 convolution of its
    /// input doubled; `None` for any other.
    pub fn of(geometry: &ConvGeometry) -> Option<Self> {
        let g = geometry;
        (g.upsample == 2 && g.kernel == 3 && g.stride == 1 && g.padding == 1).then(|| DoubledConv {
            geometry: *g,
            phases: ConvGeometry {
                out_channels: PHASES * g.out_channels,
                kernel: 2,
                upsample: 1,
                ..*g
            },
        })
    }

    /// `[O, C, 3, 3]` weights → the phases' `[4, O, C, 2, 2]`.
    fn fold(&self, weight: &[f32]) -> Vec<f32> {
        let (o, c) = (self.geometry.out_channels, self.geometry.channels);
        let mut folded_weight = vec![0f32; PHASES * o * c * 4];
        for (phase, out) in folded_weight.chunks_exact_mut(o * c * 4).enumerate() {
            let (p, q) = (phase / 2, phase % 2);
            for (taps, kernel) in weight.chunks_exact(9).zip(out.chunks_exact_mut(4)) {
                for (tap, &w) in taps.iter().enumerate() {
                    kernel[folded(p, tap / 3) * 2 + folded(q, tap % 3)] += w;
                }
            }
        }
        folded_weight
    }

    /// The adjoint of [`Self::fold`]: the phases' `[4, O, C, 2, 2]` weight gradient → `[O, C, 3, 3]`.
    fn unfold(&self, folded_gradient: &[f32]) -> Vec<f32> {
        let (o, c) = (self.geometry.out_channels, self.geometry.channels);
        let mut gradient = vec![0f32; o * c * 9];
        for (phase, part) in folded_gradient.chunks_exact(o * c * 4).enumerate() {
            let (p, q) = (phase / 2, phase % 2);
            for (taps, kernel) in gradient.chunks_exact_mut(9).zip(part.chunks_exact(4)) {
                for (tap, d) in taps.iter_mut().enumerate() {
                    *d += kernel[folded(p, tap / 3) * 2 + folded(q, tap % 3)];
                }
            }
        }
        gradient
    }

    /// Where phase `phase`'s plane of output plane `plane` (image b, channel o: `b·O + o`) starts
    /// among the phase outputs `[B, 4, O, H + 1, W + 1]`.
    fn phase_plane(&self, plane: usize, phase: usize) -> usize {
        let o = self.geometry.out_channels;
        ((plane / o * PHASES + phase) * o + plane % o) * self.phase_len()
    }

    /// Values in one phase plane.
    fn phase_len(&self) -> usize {
        (self.geometry.height + 1) * (self.geometry.width + 1)
    }

    /// `[B, 4·O, H + 1, W + 1]` phase outputs → `[B, O, 2H, 2W]`.
    fn interleave(&self, phases: &[f32]) -> Vec<f32> {
        let (h, w) = (self.geometry.height, self.geometry.width);
        let stride = w + 1;
        let mut y = zeros(phases.len() / self.phase_len() / PHASES * 4 * h * w);
        y.par_chunks_mut(4 * h * w).enumerate().for_each(|(plane, out)| {
            for (row, line) in out.chunks_exact_mut(2 * w).enumerate() {
                let (yy, p) = (row / 2, row % 2);
                let source = |q: usize| {
                    let start = self.phase_plane(plane, 2 * p + q) + (yy + p) * stride + q;
                    &phases[start..][..w]
                };
                for ((pair, &even), &odd) in line.chunks_exact_mut(2).zip(source(0)).zip(source(1)) {
                    pair[0] = even;
                    pair[1] = odd;
                }
            }
        });
        y
    }

    /// The adjoint of [`Self::interleave`]: `[B, O, 2H, 2W]` → `[B, 4·O, H + 1, W + 1]`, zeros
    /// where no output pixel reads.
    fn split(&self, dy: &[f32]) -> Vec<f32> {
        let (h, w, o) = (self.geometry.height, self.geometry.width, self.geometry.out_channels);
        let stride = w + 1;
        let planes = dy.len() / (4 * h * w);
        let mut split = zeros(planes * PHASES * self.phase_len());
        split.par_chunks_mut(self.phase_len()).enumerate().for_each(|(index, dst)| {
            let (image, phase, channel) = (index / (PHASES * o), index / o % PHASES, index % o);
            let (p, q) = (phase / 2, phase % 2);
            let plane = &dy[(image * o + channel) * 4 * h * w..][..4 * h * w];
            for yy in 0..h {
                let line = &plane[(2 * yy + p) * 2 * w..][..2 * w];
                let out = &mut dst[(yy + p) * stride + q..][..w];
                for (d, pair) in out.iter_mut().zip(line.chunks_exact(2)) {
                    *d = pair[q];
                }
            }
        });
        split
    }

    /// The convolution of `x` `[B, C, H, W]` doubled: `[B, O, 2H, 2W]` (as
    /// [`ConvGeometry::forward`]).
    pub fn forward(&self, x: &[f32], weight: &[f32], bias: &[f32]) -> Vec<f32> {
        let bias: Vec<f32> = (0..PHASES).flat_map(|_| bias.iter().copied()).collect();
        self.interleave(&self.phases.forward(x, &self.fold(weight), &bias))
    }

    /// The input gradient (if `input`), the weight gradient and the bias gradient for upstream
    /// `dy` `[B, O, 2H, 2W]` at input `x` (as [`ConvGeometry::weight_gradient`] and
    /// [`ConvGeometry::input_gradient`]).
    pub fn gradients(&self, x: &[f32], weight: &[f32], dy: &[f32], input: bool) -> (Option<Vec<f32>>, Vec<f32>, Vec<f32>) {
        let dz = self.split(dy);
        let (folded_dw, folded_db) = self.phases.weight_gradient(x, &dz);
        let o = self.geometry.out_channels;
        let mut db = vec![0f32; o];
        for part in folded_db.chunks_exact(o) {
            db.iter_mut().zip(part).for_each(|(d, v)| *d += v);
        }
        let dx = input.then(|| self.phases.input_gradient(&self.fold(weight), &dz));
        (dx, self.unfold(&folded_dw), db)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values in [-1, 1).
    fn values(n: usize, seed: u32) -> Vec<f32> {
        (0..n as u32)
            .map(|i| ((i.wrapping_mul(2654435761) ^ seed.wrapping_mul(40503)) % 2000) as f32 / 1000.0 - 1.0)
            .collect()
    }

    fn worst(a: &[f32], b: &[f32]) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max)
    }

    fn doubled(channels: usize, height: usize, width: usize, out_channels: usize) -> ConvGeometry {
        ConvGeometry {
            channels,
            height,
            width,
            out_channels,
            kernel: 3,
            stride: 1,
            padding: 1,
            upsample: 2,
        }
    }

    /// The phase form against the doubled input's convolution unfolded tap by tap (itself tested
    /// against the definition and central differences in `conv_kernel`): output, and the input,
    /// weight and bias gradients, on odd and even sides, one pixel wide, and a batch of three.
    #[test]
    fn the_phase_form_matches_the_convolution_of_the_doubled_input() {
        for g in [doubled(3, 5, 4, 2), doubled(2, 1, 6, 5), doubled(4, 7, 7, 3), doubled(1, 2, 1, 1)] {
            let phases = DoubledConv::of(&g).expect("a 3×3 convolution of a doubled input");
            let (x, w, b) = (values(3 * g.input_len(), 1), values(g.weight_len(), 2), values(g.out_channels, 3));
            assert!(worst(&phases.forward(&x, &w, &b), &g.forward(&x, &w, &b)) < 1e-5, "{g:?}: output");
            let upstream = values(3 * g.output_len(), 4);
            let (dx, dw, db) = phases.gradients(&x, &w, &upstream, true);
            let (want_dw, want_db) = g.weight_gradient(&x, &upstream);
            assert!(
                worst(&dx.expect("asked for"), &g.input_gradient(&w, &upstream)) < 1e-5,
                "{g:?}: input gradient"
            );
            assert!(worst(&dw, &want_dw) < 1e-4, "{g:?}: weight gradient");
            assert!(worst(&db, &want_db) < 1e-4, "{g:?}: bias gradient");
            assert!(phases.gradients(&x, &w, &upstream, false).0.is_none());
        }
    }

    #[test]
    fn only_a_three_by_three_same_convolution_of_a_doubled_input_has_a_phase_form() {
        let g = doubled(2, 3, 3, 2);
        assert!(DoubledConv::of(&g).is_some());
        for other in [
            ConvGeometry { upsample: 1, ..g },
            ConvGeometry { upsample: 3, ..g },
            ConvGeometry {
                kernel: 5,
                padding: 2,
                ..g
            },
            ConvGeometry { padding: 0, ..g },
            ConvGeometry { stride: 2, ..g },
        ] {
            assert!(DoubledConv::of(&other).is_none(), "{other:?}");
        }
    }

    /// The same bits on one thread as on several: training stays reproducible.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let g = doubled(3, 9, 6, 4);
        let phases = DoubledConv::of(&g).expect("a phase form");
        let (x, w, b) = (values(2 * g.input_len(), 5), values(g.weight_len(), 6), values(4, 7));
        let upstream = values(2 * g.output_len(), 8);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| {
                let (dx, dw, db) = phases.gradients(&x, &w, &upstream, true);
                [phases.forward(&x, &w, &b), dx.expect("asked for"), dw, db]
            })
        };
        assert_eq!(run(1), run(3));
    }
}
