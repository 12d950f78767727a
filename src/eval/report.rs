//! Scoring a trained model on frames (`puppet eval`): fit each frame, render the fit crisply at
//! the frame's size, and measure it with the metrics of this module; where the sequence has
//! ground truth, also the fitted vertices against the true ones (vertex error, PCK).

use burn::tensor::Device;
use serde::Serialize;

use super::{l2, masked_rmse, pck, silhouette_iou, vertex_error};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::render::render_crisp;
use crate::synth::{true_positions, Truth};
use crate::train::Frames;

/// The PCK thresholds of neural-puppet.md Table 2.
pub const PCK_ALPHAS: [f64; 3] = [0.1, 0.05, 0.025];

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
}

/// Scores of a set of frames and their means.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Per frame, in sequence order.
    pub frames: Vec<FrameScores>,
    /// Means over frames (vertex error and PCK over frames with truth).
    pub mean: FrameScores,
}

/// Fits and scores `frames.frames[i]` for each `i` in `indices` (all frames if empty).
///
/// # Errors
/// Frame-size mismatches (naming the file) and ground truth that does not fit the puppet.
pub fn evaluate(model: &Model, frames: &Frames, indices: &[usize], device: &Device) -> Result<Report> {
    let indices: Vec<usize> = if indices.is_empty() { (0..frames.frames.len()).collect() } else { indices.to_vec() };
    let names = frames.names();
    let mut scores = Vec::with_capacity(indices.len());
    for chunk in indices.chunks(16) {
        let pictures: Vec<_> = chunk.iter().map(|&i| &frames.frames[i]).collect();
        for (&i, picture) in chunk.iter().zip(&pictures) {
            model.check_frame(picture).map_err(|e| Error::format(&frames.files[i], e.to_string()))?;
        }
        let fits = model.fit(&pictures, device)?;
        for ((&i, picture), fit) in chunk.iter().zip(&pictures).zip(&fits) {
            let render = render_crisp(&model.puppet, fit, picture.width, picture.height)?;
            let truth = frames.truth.as_ref().map(|t| truth_scores(t, i, model, fit, picture.width, picture.height)).transpose()?;
            scores.push(FrameScores {
                frame: names[i].clone(),
                l2: l2(&render, picture),
                masked_rmse: masked_rmse(&render, picture),
                iou: silhouette_iou(&render, picture),
                vertex_error: truth.map(|t| t.0),
                pck: truth.map(|t| t.1),
            });
        }
    }
    let mean = mean_scores(&scores);
    Ok(Report { frames: scores, mean })
}

fn truth_scores(truth: &Truth, frame: usize, model: &Model, fit: &[[f32; 2]], w: u32, h: u32) -> Result<(f64, [f64; 3])> {
    let true_v = true_positions(truth, frame, &model.puppet)?;
    Ok((vertex_error(fit, &true_v), PCK_ALPHAS.map(|a| pck(fit, &true_v, a, w, h))))
}

fn mean_scores(scores: &[FrameScores]) -> FrameScores {
    let n = scores.len().max(1) as f64;
    let avg = |f: &dyn Fn(&FrameScores) -> f64| scores.iter().map(f).sum::<f64>() / n;
    let with_truth: Vec<&FrameScores> = scores.iter().filter(|s| s.vertex_error.is_some()).collect();
    let m = with_truth.len() as f64;
    FrameScores {
        frame: "mean".into(),
        l2: avg(&|s| s.l2),
        masked_rmse: avg(&|s| s.masked_rmse),
        iou: avg(&|s| s.iou),
        vertex_error: (m > 0.0).then(|| with_truth.iter().filter_map(|s| s.vertex_error).sum::<f64>() / m),
        pck: (m > 0.0).then(|| [0, 1, 2].map(|k| with_truth.iter().filter_map(|s| s.pck.map(|p| p[k])).sum::<f64>() / m)),
    }
}

impl Report {
    /// A fixed-width table of every frame and the mean.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{:<24} {:>9} {:>8} {:>7} {:>9} {:>7} {:>7} {:>7}\n",
            "frame", "L2", "mRMSE", "IoU", "vert px", "PCK.1", "PCK.05", "PCK.025"
        );
        for s in self.frames.iter().chain(std::iter::once(&self.mean)) {
            let opt = |v: Option<f64>, scale: f64| v.map_or("-".to_string(), |v| format!("{:.2}", v * scale));
            let pck = |k: usize| opt(s.pck.map(|p| p[k]), 100.0);
            out.push_str(&format!(
                "{:<24} {:>9.1} {:>8.4} {:>7.4} {:>9} {:>7} {:>7} {:>7}\n",
                s.frame,
                s.l2,
                s.masked_rmse,
                s.iou,
                opt(s.vertex_error, 1.0),
                pck(0),
                pck(1),
                pck(2)
            ));
        }
        out
    }
}
