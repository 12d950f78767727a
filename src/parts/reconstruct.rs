//! Poses rebuilt from the parts (apes-part-extraction.md §3.3 scores part sets by how well they
//! reconstruct the poses): each part cut from the reference pose, moved into a pose by its
//! similarity, the parts stacked back to front in the found order. Rigid per part — the paper
//! deforms parts by ARAP, which this does not — so it shows what the parts and their order
//! explain, and its L2 against the pose is an upper bound of the paper's reconstruction error.

use super::pose::Pose;
use super::segment::Segmentation;
use super::superpixels::NONE;
use super::Parts;
use crate::picture::Picture;

/// Pose `t` redrawn from the reference's parts; straight alpha, the pose's size.
pub fn reconstruct(parts: &Parts, t: usize) -> Picture {
    rebuild(&parts.poses, &parts.segmentation, &parts.skeleton.order, t)
}

/// Pose `t` redrawn from the reference's parts of `seg`, stacked back to front in `order`.
pub fn rebuild(poses: &[Pose], seg: &Segmentation, order: &[usize], t: usize) -> Picture {
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
            let z = inv.apply(y);
            let (zx, zy) = (z[0].round(), z[1].round());
            if zx < 0.0 || zy < 0.0 || zx as usize >= w || zy as usize >= h {
                continue;
            }
            let j = zy as usize * w + zx as usize;
            if labels[j] != NONE && labels[j] as usize == p {
                *pixel = reference.image.pixels[j];
                break;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::similarity::Similarity;
    use crate::parts::skeleton::Skeleton;

    #[test]
    fn a_part_moved_by_its_motion_lands_where_the_motion_says() {
        // One part: a 2 × 2 square at (1, 1) of a 6 × 6 reference, moved 3 px right in pose 1.
        let mut image = Picture::filled(6, 6, [0.0; 4]);
        let mut labels = vec![NONE; 36];
        for k in [7, 8, 13, 14] {
            image.pixels[k] = [1.0, 0.0, 0.0, 1.0];
            labels[k] = 0;
        }
        let pose = Pose::new("p", image);
        let parts = Parts {
            poses: vec![pose.clone(), pose],
            superpixels: Vec::new(),
            segmentation: Segmentation {
                reference: 0,
                parts: 1,
                labels: vec![labels.clone(), labels],
                motions: vec![vec![Similarity::IDENTITY, Similarity::new(0.0, 1.0, [3.0, 0.0])]],
            },
            skeleton: Skeleton {
                root: 0,
                hinges: Vec::new(),
                order: vec![0],
            },
            cover: None,
        };
        let moved = reconstruct(&parts, 1);
        let drawn: Vec<usize> = (0..36).filter(|&k| moved.pixels[k][3] > 0.0).collect();
        assert_eq!(drawn, [10, 11, 16, 17]);
        assert_eq!(reconstruct(&parts, 0).pixels, parts.poses[0].image.pixels);
    }
}
