//! Correspondences between two frames through the fitted template (neural-puppet.md §4.3):
//! a point of frame a is bound to the template fitted to a (barycentric in the enclosing
//! triangle of the front-most layer, [`bind`]) and placed with the same barycentric
//! coordinates on the template fitted to b.

use std::path::Path;

use super::bind::{bind, Binding};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::puppet::Puppet;
use crate::user_file;

/// The most points a points file may list.
pub const MAX_POINTS: usize = 1_000_000;

/// Reads a points file: a JSON list of `[x, y]` points (frame pixels).
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::DATA`];
/// [`Error::Format`] naming the file for anything but a list of finite number pairs, or more
/// than [`MAX_POINTS`] of them.
pub fn load_points(path: &Path) -> Result<Vec<[f32; 2]>> {
    parse_points(&user_file::read_bytes(path, user_file::DATA)?, path)
}

/// Parses the bytes of a points file; `path` only names it in errors.
///
/// # Errors
/// [`Error::Format`] naming `path` for anything but a list of finite number pairs, or more than
/// [`MAX_POINTS`] of them.
pub fn parse_points(bytes: &[u8], path: &Path) -> Result<Vec<[f32; 2]>> {
    let points: Vec<[f32; 2]> =
        serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("not a JSON list of [x, y] points: {e}")))?;
    if points.len() > MAX_POINTS {
        return Err(Error::limit("the points", points.len() as u64, MAX_POINTS as u64, "points").with_path(path));
    }
    if let Some(i) = points.iter().position(|p| !p[0].is_finite() || !p[1].is_finite()) {
        return Err(Error::format(path, format!("point {i} is not finite")));
    }
    Ok(points)
}

/// A grid of points over the opaque pixels of `frame`, every `spacing` pixels (at least 1),
/// offset by half a spacing from the corner.
pub fn grid_points(frame: &Picture, spacing: f32) -> Vec<[f32; 2]> {
    let spacing = spacing.max(1.0);
    let mut out = Vec::new();
    let mut y = spacing / 2.0;
    while y < frame.height as f32 {
        let mut x = spacing / 2.0;
        while x < frame.width as f32 {
            if frame.get(x as u32, y as u32)[3] > 0.5 {
                out.push([x, y]);
            }
            x += spacing;
        }
        y += spacing;
    }
    out
}

/// Where one point of frame a lands in frame b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correspondence {
    /// The point in frame a (pixels).
    pub from: [f32; 2],
    /// Its match in frame b (pixels).
    pub to: [f32; 2],
    /// How it was bound on the template fitted to a.
    pub binding: Binding,
}

/// Maps `points` of frame a into frame b: `from_vertices`/`to_vertices` are the template fitted
/// to a and to b (global numbering, frame pixels). A point that is not on the character in a
/// (see [`bind`]) maps to `None`.
///
/// # Errors
/// [`Error::Mismatch`] if either pose does not have one position per puppet vertex.
pub fn correspond(
    puppet: &Puppet,
    from_vertices: &[[f32; 2]],
    to_vertices: &[[f32; 2]],
    points: &[[f32; 2]],
) -> Result<Vec<Option<Correspondence>>> {
    for (name, v) in [("frame a", from_vertices), ("frame b", to_vertices)] {
        if v.len() != puppet.vertex_count() {
            return Err(Error::mismatch(
                format!("correspond: the vertex count of {name}'s pose"),
                v.len(),
                puppet.vertex_count(),
            ));
        }
    }
    Ok(points
        .iter()
        .map(|&p| {
            bind(puppet, from_vertices, p).ok().map(|binding| Correspondence {
                from: p,
                to: binding.position(to_vertices),
                binding,
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::layered_puppet;

    #[test]
    fn points_follow_a_per_layer_rigid_motion_exactly() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        // Frame b: every layer rotated by its own angle about its own pivot.
        let offsets = puppet.vertex_offsets();
        let mut moved = rest.clone();
        let motions: Vec<(f32, [f32; 2], [f32; 2])> = (0..puppet.layers.len())
            .map(|l| (0.1 * l as f32 - 0.15, [10.0 + 5.0 * l as f32, 20.0], [l as f32, -1.0]))
            .collect();
        let apply = |l: usize, p: [f32; 2]| {
            let (a, c, t) = motions[l];
            let (s, co) = a.sin_cos();
            let d = [p[0] - c[0], p[1] - c[1]];
            [c[0] + co * d[0] - s * d[1] + t[0], c[1] + s * d[0] + co * d[1] + t[1]]
        };
        for l in 0..puppet.layers.len() {
            for v in offsets[l]..offsets[l + 1] {
                moved[v] = apply(l, rest[v]);
            }
        }
        let points: Vec<[f32; 2]> = (0..20)
            .flat_map(|i| (0..20).map(move |j| [2.4 * i as f32 + 0.7, 2.0 * j as f32 + 0.3]))
            .collect();
        let out = correspond(&puppet, &rest, &moved, &points).unwrap();
        let mut mapped = 0;
        for c in out.into_iter().flatten() {
            let want = apply(c.binding.layer, c.binding.position(&rest));
            assert!(
                (want[0] - c.to[0]).abs() < 1e-3 && (want[1] - c.to[1]).abs() < 1e-3,
                "{c:?} vs {want:?}"
            );
            mapped += 1;
        }
        assert!(mapped > 60, "only {mapped} points on the puppet");
    }

    #[test]
    fn off_character_points_map_to_none_and_bad_poses_are_errors() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let out = correspond(&puppet, &rest, &rest, &[[-30.0, -30.0], [20.3, 30.2]]).unwrap();
        assert!(out[0].is_none());
        let to = out[1].expect("a torso point").to;
        assert!((to[0] - 20.3).abs() < 1e-4 && (to[1] - 30.2).abs() < 1e-4, "{to:?}");
        let err = correspond(&puppet, &rest, &rest[2..], &[]).unwrap_err().to_string();
        assert!(err.contains("frame b"), "{err}");
    }
}
