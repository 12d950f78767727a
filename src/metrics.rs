//! The metrics of DESIGN.md, defined once and used everywhere (fits, `puppet eval`, tests,
//! benches): L2, masked RMSE, silhouette IoU on pictures; vertex error and PCK on point sets.
//!
//! Pictures are straight-alpha [`Picture`]s of the same size; see each function for its units.

use crate::picture::Picture;

/// The PCK thresholds of neural-puppet.md Table 2.
pub const PCK_ALPHAS: [f64; 3] = [0.1, 0.05, 0.025];

/// Composites a straight-alpha pixel on white, channels in [0, 1].
fn on_white(p: [f32; 4]) -> [f64; 3] {
    let a = p[3].clamp(0.0, 1.0) as f64;
    [0, 1, 2].map(|c| p[c].clamp(0.0, 1.0) as f64 * a + (1.0 - a))
}

/// L2: the Frobenius norm of (output − target) over the RGB images composited on white, values
/// in [0, 255] (neural-puppet.md Table 1's quantity).
///
/// # Panics
/// If the sizes differ (a caller bug: frames are checked when loaded).
pub fn l2(output: &Picture, target: &Picture) -> f64 {
    l2_squared(output, target).sqrt()
}

/// The square of [`l2`]: a sum over pixels, so the L2 of a picture that differs from another only
/// inside a window follows from the sums over that window.
///
/// # Panics
/// If the sizes differ.
pub fn l2_squared(output: &Picture, target: &Picture) -> f64 {
    assert_same_size(output, target);
    output
        .pixels
        .iter()
        .zip(&target.pixels)
        .map(|(&a, &b)| {
            let (a, b) = (on_white(a), on_white(b));
            (0..3).map(|c| (255.0 * (a[c] - b[c])).powi(2)).sum::<f64>()
        })
        .sum()
}

/// Masked RMSE: root mean square of the RGB difference (composited on white, values in
/// [0, 1]) over the pixels where the output or the target has alpha > 0.5. 0 when neither has any.
///
/// # Panics
/// If the sizes differ.
pub fn masked_rmse(output: &Picture, target: &Picture) -> f64 {
    assert_same_size(output, target);
    let (mut sum, mut n) = (0.0, 0usize);
    for (&a, &b) in output.pixels.iter().zip(&target.pixels) {
        if a[3] > 0.5 || b[3] > 0.5 {
            let (a, b) = (on_white(a), on_white(b));
            sum += (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>();
            n += 3;
        }
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

/// Silhouette IoU of alpha > 0.5; 1 when both are empty.
///
/// # Panics
/// If the sizes differ.
pub fn silhouette_iou(output: &Picture, target: &Picture) -> f64 {
    assert_same_size(output, target);
    let (mut inter, mut union) = (0usize, 0usize);
    for (a, b) in output.pixels.iter().zip(&target.pixels) {
        let (a, b) = (a[3] > 0.5, b[3] > 0.5);
        inter += (a && b) as usize;
        union += (a || b) as usize;
    }
    if union == 0 {
        1.0
    } else {
        inter as f64 / union as f64
    }
}

/// Mean distance in pixels between predicted and true points (vertex error on synthetic data).
///
/// # Panics
/// If the lengths differ.
pub fn vertex_error(predicted: &[[f32; 2]], truth: &[[f32; 2]]) -> f64 {
    assert_eq!(predicted.len(), truth.len(), "vertex error of point sets of different sizes");
    if predicted.is_empty() {
        return 0.0;
    }
    let sum: f64 = predicted
        .iter()
        .zip(truth)
        .map(|(p, t)| ((p[0] - t[0]) as f64).hypot((p[1] - t[1]) as f64))
        .sum();
    sum / predicted.len() as f64
}

/// PCK@α: the share of points whose prediction lies within α·max(width, height) of the truth
/// (neural-puppet.md Table 2's quantity, α ∈ {0.1, 0.05, 0.025}).
///
/// # Panics
/// If the lengths differ.
pub fn pck(predicted: &[[f32; 2]], truth: &[[f32; 2]], alpha: f64, width: u32, height: u32) -> f64 {
    assert_eq!(predicted.len(), truth.len(), "PCK of point sets of different sizes");
    if predicted.is_empty() {
        return 1.0;
    }
    let radius = alpha * width.max(height) as f64;
    let hits = predicted
        .iter()
        .zip(truth)
        .filter(|(p, t)| ((p[0] - t[0]) as f64).hypot((p[1] - t[1]) as f64) <= radius)
        .count();
    hits as f64 / predicted.len() as f64
}

fn assert_same_size(a: &Picture, b: &Picture) {
    assert_eq!((a.width, a.height), (b.width, b.height), "metric of pictures of different sizes");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_on_hand_computed_cases() {
        let white = Picture::filled(2, 1, [1.0, 1.0, 1.0, 1.0]);
        let mut black = white.clone();
        black.pixels[0] = [0.0, 0.0, 0.0, 1.0];
        // One pixel differs by 255 in three channels: sqrt(3·255²).
        assert!((l2(&black, &white) - 255.0 * 3f64.sqrt()).abs() < 1e-9);
        // A transparent pixel composites to white.
        let clear = Picture::filled(2, 1, [0.3, 0.2, 0.1, 0.0]);
        assert_eq!(l2(&clear, &white), 0.0);
        // Masked RMSE over both pixels (both opaque): one of two differs by 1 in every channel.
        assert!((masked_rmse(&black, &white) - 0.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(silhouette_iou(&clear, &white), 0.0);
        assert_eq!(silhouette_iou(&black, &white), 1.0);
        let truth = [[0.0, 0.0], [10.0, 0.0]];
        let pred = [[3.0, 4.0], [10.0, 0.0]];
        assert!((vertex_error(&pred, &truth) - 2.5).abs() < 1e-12);
        // L = max(100, 50) = 100: at α = 0.05 the 5-px miss is just within, at 0.04 it is not.
        assert_eq!(pck(&pred, &truth, 0.05, 100, 50), 1.0);
        assert_eq!(pck(&pred, &truth, 0.04, 100, 50), 0.5);
        assert_eq!(pck(&pred, &truth, 0.05, 50, 100), 1.0, "L is the larger side");
    }
}
