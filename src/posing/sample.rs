//! Drawing the rigid part of a random pose: each limb turned about its joint, then the whole
//! figure squashed or stretched, turned, scaled and shifted. Every draw comes from one [`Rng`]
//! stream in a fixed order, so a seed gives one pose. The training sampler of sampled poses
//! (`train::sampled`) draws its poses with [`turn_limbs`] and [`scale_and_shift`] too.

use crate::puppet::limbs::Limb;
use crate::rng::Rng;

/// Turns each of `limbs` (root first, as [`crate::puppet::limbs::limbs`] orders them) about its
/// pivot in `pose` (global numbering, pixels) by an angle drawn uniformly within
/// ±`max_degrees`, one draw per limb in order.
pub fn turn_limbs(limbs: &[Limb], pose: &mut [[f32; 2]], max_degrees: f32, rng: &mut Rng) {
    for limb in limbs {
        limb.turn(pose, rng.range(-max_degrees, max_degrees).to_radians());
    }
}

/// Scales `pose` (pixels of a `width × height` frame) about the frame's centre by `1 ± scale`
/// and shifts it by up to ±`shift` of the frame's width and height, drawing the scale, then the
/// shift along x, then along y.
pub fn scale_and_shift(pose: &mut [[f32; 2]], width: u32, height: u32, scale: f32, shift: f32, rng: &mut Rng) {
    let (w, h) = (width as f32, height as f32);
    let scale = 1.0 + rng.range(-scale, scale);
    let shift = [rng.range(-shift, shift) * w, rng.range(-shift, shift) * h];
    let centre = [w / 2.0, h / 2.0];
    for p in pose {
        *p = [
            centre[0] + (p[0] - centre[0]) * scale + shift[0],
            centre[1] + (p[1] - centre[1]) * scale + shift[1],
        ];
    }
}

/// Squashes or stretches `pose` about the centre of its bounding box — the figure's height times
/// `1 + k` and its width divided by it, `k` drawn within ±`squash`, so the area stays — and
/// turns it about the same centre by an angle drawn within ±`max_degrees`. The map's
/// determinant is one: no triangle turns over.
pub fn squash_and_turn(pose: &mut [[f32; 2]], squash: f32, max_degrees: f32, rng: &mut Rng) {
    let k = 1.0 + rng.range(-squash, squash);
    let (s, c) = rng.range(-max_degrees, max_degrees).to_radians().sin_cos();
    let centre = bounding_centre(pose);
    for p in pose {
        let (dx, dy) = ((p[0] - centre[0]) / k, (p[1] - centre[1]) * k);
        *p = [centre[0] + c * dx - s * dy, centre[1] + s * dx + c * dy];
    }
}

/// The centre of the bounding box of `points` (the origin for none).
fn bounding_centre(points: &[[f32; 2]]) -> [f32; 2] {
    if points.is_empty() {
        return [0.0, 0.0];
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
}

/// The larger side of the bounding box of `points` (pixels; 0 for none).
pub fn figure_size(points: &[[f32; 2]]) -> f32 {
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0]).max(hi[1] - lo[1]).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signed_area(t: [[f32; 2]; 3]) -> f32 {
        let [a, b, c] = t;
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
    }

    #[test]
    fn squash_keeps_area_and_winding_and_the_centre() {
        let tri = [[10.0, 10.0], [30.0, 12.0], [14.0, 40.0]];
        let mut pose = tri.to_vec();
        let before = bounding_centre(&pose);
        squash_and_turn(&mut pose, 0.2, 20.0, &mut Rng::new(5));
        let after = [pose[0], pose[1], pose[2]];
        assert!(
            (signed_area(after) - signed_area(tri)).abs() < 1e-2,
            "{} vs {}",
            signed_area(after),
            signed_area(tri)
        );
        assert_ne!(after, tri, "the figure moved");
        // The box centre is the fixed point of the map, though the box itself changes.
        let moved = bounding_centre(&pose);
        assert!((moved[0] - before[0]).abs() < 15.0 && (moved[1] - before[1]).abs() < 15.0);
    }

    #[test]
    fn still_settings_leave_the_pose() {
        let mut pose = vec![[3.0, 4.0], [10.0, 2.0]];
        scale_and_shift(&mut pose, 20, 10, 0.0, 0.0, &mut Rng::new(1));
        squash_and_turn(&mut pose, 0.0, 0.0, &mut Rng::new(1));
        for (p, q) in pose.iter().zip([[3.0, 4.0], [10.0, 2.0]]) {
            assert!((p[0] - q[0]).abs() < 1e-5 && (p[1] - q[1]).abs() < 1e-5, "{p:?}");
        }
        assert_eq!(figure_size(&pose), 7.0);
    }
}
