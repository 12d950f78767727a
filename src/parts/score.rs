//! Part IoU (apes-part-extraction.md §5.1: "Hungarian matching between ground-truth and
//! reconstructed parts based on IoU, 1 − IoU as cost"), three ways:
//! - **paper**: one matching per pose, the IoU averaged over its matched pairs, then over poses;
//! - **strict**: one matching for the whole sheet on intersections and unions pooled over poses,
//!   every true part scored (0 when no predicted part is left for it), averaged over true parts;
//! - **merged**: for truth coarser than the prediction (a hand-painted label map whose "arm"
//!   is two APES parts), each predicted part joins the true part it overlaps most, and the IoU
//!   of each true part with the union of its predicted parts is averaged over true parts.

use super::hungarian::assign;
use super::superpixels::NONE;

/// The parts of label maps drawn one flat colour per part: every distinct opaque colour (alpha
/// ≥ ½, 8-bit) is a part, numbered in order of first appearance over the poses; and the count.
pub fn labels_by_colour(maps: &[&crate::picture::Picture]) -> (Vec<Vec<u32>>, usize) {
    let mut colours: std::collections::HashMap<[u8; 3], u32> = std::collections::HashMap::new();
    let labels = maps
        .iter()
        .map(|m| {
            m.pixels
                .iter()
                .map(|p| {
                    if p[3] < 0.5 {
                        return NONE;
                    }
                    let rgb = [p[0], p[1], p[2]].map(|c| (c * 255.0).round() as u8);
                    let next = colours.len() as u32;
                    *colours.entry(rgb).or_insert(next)
                })
                .collect()
        })
        .collect();
    (labels, colours.len())
}

/// Part IoU of one sheet.
#[derive(Clone, Debug, PartialEq)]
pub struct PartScores {
    /// The paper's protocol.
    pub paper: f64,
    /// One matching per sheet, unmatched true parts 0.
    pub strict: f64,
    /// Predicted parts merged into the true part they overlap most.
    pub merged: f64,
    /// The paper's score of each pose.
    pub per_pose: Vec<f64>,
    /// Number of predicted parts seen on the sheet.
    pub predicted_parts: usize,
    /// Number of true parts seen on the sheet.
    pub true_parts: usize,
}

/// Pixel counts of one pose or of a whole sheet: `inter[t * predicted + p]`, and each part's area.
struct Overlap {
    inter: Vec<u64>,
    truth_area: Vec<u64>,
    predicted_area: Vec<u64>,
}

impl Overlap {
    fn new(truth_parts: usize, predicted_parts: usize) -> Self {
        Overlap {
            inter: vec![0; truth_parts * predicted_parts],
            truth_area: vec![0; truth_parts],
            predicted_area: vec![0; predicted_parts],
        }
    }

    fn add(&mut self, predicted: &[u32], truth: &[u32]) {
        let np = self.predicted_area.len();
        for (&p, &t) in predicted.iter().zip(truth) {
            if p != NONE {
                self.predicted_area[p as usize] += 1;
            }
            if t != NONE {
                self.truth_area[t as usize] += 1;
                if p != NONE {
                    self.inter[t as usize * np + p as usize] += 1;
                }
            }
        }
    }

    fn iou(&self, t: usize, p: usize) -> f64 {
        let i = self.inter[t * self.predicted_area.len() + p];
        let union = self.truth_area[t] + self.predicted_area[p] - i;
        if union == 0 {
            0.0
        } else {
            i as f64 / union as f64
        }
    }

    /// Matches the present true parts to the present predicted parts; the IoU of each true part
    /// (`None` if absent, 0 if present and unmatched).
    fn matched(&self) -> Vec<Option<f64>> {
        let truth: Vec<usize> = (0..self.truth_area.len()).filter(|&t| self.truth_area[t] > 0).collect();
        let predicted: Vec<usize> = (0..self.predicted_area.len()).filter(|&p| self.predicted_area[p] > 0).collect();
        let cost: Vec<f64> = truth
            .iter()
            .flat_map(|&t| predicted.iter().map(move |&p| (t, p)))
            .map(|(t, p)| 1.0 - self.iou(t, p))
            .collect();
        let assignment = assign(&cost, truth.len(), predicted.len());
        let mut out = vec![None; self.truth_area.len()];
        for (k, &t) in truth.iter().enumerate() {
            out[t] = Some(assignment[k].map_or(0.0, |c| self.iou(t, predicted[c])));
        }
        out
    }
}

/// Scores predicted label maps against true ones, pose by pose (row-major, [`NONE`] on the
/// background; predicted labels below `predicted_parts`, true below `true_parts`).
///
/// # Panics
/// If the pose counts or sizes differ, or a label is out of range (caller bugs).
pub fn part_iou(predicted: &[Vec<u32>], truth: &[Vec<u32>], predicted_parts: usize, true_parts: usize) -> PartScores {
    assert_eq!(predicted.len(), truth.len(), "pose counts differ");
    let mut sheet = Overlap::new(true_parts, predicted_parts);
    let mut per_pose = Vec::new();
    for (p, t) in predicted.iter().zip(truth) {
        assert_eq!(p.len(), t.len(), "pose sizes differ");
        let mut pose = Overlap::new(true_parts, predicted_parts);
        pose.add(p, t);
        sheet.add(p, t);
        // The paper's average runs over matched pairs only.
        let matched: Vec<f64> = pose.matched().into_iter().flatten().filter(|&v| v > 0.0).collect();
        per_pose.push(if matched.is_empty() {
            0.0
        } else {
            matched.iter().sum::<f64>() / matched.len() as f64
        });
    }
    let strict: Vec<f64> = sheet.matched().into_iter().flatten().collect();
    let mean = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    PartScores {
        paper: mean(&per_pose),
        strict: mean(&strict),
        merged: merged_iou(&sheet),
        per_pose,
        predicted_parts: sheet.predicted_area.iter().filter(|&&a| a > 0).count(),
        true_parts: strict.len(),
    }
}

fn merged_iou(sheet: &Overlap) -> f64 {
    let (nt, np) = (sheet.truth_area.len(), sheet.predicted_area.len());
    let mut inter = vec![0u64; nt];
    let mut area = vec![0u64; nt];
    for p in (0..np).filter(|&p| sheet.predicted_area[p] > 0) {
        let best = (0..nt).max_by_key(|&t| (sheet.inter[t * np + p], std::cmp::Reverse(t)));
        if let Some(t) = best.filter(|&t| sheet.inter[t * np + p] > 0) {
            inter[t] += sheet.inter[t * np + p];
            area[t] += sheet.predicted_area[p];
        }
    }
    let scores: Vec<f64> = (0..nt)
        .filter(|&t| sheet.truth_area[t] > 0)
        .map(|t| inter[t] as f64 / (sheet.truth_area[t] + area[t] - inter[t]) as f64)
        .collect();
    if scores.is_empty() {
        0.0
    } else {
        scores.iter().sum::<f64>() / scores.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_relabelled_truth_scores_one_and_a_split_part_is_scored_three_ways() {
        // Two poses of four pixels and a background pixel: true parts 0 and 1.
        let truth = vec![vec![0, 0, 1, 1, NONE], vec![1, 1, 0, 0, NONE]];
        let renamed = vec![vec![5, 5, 2, 2, NONE], vec![2, 2, 5, 5, NONE]];
        let s = part_iou(&renamed, &truth, 6, 2);
        assert_eq!((s.paper, s.strict, s.merged), (1.0, 1.0, 1.0));
        assert_eq!((s.predicted_parts, s.true_parts), (2, 2));
        // Part 1 predicted as two parts: the paper's protocol averages the matched pairs only
        // (1 and ½), strict scores part 1 by its best match (½), merged joins the halves (1).
        let split = vec![vec![0, 0, 1, 2, NONE], vec![1, 2, 0, 0, NONE]];
        let s = part_iou(&split, &truth, 3, 2);
        assert!((s.paper - 0.75).abs() < 1e-12 && (s.strict - 0.75).abs() < 1e-12, "{s:?}");
        assert_eq!(s.merged, 1.0);
        // Labels swapped between the poses: each pose alone matches perfectly, the sheet does not.
        let swapped = vec![vec![0, 0, 1, 1, NONE], vec![0, 0, 1, 1, NONE]];
        let s = part_iou(&swapped, &truth, 2, 2);
        assert_eq!(s.paper, 1.0);
        assert!((s.strict - 1.0 / 3.0).abs() < 1e-12, "{s:?}");
    }
}
