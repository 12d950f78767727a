//! Parts from motion, synchronised on one reference pose: superpixels of the reference are
//! merged while one similarity per other pose still explains where their pixels went in every
//! pose (two superpixels are one part only if they move together in every pair), then every
//! pixel of every pose takes the part whose motions best explain its own correspondences.
//!
//! This is the option issue 16 asks to measure against the paper's per-pair clustering and set
//! cover (apes-part-extraction.md §3.2–3.3): it uses every pose at once instead of pooling
//! pairwise candidates, and it labels pixels, not superpixels, so part boundaries are not held
//! to superpixel boundaries. Similarities, not rigid motions: poses vary in scale.

use rayon::prelude::*;

use super::flow::Correspondences;
use super::labelling::{distance_to, drop_small_parts, keep_largest_pieces, label_pose};
use super::pose::SheetPose;
use super::superpixels::{Superpixels, NONE};
use crate::error::{Error, Result};
use crate::geom::similarity::{Moments, Similarity};

/// How parts are found.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentOptions {
    /// The pose whose superpixels are merged (`None`: the pose with the most foreground, where
    /// parts hide each other least).
    pub reference: Option<usize>,
    /// Stop merging at this many parts (`None`: merge while the residual allows).
    pub parts: Option<usize>,
    /// Largest merge cost, as a fraction of the larger pose side: in the worst pose, how much
    /// one similarity fitted to both parts raises the RMS residual over one similarity each.
    pub merge_residual: f32,
    /// Parts smaller than this fraction of the reference's foreground join a neighbour.
    pub min_part: f32,
    /// Rounds of refitting the parts' motions to their pixels and relabelling the reference.
    pub refinements: usize,
    /// Weight, per pixel of distance, of how far a pixel's place in the reference lies from a
    /// part's region there, beside the motion residual, when pixels are labelled.
    pub distance_weight: f32,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        SegmentOptions {
            reference: None,
            parts: None,
            merge_residual: 0.011,
            min_part: 0.01,
            refinements: 5,
            distance_weight: 0.25,
        }
    }
}

/// Parts found on a sheet.
#[derive(Clone, Debug, PartialEq)]
pub struct Segmentation {
    /// The reference pose.
    pub reference: usize,
    /// Number of parts.
    pub parts: usize,
    /// Per pose, the row-major part of each pixel ([`NONE`] on the background).
    pub labels: Vec<Vec<u32>>,
    /// `motions[part][pose]`: the part's similarity from the reference to the pose (identity on
    /// the reference).
    pub motions: Vec<Vec<Similarity>>,
}

/// A cluster of reference superpixels: its members and its moments towards every pose.
#[derive(Clone)]
struct Cluster {
    members: Vec<usize>,
    size: usize,
    moments: Vec<Moments>,
}

impl Cluster {
    fn merge_cost(&self, other: &Cluster) -> f64 {
        merge_cost(&self.moments, &other.moments)
    }
}

/// What merging two sets of pixels costs: in the worst pose, how much one similarity fitted to
/// both raises the mean squared residual over keeping one each (Ward's criterion), as an RMS in
/// pixels. Exact correspondences leave each set's own residual near zero, so this is then the
/// union's residual; noisy ones (optical flow) raise every set's residual, and only the
/// increase says whether two sets move apart.
fn merge_cost(a: &[Moments], b: &[Moments]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let (nx, ny) = (x.count() as f64, y.count() as f64);
            if nx + ny == 0.0 {
                return 0.0;
            }
            let apart = (nx * x.mean_squared_residual() + ny * y.mean_squared_residual()) / (nx + ny);
            (x.merged(y).mean_squared_residual() - apart).max(0.0)
        })
        .fold(0.0, f64::max)
        .sqrt()
}

/// Finds the parts of `poses` from their correspondences and the reference pose's superpixels
/// (`superpixels[k]` of pose `k`).
///
/// # Errors
/// [`Error::Mismatch`] if correspondences are missing or sizes differ; [`Error::Setting`] for a
/// reference out of range or options out of range.
pub fn segment(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    options: &SegmentOptions,
) -> Result<Segmentation> {
    flows.check_complete()?;
    if flows.poses() != poses.len() || superpixels.len() != poses.len() {
        return Err(Error::mismatch(
            "poses, superpixels and correspondences",
            format!("{}, {}, {}", poses.len(), superpixels.len(), flows.poses()),
            "one count",
        ));
    }
    if !(options.merge_residual > 0.0 && options.merge_residual.is_finite()) {
        return Err(Error::setting(
            "merge residual",
            options.merge_residual,
            "a positive fraction of the pose size",
        ));
    }
    let reference = reference_pose(poses, options)?;
    let (w, h) = (poses[reference].width(), poses[reference].height());
    let size = w.max(h) as f64;
    let sp = &superpixels[reference];
    let others: Vec<usize> = (0..poses.len()).filter(|&t| t != reference).collect();
    // Moments of each superpixel towards each other pose.
    let mut clusters: Vec<Cluster> = (0..sp.count)
        .map(|k| Cluster {
            members: vec![k],
            size: sp.sizes[k],
            moments: vec![Moments::default(); others.len()],
        })
        .collect();
    for (slot, &t) in others.iter().enumerate() {
        let flow = flows.get(reference, t).expect("checked complete");
        for (i, &l) in sp.labels.iter().enumerate() {
            if l != NONE {
                if let Some(q) = flow.at(i) {
                    clusters[l as usize].moments[slot].add([(i % w) as f32, (i / w) as f32], q);
                }
            }
        }
    }
    let adjacent = superpixel_adjacency(sp, w);
    let mut cluster_of: Vec<usize> = (0..sp.count).collect();
    let mut alive: Vec<bool> = vec![true; sp.count];
    let threshold = options.merge_residual as f64 * size;
    let min_size = (options.min_part as f64 * poses[reference].area() as f64) as usize;
    let mut count = sp.count;
    // Greedy agglomeration over adjacent clusters, cheapest merge first.
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for &(a, b) in &adjacent {
            let (ca, cb) = (cluster_of[a], cluster_of[b]);
            if ca == cb {
                continue;
            }
            let cost = clusters[ca].merge_cost(&clusters[cb]);
            let key = (ca.min(cb), ca.max(cb));
            if best.is_none_or(|(c, x, y)| cost < c || (cost == c && key < (x, y))) {
                best = Some((cost, key.0, key.1));
            }
        }
        let Some((cost, a, b)) = best else { break };
        let small = clusters[a].size < min_size || clusters[b].size < min_size;
        let wanted = options.parts.is_some_and(|n| count > n);
        let under = options.parts.is_none() && cost <= threshold;
        if !(wanted || under || small) {
            // Only merges involving a part below the minimum size remain allowed.
            match cheapest_small_merge(&adjacent, &cluster_of, &clusters, min_size) {
                Some((a, b)) => merge(&mut clusters, &mut cluster_of, &mut alive, a, b),
                None => break,
            }
        } else {
            merge(&mut clusters, &mut cluster_of, &mut alive, a, b);
        }
        count -= 1;
    }
    let live: Vec<usize> = (0..clusters.len()).filter(|&c| alive[c]).collect();
    let part_of_cluster: std::collections::HashMap<usize, usize> = live.iter().enumerate().map(|(p, &c)| (c, p)).collect();
    let merged: Vec<u32> = sp
        .labels
        .iter()
        .map(|&l| {
            if l == NONE {
                NONE
            } else {
                part_of_cluster[&cluster_of[l as usize]] as u32
            }
        })
        .collect();
    // The merging above cannot undo an early merge across a boundary: refine, then merge parts
    // that still move together, until none do.
    Ok(settle(poses, superpixels, flows, options, reference, merged, live.len()))
}

/// The pose whose parts are found: the one asked for, or the one with the most foreground
/// (where parts hide each other least).
///
/// # Errors
/// [`Error::Setting`] for a reference out of range.
pub(super) fn reference_pose(poses: &[SheetPose], options: &SegmentOptions) -> Result<usize> {
    match options.reference {
        Some(r) if r >= poses.len() => Err(Error::setting("reference pose", r, format!("a pose number below {}", poses.len()))),
        Some(r) => Ok(r),
        None => Ok((0..poses.len())
            .max_by_key(|&k| (poses[k].area(), std::cmp::Reverse(k)))
            .unwrap_or(0)),
    }
}

/// Parts of every pose from a first labelling of the reference pose (`parts` parts,
/// [`NONE`] where it has none): Lloyd-style rounds refit the parts' motions and relabel the
/// reference's pixels, touching parts that still move together merge (unless the part count
/// is fixed), and every pixel of every pose takes the part whose motions explain it best.
/// `flows` must be complete and the options checked.
pub(super) fn settle(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    options: &SegmentOptions,
    reference: usize,
    initial: Vec<u32>,
    parts: usize,
) -> Segmentation {
    let (w, h) = (poses[reference].width(), poses[reference].height());
    let context = Reference {
        pose: &poses[reference],
        sp: &superpixels[reference],
        flows,
        index: reference,
        others: (0..poses.len()).filter(|&t| t != reference).collect(),
        size: [w, h],
        options,
        min_size: (options.min_part as f64 * poses[reference].area() as f64) as usize,
        threshold: options.merge_residual as f64 * w.max(h) as f64,
    };
    let (mut reference_labels, mut parts) = context.refine(initial, parts);
    if options.parts.is_none() {
        while let Some(fewer) = context.merge_touching(&reference_labels, parts) {
            (reference_labels, parts) = context.refine(fewer, parts - 1);
        }
    }
    let (motions, distance) = context.model(&reference_labels, parts);
    let labels = (0..poses.len())
        .into_par_iter()
        .map(|t| {
            if t == reference {
                reference_labels.clone()
            } else {
                label_pose(
                    t,
                    &poses[t],
                    &superpixels[t],
                    flows,
                    &motions,
                    &distance,
                    [w, h],
                    options.distance_weight,
                )
            }
        })
        .collect();
    Segmentation {
        reference,
        parts,
        labels,
        motions,
    }
}

/// The reference pose and what refining its parts needs.
struct Reference<'a> {
    pose: &'a SheetPose,
    sp: &'a Superpixels,
    flows: &'a Correspondences,
    index: usize,
    others: Vec<usize>,
    size: [usize; 2],
    options: &'a SegmentOptions,
    min_size: usize,
    threshold: f64,
}

impl Reference<'_> {
    /// Each part's moments towards every other pose, from its pixels.
    fn moments(&self, labels: &[u32], parts: usize) -> Vec<Vec<Moments>> {
        let w = self.size[0];
        let mut moments = vec![vec![Moments::default(); self.others.len()]; parts];
        for (slot, &t) in self.others.iter().enumerate() {
            let flow = self.flows.get(self.index, t).expect("checked complete");
            for (i, &l) in labels.iter().enumerate() {
                if l != NONE {
                    if let Some(q) = flow.at(i) {
                        moments[l as usize][slot].add([(i % w) as f32, (i / w) as f32], q);
                    }
                }
            }
        }
        moments
    }

    /// Each part's similarity to every pose (identity on the reference, and where a part has
    /// too few pixels for one), and its distance map in the reference.
    fn model(&self, labels: &[u32], parts: usize) -> (Vec<Vec<Similarity>>, Vec<Vec<f32>>) {
        let moments = self.moments(labels, parts);
        let mut motions = vec![vec![Similarity::IDENTITY; self.flows.poses()]; parts];
        for (p, m) in moments.iter().enumerate() {
            for (slot, &t) in self.others.iter().enumerate() {
                motions[p][t] = m[slot].fit().unwrap_or(Similarity::IDENTITY);
            }
        }
        let [w, h] = self.size;
        let distance = (0..parts).map(|p| distance_to(labels, p as u32, w, h)).collect();
        (motions, distance)
    }

    /// Lloyd-style rounds: motions fitted to the parts' pixels, pixels given to the part whose
    /// motions explain them best, stray pieces joined to a neighbour and parts below the minimum
    /// size dropped; until nothing changes. Returns the labels and the part count.
    fn refine(&self, mut labels: Vec<u32>, mut parts: usize) -> (Vec<u32>, usize) {
        let [w, h] = self.size;
        for _ in 0..self.options.refinements {
            let (motions, distance) = self.model(&labels, parts);
            let relabelled = keep_largest_pieces(
                label_pose(
                    self.index,
                    self.pose,
                    self.sp,
                    self.flows,
                    &motions,
                    &distance,
                    [w, h],
                    self.options.distance_weight,
                ),
                w,
            );
            let (relabelled, kept) = drop_small_parts(relabelled, parts, self.min_size, w);
            let unchanged = kept == parts && relabelled == labels;
            (labels, parts) = (relabelled, kept);
            if unchanged {
                break;
            }
        }
        (labels, parts)
    }

    /// The labels with the two touching parts that move together best merged, if their union's
    /// worst-pose RMS residual is within the threshold.
    fn merge_touching(&self, labels: &[u32], parts: usize) -> Option<Vec<u32>> {
        let moments = self.moments(labels, parts);
        let w = self.size[0];
        let mut best: Option<(f64, u32, u32)> = None;
        let mut seen = std::collections::BTreeSet::new();
        for (i, &a) in labels.iter().enumerate() {
            for j in [(i % w + 1 < w).then(|| i + 1), (i + w < labels.len()).then(|| i + w)]
                .into_iter()
                .flatten()
            {
                let b = labels[j];
                if a == NONE || b == NONE || a == b || !seen.insert((a.min(b), a.max(b))) {
                    continue;
                }
                let (a, b) = (a.min(b), a.max(b));
                let cost = merge_cost(&moments[a as usize], &moments[b as usize]);
                if cost <= self.threshold && best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, b));
                }
            }
        }
        let (_, a, b) = best?;
        Some(
            labels
                .iter()
                .map(|&l| {
                    if l == b {
                        a
                    } else if l != NONE && l > b {
                        l - 1
                    } else {
                        l
                    }
                })
                .collect(),
        )
    }
}

fn merge(clusters: &mut [Cluster], cluster_of: &mut [usize], alive: &mut [bool], a: usize, b: usize) {
    let (keep, gone) = (a.min(b), a.max(b));
    let moved = std::mem::take(&mut clusters[gone].members);
    for &m in &moved {
        cluster_of[m] = keep;
    }
    let moments: Vec<Moments> = clusters[keep]
        .moments
        .iter()
        .zip(&clusters[gone].moments)
        .map(|(x, y)| x.merged(y))
        .collect();
    let size = clusters[gone].size;
    let target = &mut clusters[keep];
    target.members.extend(moved);
    target.moments = moments;
    target.size += size;
    alive[gone] = false;
}

fn cheapest_small_merge(
    adjacent: &[(usize, usize)],
    cluster_of: &[usize],
    clusters: &[Cluster],
    min_size: usize,
) -> Option<(usize, usize)> {
    let mut best: Option<(f64, usize, usize)> = None;
    for &(a, b) in adjacent {
        let (ca, cb) = (cluster_of[a], cluster_of[b]);
        if ca == cb || (clusters[ca].size >= min_size && clusters[cb].size >= min_size) {
            continue;
        }
        let cost = clusters[ca].merge_cost(&clusters[cb]);
        if best.is_none_or(|(c, _, _)| cost < c) {
            best = Some((cost, ca, cb));
        }
    }
    best.map(|(_, a, b)| (a, b))
}

/// Pairs of superpixels sharing a 4-neighbour border, each pair once, sorted.
fn superpixel_adjacency(sp: &Superpixels, w: usize) -> Vec<(usize, usize)> {
    let n = sp.labels.len();
    let mut pairs = std::collections::BTreeSet::new();
    for i in 0..n {
        let a = sp.labels[i];
        if a == NONE {
            continue;
        }
        for j in [(i % w + 1 < w).then(|| i + 1), (i + w < n).then(|| i + w)].into_iter().flatten() {
            let b = sp.labels[j];
            if b != NONE && b != a {
                pairs.insert((a.min(b) as usize, a.max(b) as usize));
            }
        }
    }
    pairs.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parts::flow::Flow;
    use crate::parts::score::part_iou;
    use crate::parts::skeleton::skeleton;
    use crate::parts::superpixels::slic;
    use crate::picture::Picture;

    /// Two rectangles, a body and an arm hinged to it at `PIVOT` (reference coordinates), in
    /// four poses: each pose moves the body by a similarity and turns the arm about the pivot.
    const PIVOT: [f32; 2] = [40.0, 30.0];

    fn motions() -> Vec<[Similarity; 2]> {
        let about = |angle: f32| {
            Similarity::new(0.0, 1.0, PIVOT)
                .compose(&Similarity::new(angle, 1.0, [0.0, 0.0]))
                .compose(&Similarity::new(0.0, 1.0, [-PIVOT[0], -PIVOT[1]]))
        };
        [
            (0.0, 1.0, [0.0, 0.0], 0.0),
            (0.2, 1.05, [4.0, 2.0], 0.9),
            (-0.15, 0.95, [-3.0, 3.0], -0.7),
            (0.1, 1.0, [2.0, -4.0], 1.4),
        ]
        .into_iter()
        .map(|(angle, scale, t, bend)| {
            // Rotations about the body's centre keep the pose inside the frame.
            let body = Similarity::new(0.0, 1.0, [32.0 + t[0], 32.0 + t[1]])
                .compose(&Similarity::new(angle, scale, [0.0, 0.0]))
                .compose(&Similarity::new(0.0, 1.0, [-32.0, -32.0]));
            [body, body.compose(&about(bend))]
        })
        .collect()
    }

    /// Which part a reference point belongs to: the body is 20..44 × 18..50, the arm 40..58 × 27..33.
    fn part_at(p: [f32; 2]) -> Option<usize> {
        if (40.0..58.0).contains(&p[0]) && (27.0..33.0).contains(&p[1]) {
            Some(1)
        } else if (20.0..44.0).contains(&p[0]) && (18.0..50.0).contains(&p[1]) {
            Some(0)
        } else {
            None
        }
    }

    #[test]
    fn two_parts_moving_apart_are_found_exactly_with_their_hinge() {
        let n = 64usize;
        let motions = motions();
        let mut poses = Vec::new();
        let mut truth = Vec::new();
        // Draw each pose by pulling pixels back through each part's motion, arm in front.
        for m in &motions {
            let mut image = Picture::filled(n as u32, n as u32, [0.0; 4]);
            let mut labels = vec![NONE; n * n];
            for (i, (pixel, label)) in image.pixels.iter_mut().zip(labels.iter_mut()).enumerate() {
                let y = [(i % n) as f32, (i / n) as f32];
                if let Some(part) = [1, 0].into_iter().find(|&part| part_at(m[part].inverse().apply(y)) == Some(part)) {
                    *pixel = if part == 0 { [0.8, 0.3, 0.2, 1.0] } else { [0.2, 0.5, 0.8, 1.0] };
                    *label = part as u32;
                }
            }
            poses.push(SheetPose::new("pose", image));
            truth.push(labels);
        }
        let mut flows = Correspondences::new(poses.len(), n * n);
        for s in 0..poses.len() {
            for t in (0..poses.len()).filter(|&t| t != s) {
                let to = truth[s]
                    .iter()
                    .enumerate()
                    .map(|(i, &l)| {
                        if l == NONE {
                            return [f32::NAN; 2];
                        }
                        let p = l as usize;
                        motions[t][p].apply(motions[s][p].inverse().apply([(i % n) as f32, (i / n) as f32]))
                    })
                    .collect();
                flows.set(s, t, Flow { to }).expect("a pair of poses");
            }
        }
        let superpixels: Vec<Superpixels> = poses.iter().map(|p| slic(p, 30, 10.0)).collect();
        let options = SegmentOptions {
            reference: Some(0),
            ..SegmentOptions::default()
        };
        let seg = segment(&poses, &superpixels, &flows, &options).expect("segments");
        assert_eq!(seg.parts, 2);
        let scores = part_iou(&seg.labels, &truth, 2, 2);
        assert!(scores.strict > 0.99, "{scores:?}");
        let sk = skeleton(&seg, n);
        assert_eq!(sk.hinges.len(), 1);
        let pivot = sk.hinges[0].pivot;
        assert!((pivot[0] - PIVOT[0]).hypot(pivot[1] - PIVOT[1]) < 0.5, "{pivot:?}");
        // The arm is drawn over the body.
        let arm = seg.labels[0][30 * n + 50] as usize;
        assert_eq!(sk.order.last(), Some(&arm));
        // Asking for one part merges them.
        let one = segment(&poses, &superpixels, &flows, &SegmentOptions { parts: Some(1), ..options }).expect("segments");
        assert_eq!(one.parts, 1);
    }
}
