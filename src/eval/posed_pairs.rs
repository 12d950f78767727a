//! Correspondences scored on the posing engine's characters (`puppet prior data` folders): the
//! disjoint pairs of consecutive poses (0 → 1, 2 → 3, …), each vertex shown in both carried from
//! the first to the second by a correspondence network, PCK against its true place — the
//! protocol of `bench/flow_dis.py posed`, so DIS flow's figures sit beside these.

use std::path::Path;

use burn::tensor::Device;

use crate::error::{Error, Result};
use crate::metrics::pck;
use crate::parts::learn::TrainedNet;
use crate::picture::Picture;
use crate::posing::write::{pose_stems, PoseTruth};
use crate::prior::landings;
use crate::puppet::format;

/// The PCK thresholds, as shares of the frame's larger side.
pub const ALPHAS: [f64; 3] = [0.1, 0.05, 0.025];

/// One character's score.
#[derive(Clone, Debug, PartialEq)]
pub struct PosedScore {
    /// Pose pairs scored.
    pub pairs: usize,
    /// Vertices scored over all pairs.
    pub vertices: usize,
    /// PCK at each of [`ALPHAS`], the mean over pairs.
    pub pck: [f64; 3],
}

/// Scores `net` on the poses in `dir` (a character's folder from `puppet prior data`).
///
/// # Errors
/// [`Error::Format`] naming `dir` if it holds fewer than two poses; as [`format::load`],
/// [`PoseTruth::load`] and [`Picture::load`], naming the file; [`Error::Mismatch`] for a
/// frame of another size than the puppet's.
pub fn score_posed(dir: &Path, net: &TrainedNet, device: &Device) -> Result<PosedScore> {
    let puppet = format::load(&dir.join("puppet.json"))?;
    let stems = pose_stems(dir);
    if stems.len() < 2 {
        return Err(Error::format(dir, "fewer than two poses (pose_000.json, pose_001.json, …) to pair"));
    }
    let read = |stem: &Path| -> Result<(Picture, PoseTruth)> {
        let path = stem.with_extension("png");
        let picture = Picture::load(&path)?;
        if (picture.width, picture.height) != (puppet.width, puppet.height) {
            return Err(Error::mismatch(
                format!("{}: the frame's size", path.display()),
                format!("{}×{}", picture.width, picture.height),
                format!("{}×{}", puppet.width, puppet.height),
            ));
        }
        Ok((picture, PoseTruth::load(&stem.with_extension("json"), puppet.vertex_count())?))
    };
    let mut score = PosedScore {
        pairs: 0,
        vertices: 0,
        pck: [0.0; 3],
    };
    for pair in stems.chunks_exact(2) {
        let ((a, ta), (b, tb)) = (read(&pair[0])?, read(&pair[1])?);
        let both: Vec<usize> = (0..ta.vertices.len()).filter(|&k| ta.visible[k] && tb.visible[k]).collect();
        let points: Vec<[f32; 2]> = both.iter().map(|&k| ta.vertices[k]).collect();
        // A point the network cannot place counts as a miss.
        let predicted: Vec<[f32; 2]> = landings(net, &a, &b, &points, device)
            .into_iter()
            .map(|l| l.map_or([f32::INFINITY; 2], |l| l.at))
            .collect();
        let truth: Vec<[f32; 2]> = both.iter().map(|&k| tb.vertices[k]).collect();
        for (sum, alpha) in score.pck.iter_mut().zip(ALPHAS) {
            *sum += pck(&predicted, &truth, alpha, puppet.width, puppet.height);
        }
        score.pairs += 1;
        score.vertices += both.len();
    }
    for sum in &mut score.pck {
        *sum /= score.pairs as f64;
    }
    Ok(score)
}
