//! Correspondence accuracy on synthetic pairs with ground truth (neural-puppet.md §4.3, Table 2
//! protocol): for ordered pairs (a, b) of held-out frames, keypoints visible in a are carried
//! into b through the fitted template ([`correspond`]) and compared with where the truth puts
//! them; PCK@α per pair (DESIGN.md: within α·max(W, H)), averaged over pairs.
//!
//! Keypoints are the template's vertices, placed in frame a by the truth (each layer by the part
//! of the same name), kept where frame a's label map shows that part at the point's pixel —
//! i.e. visible, as an annotator would click them. Their truth in b is the same rest point mapped
//! by b's truth. A keypoint our fit of a does not cover counts as a miss.

use std::path::{Path, PathBuf};

use burn::tensor::Device;

use crate::edit::correspond::correspond;
use crate::error::{Error, Result};
use crate::fit::frame::frame_check;
use crate::fit::{fit, FitOptions};
use crate::metrics::{pck, PCK_ALPHAS};
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::sequence::Frames;
use crate::puppet::Puppet;
use crate::synth::Truth;
use crate::train::trainer::SplitRecord;

/// One ordered pair's keypoints and matches.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PairKeypoints {
    /// Frame a's image file.
    pub a: PathBuf,
    /// Frame b's image file.
    pub b: PathBuf,
    /// Visible keypoints in a, frame pixels.
    pub points_a: Vec<[f32; 2]>,
    /// Their true positions in b.
    pub truth_b: Vec<[f32; 2]>,
    /// Our matches in b (`None`: not on our fit of a).
    pub ours_b: Vec<Option<[f32; 2]>>,
}

/// Everything the optical-flow peer (bench/flow_dis.py) needs, and our scores.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PckPairs {
    /// Frame width (pixels).
    pub width: u32,
    /// Frame height (pixels).
    pub height: u32,
    /// The α of each PCK entry.
    pub alphas: Vec<f64>,
    /// The pairs.
    pub pairs: Vec<PairKeypoints>,
    /// Our PCK@α (share in [0, 1]) per α, averaged over pairs.
    pub ours: Vec<f64>,
}

/// A keypoint: a template vertex as placed in one frame by the truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    /// Index of its part in [`Truth::parts`].
    pub part: usize,
    /// Its rest (template) position, pixels.
    pub rest: [f32; 2],
    /// Its position in the frame, pixels.
    pub position: [f32; 2],
}

/// The visible keypoints of frame `f` (module doc).
///
/// # Errors
/// [`Error::Mismatch`] if a layer of `puppet` names no part of `truth` or `f` is past its frames;
/// label-map read errors name the file.
pub fn visible_keypoints(truth: &Truth, sequence_dir: &Path, f: usize, puppet: &Puppet) -> Result<Vec<Keypoint>> {
    let frame = truth
        .frames
        .get(f)
        .ok_or_else(|| Error::mismatch("the truth's frame count", truth.frames.len(), format!("more than {f}")))?;
    let labels = Picture::load(&sequence_dir.join(&frame.labels))?;
    let mut out = Vec::new();
    for layer in &puppet.layers {
        let part = truth
            .part_index(&layer.name)
            .ok_or_else(|| Error::mismatch(format!("layer {:?}", layer.name), "in the puppet", "a part of the truth"))?;
        let colour = crate::puppet::character::parse_color(&truth.parts[part].label)
            .map_err(|e| Error::setting(format!("the truth's part {:?} label", layer.name), &truth.parts[part].label, e))?;
        for &r in &layer.mesh.vertices {
            let p = truth.map_point(f, part, r);
            let (x, y) = (p[0].floor(), p[1].floor());
            if x < 0.0 || y < 0.0 || x >= labels.width as f32 || y >= labels.height as f32 {
                continue;
            }
            let l = labels.get(x as u32, y as u32);
            let rgb = [l[0], l[1], l[2]].map(|c| (c * 255.0).round() as u8);
            if l[3] > 0.5 && rgb == colour {
                out.push(Keypoint {
                    part,
                    rest: r,
                    position: p,
                });
            }
        }
    }
    Ok(out)
}

/// Scores correspondences on `pairs` (indices into `files`/`fits`, which are the sequence's
/// frame files and our fitted poses of them, frame pixels).
///
/// # Errors
/// As [`visible_keypoints`]; [`Error::Mismatch`] for an index out of range or a fit of the
/// wrong size.
pub fn pck_pairs(
    truth: &Truth,
    sequence_dir: &Path,
    files: &[PathBuf],
    fits: &[Vec<[f32; 2]>],
    puppet: &Puppet,
    pairs: &[(usize, usize)],
) -> Result<PckPairs> {
    let mut out = Vec::with_capacity(pairs.len());
    let mut sums = [0.0f64; 3];
    for &(a, b) in pairs {
        if a >= files.len() || b >= files.len() || a >= fits.len() || b >= fits.len() {
            return Err(Error::mismatch(
                format!("pck: pair ({a}, {b})"),
                "past the frames",
                format!("below {}", files.len()),
            ));
        }
        let keypoints = visible_keypoints(truth, sequence_dir, a, puppet)?;
        let points_a: Vec<[f32; 2]> = keypoints.iter().map(|k| k.position).collect();
        let truth_b: Vec<[f32; 2]> = keypoints.iter().map(|k| truth.map_point(b, k.part, k.rest)).collect();
        let ours_b: Vec<Option<[f32; 2]>> = correspond(puppet, &fits[a], &fits[b], &points_a)?
            .into_iter()
            .map(|c| c.map(|c| c.to))
            .collect();
        // A miss is placed at infinity so it never counts as correct.
        let predicted: Vec<[f32; 2]> = ours_b.iter().map(|p| p.unwrap_or([f32::INFINITY; 2])).collect();
        for (s, &alpha) in sums.iter_mut().zip(&PCK_ALPHAS) {
            *s += pck(&predicted, &truth_b, alpha, puppet.width, puppet.height);
        }
        out.push(PairKeypoints {
            a: files[a].clone(),
            b: files[b].clone(),
            points_a,
            truth_b,
            ours_b,
        });
    }
    let n = pairs.len().max(1) as f64;
    Ok(PckPairs {
        width: puppet.width,
        height: puppet.height,
        alphas: PCK_ALPHAS.to_vec(),
        pairs: out,
        ours: sums.iter().map(|s| s / n).collect(),
    })
}

/// All ordered pairs (a, b), a ≠ b, of `frames`.
pub fn ordered_pairs(frames: &[usize]) -> Vec<(usize, usize)> {
    frames
        .iter()
        .flat_map(|&a| frames.iter().filter(move |&&b| b != a).map(move |&b| (a, b)))
        .collect()
}

/// Which frames of a sequence a PCK score holds out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeldOut {
    /// The frames the model's split.json held out of its training.
    Split,
    /// The odd frames (a sequence the model never saw, scored as the in-between protocol does).
    Odd,
}

/// The correspondence protocol on a synthetic sequence: the `held_out` frames are fitted with
/// `fit_options`, and every ordered pair of them scored by [`pck_pairs`].
///
/// # Errors
/// [`Error::Format`] naming the sequence if it has no truth.json, or the model folder if it has
/// no split.json (for [`HeldOut::Split`]), if its held-out frames are not all in the sequence,
/// or if fewer than two frames are held out; as [`Frames::load`], [`fit`] and [`pck_pairs`].
pub fn score_sequence(
    model_dir: &Path,
    model: &Model,
    sequence: &Path,
    held_out: HeldOut,
    fit_options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<(PckPairs, Vec<(usize, usize)>)> {
    let frames = Frames::load(sequence, &frame_check(model))?;
    let truth = Truth::for_sequence(sequence)?.ok_or_else(|| Error::format(sequence, "no truth.json (PCK needs a synthetic sequence)"))?;
    let test: Vec<usize> = match held_out {
        HeldOut::Odd => (1..frames.frames.len()).step_by(2).collect(),
        HeldOut::Split => SplitRecord::load(model_dir)?
            .ok_or_else(|| Error::format(model_dir, "no split.json (was the model trained by puppet?)"))?
            .test_indices(&frames.names())
            .ok_or_else(|| {
                Error::format(
                    model_dir,
                    format!("the model's held-out frames are not all in {}", sequence.display()),
                )
            })?,
    };
    if test.len() < 2 {
        return Err(Error::format(model_dir, "fewer than two held-out frames, no pair to score"));
    }
    progress.stage("fit", test.len() as u64);
    let pictures: Vec<&Picture> = test.iter().map(|&t| &frames.frames[t]).collect();
    let fitted = fit(model, &pictures, fit_options, device, progress)?;
    let mut fits = vec![Vec::new(); frames.frames.len()];
    for (&t, pose) in test.iter().zip(fitted) {
        fits[t] = pose;
    }
    let pairs = ordered_pairs(&test);
    let scored = pck_pairs(&truth, &frames.root, &frames.files, &fits, &model.puppet, &pairs)?;
    Ok((scored, pairs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::synth::{self, SynthOptions};

    #[test]
    fn true_fits_score_full_pck_and_rest_fits_score_less() {
        let dir = tempfile::tempdir().unwrap();
        let opts = SynthOptions {
            seed: 5,
            frames: 4,
            width: 96,
            height: 96,
            ..SynthOptions::default()
        };
        let seq = synth::generate(&opts, &Silent).unwrap();
        synth::write_sequence(&seq, dir.path(), &Silent).unwrap();
        let art = crate::puppet::artwork::load(&dir.path().join("template"), &Default::default()).unwrap();
        let puppet = crate::puppet::build::build(&art, &Default::default(), &Silent).unwrap().0;
        let truth = Truth::load(&dir.path().join("truth.json")).unwrap();
        let files: Vec<PathBuf> = truth.frames.iter().map(|f| dir.path().join(&f.file)).collect();
        let exact: Vec<Vec<[f32; 2]>> = (0..4).map(|f| synth::true_positions(&truth, f, &puppet).unwrap()).collect();
        let pairs = ordered_pairs(&[0, 1, 2, 3]);
        assert_eq!(pairs.len(), 12);
        let scored = pck_pairs(&truth, dir.path(), &files, &exact, &puppet, &pairs).unwrap();
        assert!(scored.pairs.iter().all(|p| p.points_a.len() > 10), "few visible keypoints");
        // With the true meshes, a visible keypoint binds to its own layer (it is in front), so
        // it maps exactly — up to points on a layer edge that bind to a neighbour in front.
        assert!(scored.ours[2] > 0.97, "{:?}", scored.ours);
        let rest = vec![puppet.rest_vertices(); 4];
        let worse = pck_pairs(&truth, dir.path(), &files, &rest, &puppet, &pairs).unwrap();
        assert!(worse.ours[2] < scored.ours[2], "{:?} vs {:?}", worse.ours, scored.ours);
        assert!(pck_pairs(&truth, dir.path(), &files, &exact, &puppet, &[(0, 9)]).is_err());
    }
}
