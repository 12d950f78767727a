//! Scoring a trained model on frames (`puppet eval`): fit each frame, render the fit crisply at
//! the frame's size, and measure it with [`crate::metrics`]; where the sequence has ground
//! truth, also the fitted vertices against the true ones (vertex error, PCK).

use burn::tensor::Device;
use serde::Serialize;

use super::edit_poses::{drag_poses, inbetween_poses};
use super::rig::{pose_scores, Scores};
use crate::appearance::AppearanceStage;
use crate::error::{Context, Error, Result};
use crate::fit::{fit_from, fit_with_latents, FitOptions};
use crate::metrics::{l2, masked_rmse, pck, silhouette_iou, vertex_error, PCK_ALPHAS};
use crate::model::Model;
use crate::parts::learn::TrainedNet;
use crate::picture::Picture;
use crate::prior::{fit_untrained, fit_with_prior, PriorFit, Start};
use crate::progress::Progress;
use crate::puppet::sequence::Frames;
use crate::puppet::visibility::visible_vertices;
use crate::puppet::LayerKind;
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
    /// On a puppet with accessory layers (ground truth only): vertex error of the body layers'
    /// vertices and of the accessories' vertices, each over all and over visible vertices.
    pub split: Option<SplitError>,
    /// Mean vertex error of each layer's vertices, in the puppet's layer order (ground truth
    /// only): which parts carry the error (hidden ones have no evidence in the frame).
    pub layer_errors: Option<Vec<f64>>,
    /// With an appearance stage: L2 of the generator's redraw of the render (Table 1's
    /// "generated" beside `l2`, its "rendered").
    pub generated_l2: Option<f64>,
    /// With an appearance stage: silhouette IoU of the redraw.
    pub generated_iou: Option<f64>,
}

/// Vertex errors of a dressed puppet, body and accessories apart (pixels; `None` where a group
/// has no vertex).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SplitError {
    /// Body vertices, all.
    pub body: Option<f64>,
    /// Body vertices the frame shows.
    pub body_visible: Option<f64>,
    /// Accessory vertices, all.
    pub accessories: Option<f64>,
    /// Accessory vertices the frame shows.
    pub accessories_visible: Option<f64>,
}

/// Scores of a set of frames and their means.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Per frame, in sequence order.
    pub frames: Vec<FrameScores>,
    /// Means over frames (vertex error and PCK over frames with truth).
    pub mean: FrameScores,
    /// On a puppet with accessory layers: how the accessories hold up ([`pose_scores`], the
    /// worst over the poses) on the fits, on in-betweens of consecutive frames (the default path) and on
    /// seeded drags ([`super::edit_poses`]).
    pub accessories: Option<AccessoryScores>,
    /// The puppet's layer names, in the order of [`FrameScores::layer_errors`].
    pub layers: Vec<String>,
    /// How many fits came from the prior's placement (`None`: the prior was not used).
    pub from_prior: Option<usize>,
}

/// A dressed puppet's accessories on each kind of pose.
#[derive(Clone, Debug, Serialize)]
pub struct AccessoryScores {
    /// On the fitted frames.
    pub fits: Scores,
    /// On in-betweens of consecutive frames (t = ¼, ½, ¾); `None` with one frame.
    pub inbetweens: Option<Scores>,
    /// On two-pin drags from each fitted frame.
    pub drags: Option<Scores>,
    /// Poses scored: fits, in-betweens, drag frames.
    pub poses: [usize; 3],
}

/// How [`evaluate`] fits and what it scores besides the fits.
#[derive(Clone, Copy)]
pub struct Scoring<'a> {
    /// How frames are fitted.
    pub fit: &'a FitOptions,
    /// Where each fit starts.
    pub start: FitStart<'a>,
    /// An appearance stage whose redraws of the renders are scored too.
    pub appearance: Option<&'a AppearanceStage>,
}

/// Where the fits of [`evaluate`] start.
#[derive(Clone, Copy, Debug)]
pub enum FitStart<'a> {
    /// The model's network (its pass and latent steps).
    Network,
    /// The better of the fits from the network and from the prior's placement
    /// ([`fit_with_prior`]).
    NetworkOrPrior(&'a TrainedNet),
    /// The prior's placement alone: a model with no trained network ([`fit_untrained`]).
    Prior(&'a TrainedNet),
    /// The rest pose, for every frame: the control that shows what the prior adds.
    Rest,
}

/// The seed of the drags of [`AccessoryScores::drags`].
const DRAG_SEED: u64 = 14;

/// Fits (as `options` say) and scores `frames.frames[i]` for each `i` in `indices` (all frames if
/// empty), against `truth` where given (matched to frames by file name); with an `appearance`
/// stage, its redraws of the renders too.
///
/// # Errors
/// A frame of the wrong size (naming the file); truth that does not fit the puppet.
pub fn evaluate(
    model: &Model,
    frames: &Frames,
    indices: &[usize],
    truth: Option<&Truth>,
    scoring: &Scoring,
    device: &Device,
    progress: &dyn Progress,
) -> Result<Report> {
    let (options, appearance) = (scoring.fit, scoring.appearance);
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
    let (latents, fits, from_prior) = match scoring.start {
        FitStart::Network => {
            let (z, fits) = fit_with_latents(model, &pictures, options, device, progress)?;
            (Some(z), fits, None)
        }
        FitStart::NetworkOrPrior(prior) => {
            let PriorFit { poses: fits, starts } = fit_with_prior(prior, model, &pictures, options, device, progress)?;
            (None, fits, Some(starts.iter().filter(|&&s| s == Start::Prior).count()))
        }
        FitStart::Prior(prior) => {
            let fits = fit_untrained(prior, model, &pictures, options, device, progress)?;
            (None, fits, Some(pictures.len()))
        }
        FitStart::Rest => {
            let rest = vec![model.puppet.rest_vertices(); pictures.len()];
            (None, fit_from(model, &pictures, &rest, options, device, progress)?, None)
        }
    };
    let mut scores = Vec::with_capacity(indices.len());
    let generated: Vec<Option<Picture>> = match appearance {
        Some(stage) => stage
            .render_and_redraw(&model.puppet, &fits, device)?
            .into_iter()
            .map(|(_, g)| Some(g))
            .collect(),
        None => vec![None; fits.len()],
    };
    for (((&i, picture), fit), generated) in indices.iter().zip(&pictures).zip(&fits).zip(&generated) {
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
            vertex_error: truth.as_ref().map(|t| t.vertex_error),
            pck: truth.as_ref().map(|t| t.pck),
            visible_vertex_error: truth.as_ref().map(|t| t.visible_vertex_error),
            visible_pck: truth.as_ref().map(|t| t.visible_pck),
            visible_share: truth.as_ref().map(|t| t.visible_share),
            true_pose_l2: truth.as_ref().map(|t| t.true_pose_l2),
            true_pose_iou: truth.as_ref().map(|t| t.true_pose_iou),
            split: truth.as_ref().and_then(|t| t.split),
            layer_errors: truth.map(|t| t.layer_errors),
            generated_l2: generated.as_ref().map(|g| l2(g, picture)),
            generated_iou: generated.as_ref().map(|g| silhouette_iou(g, picture)),
        });
    }
    let mean = mean_scores(&scores);
    let accessories = match pose_scores(&model.puppet, &fits, progress) {
        // In-betweens and drags move latents: only a network's fits have them.
        Some(on_fits) => match &latents {
            Some(latents) => {
                progress.stage("in-betweens and drags", 1);
                let inbetweens = inbetween_poses(model, latents, &fits, device);
                let drags = drag_poses(model, &pictures, options, device, DRAG_SEED)?;
                progress.advance(1);
                Some(AccessoryScores {
                    fits: on_fits,
                    inbetweens: pose_scores(&model.puppet, &inbetweens, progress),
                    drags: pose_scores(&model.puppet, &drags, progress),
                    poses: [fits.len(), inbetweens.len(), drags.len()],
                })
            }
            None => Some(AccessoryScores {
                fits: on_fits,
                inbetweens: None,
                drags: None,
                poses: [fits.len(), 0, 0],
            }),
        },
        None => None,
    };
    Ok(Report {
        frames: scores,
        mean,
        accessories,
        layers: model.puppet.layers.iter().map(|l| l.name.clone()).collect(),
        from_prior,
    })
}

/// The scores that need ground truth.
struct TruthScores {
    vertex_error: f64,
    pck: [f64; 3],
    visible_vertex_error: f64,
    visible_pck: [f64; 3],
    visible_share: f64,
    true_pose_l2: f64,
    true_pose_iou: f64,
    split: Option<SplitError>,
    layer_errors: Vec<f64>,
}

fn truth_scores(truth: &Truth, frame: usize, model: &Model, fit: &[[f32; 2]], picture: &Picture) -> Result<TruthScores> {
    let (w, h) = (picture.width, picture.height);
    let true_v = true_positions(truth, frame, &model.puppet)?;
    let true_render = render_crisp(&model.puppet, &true_v, w, h)?;
    let shown = visible_vertices(&model.puppet, &true_v);
    let keep = |points: &[[f32; 2]]| -> Vec<[f32; 2]> { points.iter().zip(&shown).filter(|(_, &s)| s).map(|(p, _)| *p).collect() };
    let (fit_shown, true_shown) = (keep(fit), keep(&true_v));
    let split = model.puppet.layers.iter().any(|l| l.kind == LayerKind::Accessory).then(|| {
        let mut accessory = vec![false; true_v.len()];
        for (layer, &offset) in model.puppet.layers.iter().zip(&model.puppet.vertex_offsets()) {
            if layer.kind == LayerKind::Accessory {
                accessory[offset..offset + layer.mesh.vertices.len()].fill(true);
            }
        }
        let error = |want_accessory: bool, only_shown: bool| {
            let chosen = |k: usize| accessory[k] == want_accessory && (shown[k] || !only_shown);
            let pick = |points: &[[f32; 2]]| -> Vec<[f32; 2]> { (0..points.len()).filter(|&k| chosen(k)).map(|k| points[k]).collect() };
            let (f, t) = (pick(fit), pick(&true_v));
            (!t.is_empty()).then(|| vertex_error(&f, &t))
        };
        SplitError {
            body: error(false, false),
            body_visible: error(false, true),
            accessories: error(true, false),
            accessories_visible: error(true, true),
        }
    });
    let offsets = model.puppet.vertex_offsets();
    let layer_errors = offsets
        .windows(2)
        .map(|r| vertex_error(&fit[r[0]..r[1]], &true_v[r[0]..r[1]]))
        .collect();
    Ok(TruthScores {
        layer_errors,
        vertex_error: vertex_error(fit, &true_v),
        pck: PCK_ALPHAS.map(|a| pck(fit, &true_v, a, w, h)),
        visible_vertex_error: vertex_error(&fit_shown, &true_shown),
        visible_pck: PCK_ALPHAS.map(|a| pck(&fit_shown, &true_shown, a, w, h)),
        visible_share: true_shown.len() as f64 / true_v.len().max(1) as f64,
        true_pose_l2: l2(&true_render, picture),
        true_pose_iou: silhouette_iou(&true_render, picture),
        split,
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
        split: mean_split(scores),
        layer_errors: (m > 0.0).then(|| {
            let per_frame: Vec<&Vec<f64>> = with_truth.iter().filter_map(|s| s.layer_errors.as_ref()).collect();
            (0..per_frame.first().map_or(0, |e| e.len()))
                .map(|l| per_frame.iter().map(|e| e[l]).sum::<f64>() / per_frame.len().max(1) as f64)
                .collect()
        }),
        generated_l2: mean_of(scores, |s| s.generated_l2),
        generated_iou: mean_of(scores, |s| s.generated_iou),
    }
}

/// The mean of a score over the frames that have it.
fn mean_of(scores: &[FrameScores], f: fn(&FrameScores) -> Option<f64>) -> Option<f64> {
    let v: Vec<f64> = scores.iter().filter_map(f).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Each part of the split averaged over the frames that have it.
fn mean_split(scores: &[FrameScores]) -> Option<SplitError> {
    let splits: Vec<SplitError> = scores.iter().filter_map(|s| s.split).collect();
    let avg = |f: fn(&SplitError) -> Option<f64>| {
        let v: Vec<f64> = splits.iter().filter_map(f).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    (!splits.is_empty()).then(|| SplitError {
        body: avg(|s| s.body),
        body_visible: avg(|s| s.body_visible),
        accessories: avg(|s| s.accessories),
        accessories_visible: avg(|s| s.accessories_visible),
    })
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
        if self.mean.generated_l2.is_some() {
            out.push_str(&format!(
                "appearance         {:>9} {:>9} {:>6} {:>12} {:>12} {:>6} {:>6}\n",
                "rendered", "generated", "ratio", "rendered²", "generated²", "ratio²", "IoU"
            ));
            // The paper does not say whether Table 1 is the norm or its square: both, the mean
            // row averaging the frames' squares.
            let n = self.frames.len().max(1) as f64;
            let mean_square = |f: fn(&FrameScores) -> f64| self.frames.iter().map(|s| f(s).powi(2)).sum::<f64>() / n;
            let mean_squares = (mean_square(|s| s.l2), mean_square(|s| s.generated_l2.unwrap_or(f64::NAN)));
            for (k, s) in self.frames.iter().chain(std::iter::once(&self.mean)).enumerate() {
                if let (Some(g), Some(iou)) = (s.generated_l2, s.generated_iou) {
                    let (r2, g2) = if k == self.frames.len() {
                        mean_squares
                    } else {
                        (s.l2 * s.l2, g * g)
                    };
                    out.push_str(&format!(
                        "{:<18} {:>9.1} {:>9.1} {:>6.3} {:>12.0} {:>12.0} {:>6.3} {:>6.4}\n",
                        s.frame,
                        s.l2,
                        g,
                        g / s.l2,
                        r2,
                        g2,
                        g2 / r2,
                        iou
                    ));
                }
            }
        }
        if let Some(errors) = &self.mean.layer_errors {
            let each: Vec<String> = self.layers.iter().zip(errors).map(|(name, e)| format!("{name} {e:.2}")).collect();
            out.push_str(&format!("vertex error by layer, mean (px): {}\n", each.join(", ")));
        }
        if let Some(split) = &self.mean.split {
            let px = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
            out.push_str(&format!(
                "vertex error, mean (px): body {} all / {} visible; accessories {} all / {} visible\n",
                px(split.body),
                px(split.body_visible),
                px(split.accessories),
                px(split.accessories_visible)
            ));
        }
        if let Some(a) = &self.accessories {
            out.push_str(&format!("accessories (worst pose)  {:>6} | {}\n", "poses", Scores::header()));
            for (name, scores, n) in [
                ("fits", Some(&a.fits), a.poses[0]),
                ("in-betweens", a.inbetweens.as_ref(), a.poses[1]),
                ("drags", a.drags.as_ref(), a.poses[2]),
            ] {
                if let Some(s) = scores {
                    out.push_str(&format!("  {name:<23} {n:>6} | {}\n", s.row()));
                }
            }
            out.push_str("  (shares and distances of the worst pose; leaks, inv and holes summed over the poses)\n");
        }
        out
    }
}
