//! Small predicates on single triangles and segments shared by point binding, pin overlays and
//! visibility tests.

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

/// The point of segment `a b` closest to `p` (`a` for a zero-length segment).
pub fn closest_on_segment(a: [f32; 2], b: [f32; 2], p: [f32; 2]) -> [f32; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let s = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + s * d[0], a[1] + s * d[1]]
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
        assert_eq!(closest_on_segment([0.0, 0.0], [4.0, 0.0], [1.0, 3.0]), [1.0, 0.0]);
        assert_eq!(closest_on_segment([0.0, 0.0], [4.0, 0.0], [9.0, 1.0]), [4.0, 0.0]);
        assert_eq!(closest_on_segment([2.0, 2.0], [2.0, 2.0], [9.0, 1.0]), [2.0, 2.0]);
    }
}
