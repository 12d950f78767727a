//! Element-wise maths and reductions over f32 slices written so that their loops vectorise: an
//! exponential in plain arithmetic, and sums and maxima kept in eight lanes (one running
//! accumulator is a dependency chain the compiler may not reorder).

/// e^x within about 2 ulp (Cephes' `expf`), in plain arithmetic so that loops over it
/// vectorise: libm's `expf` is a call per value.
/// x = n·ln 2 + r with n = round(x·log₂e) and |r| ≤ ln 2 / 2; e^r by a degree-7 polynomial;
/// 2ⁿ from the exponent bits. Clamped to the range where both e^x and 2ⁿ are normal floats.
#[inline]
pub fn exp(x: f32) -> f32 {
    // 1.5·2²³: adding it rounds x·log₂e to an integer n, which then sits in the low mantissa
    // bits (no float-to-int conversion, whose saturation does not vectorise).
    const ROUND: f32 = 12_582_912.0;
    let x = x.clamp(-87.3, 88.3);
    let shifted = x * std::f32::consts::LOG2_E + ROUND;
    let n = shifted - ROUND;
    // ln 2 in two parts, the first (355/512) exact in few bits, so n·ln 2 loses nothing.
    let r = x - n * 0.693_359_4 + n * 2.121_944_4e-4;
    let p = ((((1.987_569_1e-4 * r + 1.398_2e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r + 0.166_666_65) * r + 0.5;
    let e_r = p * r * r + r + 1.0;
    // The low bits of `shifted` are 2²² + n; plus the bias 127, shifted into the exponent field
    // (the 2²² falls off the top), they are 2ⁿ.
    e_r * f32::from_bits(shifted.to_bits().wrapping_add(127) << 23)
}

/// Accumulators of a lane reduction: enough independent chains to fill the vector units.
const LANES: usize = 8;
/// Elements per block of a [`lane_sum`], whose f32 lane sums are then added in f64: short enough
/// that a block's f32 rounding stays far below the f64 total's needs, long enough to vectorise.
const BLOCK: usize = 512;

/// Σ term(aᵢ, bᵢ) in f64: eight f32 lanes per block of 512 (so the loop vectorises; a single
/// f64 accumulator does not), the blocks' sums added in f64.
pub fn lane_sum(a: &[f32], b: &[f32], term: impl Fn(f32, f32) -> f32) -> f64 {
    a.chunks(BLOCK)
        .zip(b.chunks(BLOCK))
        .map(|(a, b)| {
            let mut lanes = [0f32; LANES];
            let (mut a_chunks, mut b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
            for (a, b) in (&mut a_chunks).zip(&mut b_chunks) {
                for ((lane, &x), &y) in lanes.iter_mut().zip(a).zip(b) {
                    *lane += term(x, y);
                }
            }
            let rest: f64 = a_chunks
                .remainder()
                .iter()
                .zip(b_chunks.remainder())
                .map(|(&x, &y)| f64::from(term(x, y)))
                .sum();
            lanes.iter().map(|&l| f64::from(l)).sum::<f64>() + rest
        })
        .sum()
}

/// The largest of `values` (−∞ for none; NaNs are passed over), in eight lanes.
pub fn lane_max(values: &[f32]) -> f32 {
    let mut lanes = [f32::NEG_INFINITY; LANES];
    let mut chunks = values.chunks_exact(LANES);
    for chunk in &mut chunks {
        for (lane, &v) in lanes.iter_mut().zip(chunk) {
            // A comparison and a select: the form that becomes one vector maximum.
            *lane = if v > *lane { v } else { *lane };
        }
    }
    chunks.remainder().iter().chain(&lanes).copied().fold(f32::NEG_INFINITY, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_is_within_a_few_ulp_of_libm() {
        let mut worst = 0f32;
        // Over the range where e^x is a normal float (and the clamp does not act).
        for i in -200_000..=200_000 {
            let x = i as f32 * 4.36e-4;
            let (ours, libm) = (exp(x), x.exp());
            worst = worst.max((ours - libm).abs() / libm);
        }
        assert!(worst < 3.0 * f32::EPSILON, "relative error {worst}");
        // Past the clamp: finite and positive.
        assert!(exp(1000.0).is_finite() && exp(-1000.0) > 0.0);
    }

    #[test]
    fn lane_sums_match_f64_sums() {
        for n in [0, 1, 7, 8, 9, 511, 512, 513, 16_384 + 5] {
            let a: Vec<f32> = (0..n).map(|i| ((i * 37 % 101) as f32 - 50.0) / 7.0).collect();
            let b: Vec<f32> = (0..n).map(|i| ((i * 13 % 29) as f32 - 14.0) / 3.0).collect();
            let terms = a.iter().zip(&b).map(|(&x, &y)| f64::from(x) * f64::from(y));
            let (exact, magnitude) = terms.fold((0.0, 0.0), |(s, m), t| (s + t, m + t.abs()));
            let ours = lane_sum(&a, &b, |x, y| x * y);
            // f32 rounding within a block: far below the f32 values the sums become.
            assert!((ours - exact).abs() <= 1e-7 * magnitude, "{n}: {ours} vs {exact}");
        }
    }

    #[test]
    fn lane_maxima_match_the_maximum() {
        for n in [0, 1, 7, 8, 9, 63, 64, 65, 1000] {
            let values: Vec<f32> = (0..n).map(|i| ((i * 37 % 101) as f32 - 50.0) / 7.0).collect();
            let expected = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            assert_eq!(lane_max(&values), expected, "{n} values");
        }
        // The largest value in the remainder, and NaNs passed over.
        assert_eq!(lane_max(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, f32::NAN, 9.5]), 9.5);
    }
}
