//! Poses rebuilt from the parts (apes-part-extraction.md §3.3 scores part sets by how well they
//! reconstruct the poses): each part cut from the reference pose, moved into a pose by its
//! similarity or bent there by its ARAP control mesh ([`super::deform`], the paper's appendix
//! B), the parts stacked back to front in the found order.

use super::deform::PartMesh;
use super::pose::SheetPose;
use super::segment::Segmentation;
use super::superpixels::NONE;
use crate::geom::triangle::barycentric;
use crate::picture::Picture;

/// Pose `t` redrawn from the reference's parts of `seg`, stacked back to front in `order`: each
/// part bent by its mesh (`meshes`, one per part), or moved by its similarity without meshes.
pub fn redraw(poses: &[SheetPose], seg: &Segmentation, meshes: Option<&[PartMesh]>, order: &[usize], t: usize) -> Picture {
    match meshes {
        Some(meshes) => draw_meshes(poses, seg, meshes, order, t),
        None => rebuild(poses, seg, order, t),
    }
}

/// [`redraw`] with meshes: every pixel a part's posed triangle covers takes the reference pixel
/// its rest triangle holds there, if that pixel is the part's.
fn draw_meshes(poses: &[SheetPose], seg: &Segmentation, meshes: &[PartMesh], order: &[usize], t: usize) -> Picture {
    let reference = &poses[seg.reference];
    let (w, h) = (reference.width(), reference.height());
    let labels = &seg.labels[seg.reference];
    let mut out = Picture::filled(w as u32, h as u32, [0.0; 4]);
    for &p in order {
        let mesh = &meshes[p];
        let Some(posed) = &mesh.posed[t] else { continue };
        for tri in &mesh.triangles {
            let at = tri.map(|k| posed[k as usize]);
            let rest = tri.map(|k| mesh.rest[k as usize]);
            // The pixels whose centres the triangle's bounding box holds, half-open.
            let span = |a: usize, n: usize| {
                let (lo, hi) = at
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| (lo.min(v[a]), hi.max(v[a])));
                (
                    lo.ceil().clamp(0.0, n as f32) as usize,
                    (hi.floor() + 1.0).clamp(0.0, n as f32) as usize,
                )
            };
            let ((x0, x1), (y0, y1)) = (span(0, w), span(1, h));
            for y in y0..y1 {
                for x in x0..x1 {
                    let Some(b) = barycentric(at, [x as f32, y as f32]) else { continue };
                    if b.iter().any(|&c| c < -1e-4) {
                        continue;
                    }
                    let z = [0, 1].map(|a| b[0] * rest[0][a] + b[1] * rest[1][a] + b[2] * rest[2][a]);
                    if let Some(j) = part_pixel_at(z, p, labels, w, h) {
                        out.pixels[y * w + x] = reference.image.pixels[j];
                    }
                }
            }
        }
    }
    out
}

/// [`redraw`] without meshes: each part moved by its similarity.
fn rebuild(poses: &[SheetPose], seg: &Segmentation, order: &[usize], t: usize) -> Picture {
    let reference = &poses[seg.reference];
    let (w, h) = (reference.width(), reference.height());
    let labels = &seg.labels[seg.reference];
    let inverse: Vec<_> = seg
        .motions
        .iter()
        .map(|m| if m[t].scale() > 1e-6 { Some(m[t].inverse()) } else { None })
        .collect();
    let mut out = Picture::filled(w as u32, h as u32, [0.0; 4]);
    for (i, pixel) in out.pixels.iter_mut().enumerate() {
        let y = [(i % w) as f32, (i / w) as f32];
        // Front to back: the first part whose reference region holds the pulled-back point.
        for &p in order.iter().rev() {
            let Some(inv) = &inverse[p] else { continue };
            if let Some(j) = part_pixel_at(inv.apply(y), p, labels, w, h) {
                *pixel = reference.image.pixels[j];
                break;
            }
        }
    }
    out
}

/// The reference pixel nearest the point `z`, if it lies on the `w × h` canvas and belongs to
/// part `p` by the reference's `labels`.
fn part_pixel_at(z: [f32; 2], p: usize, labels: &[u32], w: usize, h: usize) -> Option<usize> {
    let (zx, zy) = (z[0].round(), z[1].round());
    if zx < 0.0 || zy < 0.0 || zx as usize >= w || zy as usize >= h {
        return None;
    }
    let j = zy as usize * w + zx as usize;
    (labels[j] != NONE && labels[j] as usize == p).then_some(j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::similarity::Similarity;
    use crate::parts::deform::{deform_parts, BendOptions};
    use crate::parts::flow::{Correspondences, Flow};

    #[test]
    fn a_part_moved_by_its_motion_lands_where_the_motion_says() {
        // One part: a 2 × 2 square at (1, 1) of a 6 × 6 reference, moved 3 px right in pose 1.
        let mut image = Picture::filled(6, 6, [0.0; 4]);
        let mut labels = vec![NONE; 36];
        for k in [7, 8, 13, 14] {
            image.pixels[k] = [1.0, 0.0, 0.0, 1.0];
            labels[k] = 0;
        }
        let pose = SheetPose::new("p", image);
        let poses = vec![pose.clone(), pose];
        let seg = Segmentation {
            reference: 0,
            parts: 1,
            labels: vec![labels.clone(), labels.clone()],
            motions: vec![vec![Similarity::IDENTITY, Similarity::new(0.0, 1.0, [3.0, 0.0])]],
        };
        let moved = redraw(&poses, &seg, None, &[0], 1);
        let drawn: Vec<usize> = (0..36).filter(|&k| moved.pixels[k][3] > 0.0).collect();
        assert_eq!(drawn, [10, 11, 16, 17]);
        assert_eq!(redraw(&poses, &seg, None, &[0], 0).pixels, poses[0].image.pixels);

        // Bent by a mesh pulled by correspondences that say the same: the same pixels.
        let mut flows = Correspondences::new(2, 36);
        let to = (0..36).map(|k| {
            if labels[k] == 0 {
                [(k % 6) as f32 + 3.0, (k / 6) as f32]
            } else {
                [f32::NAN; 2]
            }
        });
        flows.set(0, 1, Flow { to: to.collect() }).unwrap();
        let meshes = deform_parts(&poses, &seg, &flows, &BendOptions::default()).unwrap();
        assert_eq!(redraw(&poses, &seg, Some(&meshes), &[0], 1).pixels, moved.pixels);
        assert_eq!(redraw(&poses, &seg, Some(&meshes), &[0], 0).pixels, poses[0].image.pixels);
    }
}
