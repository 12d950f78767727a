//! Scoring a trained model on frames (`puppet eval`): fit each frame, render the fit crisply at
//! the frame's size, and measure it with [`crate::metrics`]; where the sequence has ground
//! truth, also the fitted vertices against the true ones (vertex error, PCK).

use burn::tensor::Device;
use serde::Serialize;

use super::rig::{pose_scores, Scores};
use super::visibility::visible_vertices;
use crate::error::{Context, Error, Result};
use crate::fit::{fit, FitOptions};
use crate::metrics::{l2, masked_rmse, pck, silhouette_iou, vertex_error, PCK_ALPHAS};
use crate::model::Model;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::sequence::Frames;
use crate::render::render_crisp;
use crate::synth::{true_positions, Truth};

/// One frame's scores.
#[derive(Clone, Debug, Serialize)]
pub struct FrameScores {
    /// The frame's file name.
    pub frame: String,
    /// L2 (Table 1's quantity).
    pub l2: f64,
    /// Masked RMSE.
    pub masked_rmse: f64,
    /// Silhouette IoU.
    pub iou: f64,
    /// Mean fitted-vertex error in pixels (ground truth only).
    pub vertex_error: Option<f64>,
    /// PCK at [`PCK_ALPHAS`] of the fitted vertices (ground truth only).
    pub pck: Option<[f64; 3]>,
    /// Vertex error over the vertices the frame shows ([`visible_vertices`] at the true pose).
    pub visible_vertex_error: Option<f64>,
    /// PCK at [`PCK_ALPHAS`] over the vertices the frame shows.
    pub visible_pck: Option<[f64; 3]>,
    /// The share of vertices the frame shows.
    pub visible_share: Option<f64>,
    /// L2 of the puppet rendered at the TRUE vertices (ground truth only): what placing every
    /// vertex exactly scores (texture resampling, drawing the generator does that a mesh cannot).
    /// Not a floor: a fit that moves vertices off the truth can absorb part of the generator's
    /// non-affine deformation and score lower.
    pub true_pose_l2: Option<f64>,
    /// Silhouette IoU of the puppet rendered at the true vertices (ground truth only).
    pub true_pose_iou: Option<f64>,
}

/// Scores of a set of frames and their means.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Per frame, in sequence order.
    pub frames: Vec<FrameScores>,
    /// Means over frames (vertex error and PCK over frames with truth).
    pub mean: FrameScores,
    /// With an accessory rig: how the rig-placed accessories hold up on the fitted poses, the
    /// worst over the frames ([`pose_scores`]).
    pub accessories: Option<Scores>,
}

/// Fits (as `options` say) and scores `frames.frames[i]` for each `i` in `indices` (all frames if
/// empty), against `truth` where given (matched to frames by file name).
///
/// # Errors
/// A frame of the wrong size (naming the file); truth that does not fit the puppet.
pub fn evaluate(
    model: &Model,
    frames: &Frames,
    indices: &[usize],
    truth: Option<&Truth>,
    options: &FitOptions,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Report> {
    let indices: Vec<usize> = if indices.is_empty() {
        (0..frames.frames.len()).collect()
    } else {
        indices.to_vec()
    };
    let names = frames.names();
    let pictures: Vec<&Picture> = indices.iter().map(|&i| &frames.frames[i]).collect();
    for (&i, picture) in indices.iter().zip(&pictures) {
        model.check_frame(picture).at_path(&frames.files[i])?;
    }
    progress.stage("fit", pictures.len() as u64);
    let fits = fit(model, &pictures, options, device, progress)?;
    let mut scores = Vec::with_capacity(indices.len());
    for ((&i, picture), fit) in indices.iter().zip(&pictures).zip(&fits) {
        let render = render_crisp(&model.puppet, fit, picture.width, picture.height)?;
        let truth = match truth {
            Some(t) => {
                let k = t
                    .frame_named(&names[i])
                    .ok_or_else(|| Error::mismatch(format!("frame {:?}", names[i]), "not in truth.json", "a frame it describes"))?;
                Some(truth_scores(t, k, model, fit, picture)?)
            }
            None => None,
        };
        scores.push(FrameScores {
            frame: names[i].clone(),
            l2: l2(&render, picture),
            masked_rmse: masked_rmse(&render, picture),
            iou: silhouette_iou(&render, picture),
            vertex_error: truth.map(|t| t.vertex_error),
            pck: truth.map(|t| t.pck),
            visible_vertex_error: truth.map(|t| t.visible_vertex_error),
            visible_pck: truth.map(|t| t.visible_pck),
            visible_share: truth.map(|t| t.visible_share),
            true_pose_l2: truth.map(|t| t.true_pose_l2),
            true_pose_iou: truth.map(|t| t.true_pose_iou),
        });
    }
    let mean = mean_scores(&scores);
    Ok(Report {
        frames: scores,
        mean,
        accessories: pose_scores(&model.puppet, &fits),
    })
}

/// The scores that need ground truth.
#[derive(Clone, Copy)]
struct TruthScores {
    vertex_error: f64,
    pck: [f64; 3],
    visible_vertex_error: f64,
    visible_pck: [f64; 3],
    visible_share: f64,
    true_pose_l2: f64,
    true_pose_iou: f64,
}

fn truth_scores(truth: &Truth, frame: usize, model: &Model, fit: &[[f32; 2]], picture: &Picture) -> Result<TruthScores> {
    let (w, h) = (picture.width, picture.height);
    let true_v = true_positions(truth, frame, &model.puppet)?;
    let true_render = render_crisp(&model.puppet, &true_v, w, h)?;
    let shown = visible_vertices(&model.puppet, &true_v);
    let keep = |points: &[[f32; 2]]| -> Vec<[f32; 2]> { points.iter().zip(&shown).filter(|(_, &s)| s).map(|(p, _)| *p).collect() };
    let (fit_shown, true_shown) = (keep(fit), keep(&true_v));
    Ok(TruthScores {
        vertex_error: vertex_error(fit, &true_v),
        pck: PCK_ALPHAS.map(|a| pck(fit, &true_v, a, w, h)),
        visible_vertex_error: vertex_error(&fit_shown, &true_shown),
        visible_pck: PCK_ALPHAS.map(|a| pck(&fit_shown, &true_shown, a, w, h)),
        visible_share: true_shown.len() as f64 / true_v.len().max(1) as f64,
        true_pose_l2: l2(&true_render, picture),
        true_pose_iou: silhouette_iou(&true_render, picture),
    })
}

fn mean_scores(scores: &[FrameScores]) -> FrameScores {
    let n = scores.len().max(1) as f64;
    let avg = |f: &dyn Fn(&FrameScores) -> f64| scores.iter().map(f).sum::<f64>() / n;
    let with_truth: Vec<&FrameScores> = scores.iter().filter(|s| s.vertex_error.is_some()).collect();
    let m = with_truth.len() as f64;
    let truth_avg = |f: &dyn Fn(&FrameScores) -> Option<f64>| (m > 0.0).then(|| with_truth.iter().filter_map(|s| f(s)).sum::<f64>() / m);
    FrameScores {
        frame: "mean".into(),
        l2: avg(&|s| s.l2),
        masked_rmse: avg(&|s| s.masked_rmse),
        iou: avg(&|s| s.iou),
        vertex_error: truth_avg(&|s| s.vertex_error),
        pck: (m > 0.0).then(|| [0, 1, 2].map(|k| with_truth.iter().filter_map(|s| s.pck.map(|p| p[k])).sum::<f64>() / m)),
        visible_vertex_error: truth_avg(&|s| s.visible_vertex_error),
        visible_pck: (m > 0.0).then(|| [0, 1, 2].map(|k| with_truth.iter().filter_map(|s| s.visible_pck.map(|p| p[k])).sum::<f64>() / m)),
        visible_share: truth_avg(&|s| s.visible_share),
        true_pose_l2: truth_avg(&|s| s.true_pose_l2),
        true_pose_iou: truth_avg(&|s| s.true_pose_iou),
    }
}

impl Report {
    /// A fixed-width table of every frame and the mean.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{:<18} {:>7} {:>7} {:>6} | {:>6} {:>6} {:>6} {:>6} | {:>5} {:>6} {:>6} {:>6} {:>6} | {:>7} {:>6}\n",
            "frame", "L2", "mRMSE", "IoU", "px", "PCK.1", "PCK.05", ".025", "vis%", "px", "PCK.1", "PCK.05", ".025", "L2", "IoU"
        );
        out.insert_str(
            0,
            &format!(
                "{:<40}| {:<27} | {:<36} | {}\n",
                "fitted", "all vertices", "visible vertices", "true pose"
            ),
        );
        for s in self.frames.iter().chain(std::iter::once(&self.mean)) {
            let opt = |v: Option<f64>, scale: f64| v.map_or("-".to_string(), |v| format!("{:.2}", v * scale));
            let pck = |p: Option<[f64; 3]>, k: usize| opt(p.map(|p| p[k]), 100.0);
            out.push_str(&format!(
                "{:<18} {:>7.1} {:>7.4} {:>6.4} | {:>6} {:>6} {:>6} {:>6} | {:>5} {:>6} {:>6} {:>6} {:>6} | {:>7} {:>6}\n",
                s.frame,
                s.l2,
                s.masked_rmse,
                s.iou,
                opt(s.vertex_error, 1.0),
                pck(s.pck, 0),
                pck(s.pck, 1),
                pck(s.pck, 2),
                s.visible_share.map_or("-".to_string(), |v| format!("{:.1}", v * 100.0)),
                opt(s.visible_vertex_error, 1.0),
                pck(s.visible_pck, 0),
                pck(s.visible_pck, 1),
                pck(s.visible_pck, 2),
                s.true_pose_l2.map_or("-".to_string(), |v| format!("{v:.1}")),
                s.true_pose_iou.map_or("-".to_string(), |v| format!("{v:.4}")),
            ));
        }
        if let Some(a) = &self.accessories {
            out.push_str(&format!(
                "accessories on the fits (worst frame): {:>9} {:>7} {:>5} {:>7} {:>6} {:>5} {:>5} {:>7} {:>7}\n{:>39} {}\n",
                "occl.kept",
                "deepest",
                "leaks",
                "overlap",
                "drift",
                "inv",
                "holes",
                "seam95",
                "stretch",
                "",
                a.row()
            ));
        }
        out
    }
}
