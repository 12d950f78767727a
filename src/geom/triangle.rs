//! Small predicates on single triangles shared by point binding and visibility tests.

/// Barycentric coordinates of `p` in triangle `t`; `None` for a degenerate triangle.
pub fn barycentric(t: [[f32; 2]; 3], p: [f32; 2]) -> Option<[f32; 3]> {
    let [a, b, c] = t;
    let det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    if det.abs() < 1e-12 {
        return None;
    }
    let wb = ((p[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[1] - a[1])) / det;
    let wc = ((b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])) / det;
    Some([1.0 - wb - wc, wb, wc])
}

/// Whether `p` lies in triangle `t`, edges included (`tolerance` in barycentric units).
pub fn contains(t: [[f32; 2]; 3], p: [f32; 2], tolerance: f32) -> bool {
    barycentric(t, p).is_some_and(|w| w.iter().all(|&x| x >= -tolerance))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentric_coordinates_reproduce_the_point_and_flag_outside() {
        let t = [[0.0, 0.0], [4.0, 0.0], [0.0, 2.0]];
        let w = barycentric(t, [1.0, 0.5]).unwrap();
        let back = [0, 1].map(|c| w[0] * t[0][c] + w[1] * t[1][c] + w[2] * t[2][c]);
        assert!((back[0] - 1.0).abs() < 1e-6 && (back[1] - 0.5).abs() < 1e-6);
        assert!(contains(t, [1.0, 0.5], 0.0));
        assert!(!contains(t, [3.0, 1.5], 0.0));
        assert!(barycentric([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], [1.0, 0.0]).is_none());
    }
}
