//! Articulated parts from a sprite sheet of poses (APES, apes-part-extraction.md; issue 16), so a
//! puppet needs no hand-painted label map: the poses ([`pose`]), their superpixels
//! ([`superpixels`]), correspondences between every pair ([`flow`]), parts from how superpixels
//! move ([`segment`], or the paper's set cover over candidates from every pair, [`cover`]),
//! hinges, joint tree and layer order ([`skeleton`]), the parts bent into every pose by ARAP
//! ([`deform`]) and the poses rebuilt from them ([`reconstruct`]), the artwork `puppet build`
//! reads ([`artwork`]), and part IoU against a truth ([`score`]).
//!
//! Correspondences come from outside this module: today from the generator's truth (the oracle,
//! `crate::synth::sheet_flow`), which measures the back end alone.

pub mod artwork;
pub mod cover;
pub mod deform;
pub mod flow;
pub mod hungarian;
mod labelling;
pub mod learn;
pub mod matching;
pub mod pose;
pub mod reconstruct;
pub mod score;
pub mod segment;
pub mod skeleton;
pub mod superpixels;

use crate::error::{Error, Result};
use crate::metrics::l2;
use crate::picture::Picture;
use crate::progress::Progress;
use cover::{CoverOptions, CoverReport};
use deform::{BendOptions, PartMesh, Rebuild};
use flow::Correspondences;
use pose::SheetPose;
use segment::{SegmentOptions, Segmentation};
use skeleton::Skeleton;
use superpixels::Superpixels;

/// Settings of the part finder.
#[derive(Clone, Debug, PartialEq)]
pub struct PartsOptions {
    /// Superpixels per pose (SLIC's target count).
    pub superpixels: usize,
    /// SLIC's compactness.
    pub compactness: f32,
    /// Drop correspondences more than this many pixels from their superpixel's similarity
    /// ([`Correspondences::keep_rigid`]) before merging; 0 keeps all.
    pub rigid_check: f32,
    /// Merging and labelling.
    pub segment: SegmentOptions,
    /// How parts are chosen.
    pub select: Selection,
    /// How the poses are rebuilt from the parts found, to show and measure them (the set cover
    /// scores its selections as [`CoverOptions::score`] says).
    pub rebuild: Rebuild,
}

/// How parts are chosen from the correspondences.
#[derive(Clone, Debug, PartialEq)]
pub enum Selection {
    /// Superpixels of one reference pose merged while they move together in every pose
    /// ([`segment::segment`]).
    Synchronised,
    /// The paper's set cover over candidates from every pair of poses ([`cover::cover`]).
    Cover(CoverOptions),
}

impl Default for PartsOptions {
    fn default() -> Self {
        PartsOptions {
            superpixels: 100,
            compactness: 10.0,
            rigid_check: 0.0,
            segment: SegmentOptions::default(),
            select: Selection::Synchronised,
            rebuild: Rebuild::Arap(BendOptions::default()),
        }
    }
}

/// [`PartsOptions::rigid_check`] for estimated correspondences (network or flow), pixels, chosen on
/// the tuning seeds (docs/results.md "Joints, rebuilt poses and tuning"); exact correspondences
/// take none, as any check only drops true ones there.
pub const ESTIMATED_RIGID_CHECK: f32 = 4.0;

/// The most superpixels per pose [`find_parts`] accepts (merging compares every adjacent pair
/// after each merge).
pub const MAX_SUPERPIXELS: usize = 2000;

/// Parts found on a sheet, with what they were found from.
#[derive(Clone, Debug)]
pub struct Parts {
    /// The poses.
    pub poses: Vec<SheetPose>,
    /// Superpixels of each pose.
    pub superpixels: Vec<Superpixels>,
    /// The parts in every pose, and their motions.
    pub segmentation: Segmentation,
    /// Hinges, tree and order.
    pub skeleton: Skeleton,
    /// What the set cover did, when it chose the parts.
    pub cover: Option<CoverReport>,
    /// Each part's control mesh and its place in every pose, when poses are rebuilt by ARAP.
    pub meshes: Option<Vec<PartMesh>>,
}

impl Parts {
    /// Pose `t` redrawn from the reference's parts, stacked back to front in the found order
    /// (bent by their meshes when the parts have them; [`reconstruct::redraw`]); straight alpha,
    /// the pose's size.
    pub fn rebuilt_pose(&self, t: usize) -> Picture {
        reconstruct::redraw(&self.poses, &self.segmentation, self.meshes.as_deref(), &self.skeleton.order, t)
    }

    /// How well the parts rebuild the poses: the mean over the poses of the L2 (DESIGN.md)
    /// between each pose and [`rebuilt_pose`](Self::rebuilt_pose), and beside it the same with
    /// the reference pose standing in for every pose (no parts at all).
    pub fn rebuild_l2(&self) -> (f64, f64) {
        let n = self.poses.len().max(1) as f64;
        let reference = &self.poses[self.segmentation.reference].image;
        let rebuilt = (0..self.poses.len())
            .map(|t| l2(&self.rebuilt_pose(t), &self.poses[t].image))
            .sum::<f64>();
        let unchanged = self.poses.iter().map(|p| l2(reference, &p.image)).sum::<f64>();
        (rebuilt / n, unchanged / n)
    }
}

/// A pose whose correspondences come back less than this share as often as the median pose's
/// does not correspond to the others (a back view, a turn) and is set aside.
pub const SET_ASIDE_SHARE: f64 = 0.8;

/// `poses` without those that do not correspond to the others ([`poses_to_set_aside`] by the
/// forward–backward check within `tolerance` pixels), each named in a warning through
/// `progress`, with the correspondences among the rest and the indices of the poses kept.
pub fn set_aside_strangers(
    poses: Vec<SheetPose>,
    flows: Correspondences,
    tolerance: f32,
    progress: &dyn Progress,
) -> (Vec<SheetPose>, Correspondences, Vec<usize>) {
    let consistency = flows.consistency(poses.first().map_or(1, SheetPose::width), tolerance);
    let SetAside { poses: aside, median } = poses_to_set_aside(&consistency);
    for &k in &aside {
        progress.warn(&format!(
            "{} set aside: {:.0} % of its correspondences come back, against {:.0} % for the median pose \
             (a back view or a turn no articulation explains); the parts come from the other poses",
            poses[k].name,
            100.0 * consistency[k],
            100.0 * median
        ));
    }
    let keep: Vec<usize> = (0..poses.len()).filter(|k| !aside.contains(k)).collect();
    if aside.is_empty() {
        return (poses, flows, keep);
    }
    let flows = flows.subset(&keep);
    let poses = poses
        .into_iter()
        .enumerate()
        .filter(|(k, _)| !aside.contains(k))
        .map(|(_, p)| p)
        .collect();
    (poses, flows, keep)
}

/// The poses to set aside before finding parts, and the median pose's consistency they fell
/// short of.
#[derive(Clone, Debug, PartialEq)]
pub struct SetAside {
    /// The poses set aside, in order.
    pub poses: Vec<usize>,
    /// The median of the poses' consistency.
    pub median: f64,
}

/// The poses to set aside before finding parts, by `consistency` (each pose's share of
/// correspondences that come back, [`flow::Correspondences::consistency`]): those below
/// [`SET_ASIDE_SHARE`] of the median, the least consistent first, as long as two poses remain.
pub fn poses_to_set_aside(consistency: &[f64]) -> SetAside {
    let mut sorted = consistency.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(1.0);
    let mut aside: Vec<usize> = (0..consistency.len())
        .filter(|&k| consistency[k] < SET_ASIDE_SHARE * median)
        .collect();
    aside.sort_by(|&a, &b| consistency[a].total_cmp(&consistency[b]));
    aside.truncate(consistency.len().saturating_sub(2));
    aside.sort_unstable();
    SetAside { poses: aside, median }
}

/// Finds the parts of `poses` given correspondences between every pair.
///
/// # Errors
/// [`Error::Setting`] for options out of range; as [`segment::segment`].
pub fn find_parts(poses: Vec<SheetPose>, flows: &Correspondences, options: &PartsOptions) -> Result<Parts> {
    if !(1..=MAX_SUPERPIXELS).contains(&options.superpixels) {
        return Err(Error::setting(
            "superpixels",
            options.superpixels,
            format!("1 to {MAX_SUPERPIXELS}"),
        ));
    }
    if !(options.rigid_check >= 0.0 && options.rigid_check.is_finite()) {
        return Err(Error::setting("rigid_check", options.rigid_check, "a number ≥ 0 (pixels)"));
    }
    if !(options.compactness > 0.0 && options.compactness.is_finite()) {
        return Err(Error::setting("compactness", options.compactness, "a positive number"));
    }
    let superpixels: Vec<Superpixels> = {
        use rayon::prelude::*;
        poses
            .par_iter()
            .map(|p| superpixels::slic(p, options.superpixels, options.compactness))
            .collect()
    };
    let checked;
    let flows = if options.rigid_check > 0.0 {
        let mut copy = flows.clone();
        copy.keep_rigid(&superpixels, poses[0].width(), options.rigid_check);
        checked = copy;
        &checked
    } else {
        flows
    };
    let (segmentation, cover) = match &options.select {
        Selection::Synchronised => (segment::segment(&poses, &superpixels, flows, &options.segment)?, None),
        Selection::Cover(cover) => {
            let (segmentation, report) = cover::cover(&poses, &superpixels, flows, &options.segment, cover)?;
            (segmentation, Some(report))
        }
    };
    let skeleton = skeleton::skeleton(&segmentation, poses[0].width());
    let meshes = options.rebuild.meshes(&poses, &segmentation, flows)?;
    Ok(Parts {
        poses,
        superpixels,
        segmentation,
        skeleton,
        cover,
        meshes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_far_below_the_median_go_and_two_poses_always_stay() {
        let aside = poses_to_set_aside(&[0.8, 0.5, 0.82, 0.79, 0.7, 0.45]);
        assert_eq!(aside.poses, vec![1, 5]);
        assert_eq!(aside.median, 0.79);
        assert!(poses_to_set_aside(&[0.9, 0.85, 0.8]).poses.is_empty());
        // However far below, two poses remain: the two most consistent.
        assert_eq!(poses_to_set_aside(&[0.1, 0.9, 0.05, 0.2]).poses, vec![0, 2]);
        assert!(poses_to_set_aside(&[]).poses.is_empty());
    }
}
