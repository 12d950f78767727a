//! Pixel labels from part motions, and their clean-up (used by [`super::segment`]): each pixel
//! of a pose takes the part whose motions best explain its correspondences, stray pieces rejoin
//! a neighbour, and parts too small to trust are dropped.

use super::flow::Correspondences;
use super::pose::SheetPose;
use super::superpixels::{Superpixels, NONE};
use crate::geom::similarity::Similarity;

/// Parts with fewer than `min_size` pixels are dropped (their pixels take the neighbouring
/// part they border most, as stray pieces do); the rest are renumbered in order.
pub(super) fn drop_small_parts(labels: Vec<u32>, parts: usize, min_size: usize, w: usize) -> (Vec<u32>, usize) {
    let mut area = vec![0usize; parts];
    for &l in labels.iter().filter(|&&l| l != NONE) {
        area[l as usize] += 1;
    }
    let keep: Vec<bool> = area.iter().map(|&a| a >= min_size.max(1)).collect();
    if keep.iter().all(|&k| k) || !keep.iter().any(|&k| k) {
        return (labels, parts);
    }
    let mut new_index = vec![NONE; parts];
    let mut next = 0;
    for p in 0..parts {
        if keep[p] {
            new_index[p] = next;
            next += 1;
        }
    }
    // A dropped part's pixels are a stray piece of an unused label; joining them to their
    // neighbours is what `keep_largest_pieces` does for pieces that are not their part's largest.
    let orphan = next;
    let marked: Vec<u32> = labels
        .iter()
        .map(|&l| {
            if l == NONE {
                NONE
            } else if keep[l as usize] {
                new_index[l as usize]
            } else {
                orphan
            }
        })
        .collect();
    let joined = rejoin_pieces(marked, w, Some(orphan));
    // A dropped part alone in its piece of the drawing has nowhere to go: it stays a part.
    let parts = next as usize + usize::from(joined.contains(&orphan));
    (joined, parts)
}

/// Each part keeps its largest 4-connected piece; smaller pieces join the part they share the
/// longest border with (pieces with no labelled neighbour keep their label).
pub(super) fn keep_largest_pieces(labels: Vec<u32>, w: usize) -> Vec<u32> {
    rejoin_pieces(labels, w, None)
}

/// Pieces that are not their part's largest, and every piece labelled `orphan`, join the
/// part (other than `orphan`) they share the longest border with; a piece with no such
/// neighbour keeps its label.
pub(super) fn rejoin_pieces(mut labels: Vec<u32>, w: usize, orphan: Option<u32>) -> Vec<u32> {
    let n = labels.len();
    let neighbours = |i: usize| [(i % w + 1 < w).then(|| i + 1), (i + w < n).then(|| i + w)].into_iter().flatten();
    let edges = (0..n).filter(|&i| labels[i] != NONE).flat_map(|i| {
        neighbours(i)
            .filter(|&j| labels[j] == labels[i])
            .map(move |j| (i, j))
            .collect::<Vec<_>>()
    });
    let (piece, count) = crate::geom::component_labels(n, edges);
    let mut size = vec![0usize; count];
    let mut part_of_piece = vec![NONE; count];
    for i in (0..n).filter(|&i| labels[i] != NONE) {
        size[piece[i]] += 1;
        part_of_piece[piece[i]] = labels[i];
    }
    let mut largest: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    for c in (0..count).filter(|&c| part_of_piece[c] != NONE) {
        let best = largest.entry(part_of_piece[c]).or_insert(c);
        if size[c] > size[*best] {
            *best = c;
        }
    }
    let mut border: std::collections::BTreeMap<(usize, u32), usize> = std::collections::BTreeMap::new();
    for i in (0..n).filter(|&i| labels[i] != NONE) {
        for j in neighbours(i).filter(|&j| labels[j] != NONE && piece[j] != piece[i]) {
            *border.entry((piece[i], labels[j])).or_default() += 1;
            *border.entry((piece[j], labels[i])).or_default() += 1;
        }
    }
    let mut new_part = part_of_piece.clone();
    let stray = |c: usize| part_of_piece[c] != NONE && (largest[&part_of_piece[c]] != c || Some(part_of_piece[c]) == orphan);
    for c in (0..count).filter(|&c| stray(c)) {
        let best = border
            .range((c, 0)..=(c, u32::MAX))
            .filter(|(&(_, l), _)| l != part_of_piece[c] && Some(l) != orphan)
            .max_by_key(|(&(_, l), &len)| (len, std::cmp::Reverse(l)));
        if let Some((&(_, l), _)) = best {
            new_part[c] = l;
        }
    }
    for (i, l) in labels.iter_mut().enumerate() {
        if *l != NONE {
            *l = new_part[piece[i]];
        }
    }
    labels
}

/// Chamfer distance (steps of 1 and √2) in pixels from every pixel to the nearest pixel labelled `part`.
pub(super) fn distance_to(labels: &[u32], part: u32, w: usize, h: usize) -> Vec<f32> {
    let far = f32::MAX / 4.0;
    let mut d: Vec<f32> = labels.iter().map(|&l| if l == part { 0.0 } else { far }).collect();
    let (a, b) = (1.0f32, std::f32::consts::SQRT_2);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let mut v = d[i];
            if x > 0 {
                v = v.min(d[i - 1] + a);
            }
            if y > 0 {
                v = v.min(d[i - w] + a);
                if x > 0 {
                    v = v.min(d[i - w - 1] + b);
                }
                if x + 1 < w {
                    v = v.min(d[i - w + 1] + b);
                }
            }
            d[i] = v;
        }
    }
    for y in (0..h).rev() {
        for x in (0..w).rev() {
            let i = y * w + x;
            let mut v = d[i];
            if x + 1 < w {
                v = v.min(d[i + 1] + a);
            }
            if y + 1 < h {
                v = v.min(d[i + w] + a);
                if x + 1 < w {
                    v = v.min(d[i + w + 1] + b);
                }
                if x > 0 {
                    v = v.min(d[i + w - 1] + b);
                }
            }
            d[i] = v;
        }
    }
    d
}

/// Labels every foreground pixel `y` of pose `t`: for each part, its place in the reference
/// `z = motion_t⁻¹(y)`; the cost is the mean distance, over the other poses `u`, between
/// `motion_u(z)` and where `y`'s correspondence says it went, plus `distance_weight` times how
/// far `z` lies from the part's region in the reference. Pixels without correspondences take
/// the most common label of their superpixel (or stay unlabelled if it has none).
#[allow(clippy::too_many_arguments)]
pub(super) fn label_pose(
    t: usize,
    pose: &SheetPose,
    sp: &Superpixels,
    flows: &Correspondences,
    motions: &[Vec<Similarity>],
    distance: &[Vec<f32>],
    [w, h]: [usize; 2],
    distance_weight: f32,
) -> Vec<u32> {
    let poses = flows.poses();
    let inverse: Vec<Similarity> = motions.iter().map(|m| safe_inverse(&m[t])).collect();
    let pw = pose.width();
    let mut labels = vec![NONE; pose.mask.len()];
    for (i, label) in labels.iter_mut().enumerate() {
        if !pose.mask[i] {
            continue;
        }
        let y = [(i % pw) as f32, (i / pw) as f32];
        let targets: Vec<(usize, [f32; 2])> = (0..poses)
            .filter(|&u| u != t)
            .filter_map(|u| flows.get(t, u).and_then(|f| f.at(i)).map(|q| (u, q)))
            .collect();
        if targets.is_empty() {
            continue;
        }
        let mut best = (f32::INFINITY, NONE);
        for (p, motion) in motions.iter().enumerate() {
            let z = inverse[p].apply(y);
            let motion_cost = targets
                .iter()
                .map(|&(u, q)| {
                    let m = if u == t { y } else { motion[u].apply(z) };
                    (m[0] - q[0]).hypot(m[1] - q[1])
                })
                .sum::<f32>()
                / targets.len() as f32;
            let (zx, zy) = (z[0].round(), z[1].round());
            let gap = if zx >= 0.0 && zy >= 0.0 && (zx as usize) < w && (zy as usize) < h {
                distance[p][zy as usize * w + zx as usize]
            } else {
                let cx = zx.clamp(0.0, (w - 1) as f32);
                let cy = zy.clamp(0.0, (h - 1) as f32);
                distance[p][cy as usize * w + cx as usize] + (zx - cx).hypot(zy - cy)
            };
            let cost = motion_cost + distance_weight * gap;
            if cost < best.0 {
                best = (cost, p as u32);
            }
        }
        *label = best.1;
    }
    fill_from_superpixels(&mut labels, sp, pose);
    labels
}

pub(super) fn safe_inverse(s: &Similarity) -> Similarity {
    if s.scale() > 1e-6 {
        s.inverse()
    } else {
        Similarity::IDENTITY
    }
}

/// Foreground pixels left unlabelled take their superpixel's most common label.
pub(super) fn fill_from_superpixels(labels: &mut [u32], sp: &Superpixels, pose: &SheetPose) {
    let mut votes: Vec<std::collections::BTreeMap<u32, usize>> = vec![Default::default(); sp.count];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE && sp.labels[i] != NONE {
            *votes[sp.labels[i] as usize].entry(l).or_default() += 1;
        }
    }
    let majority: Vec<u32> = votes
        .iter()
        .map(|v| v.iter().max_by_key(|(&l, &n)| (n, std::cmp::Reverse(l))).map_or(NONE, |(&l, _)| l))
        .collect();
    for (i, l) in labels.iter_mut().enumerate() {
        if *l == NONE && pose.mask[i] && sp.labels[i] != NONE {
            *l = majority[sp.labels[i] as usize];
        }
    }
}
