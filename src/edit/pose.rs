//! User-constrained deformation (neural-puppet.md §4.2): fit the frame, `v = D(E(x))`, bind each
//! pin's source point to the fitted mesh by barycentric coordinates, then move the latent by
//! gradient descent through the decoder (eq. 9, `z ← z − η ∇_z L_deform`) on
//!
//! ```text
//! L_deform = L_user + α1·L_reg + α2·L_joints            (eq. 8)
//! L_user   = Σ_i ‖p_i(v) − p_i^trg‖²                     (eq. 7)
//! ```
//!
//! with L_reg the ARAP energy of eq. 2 relative to the rest template and L_joints the hinge term
//! of eq. 3 — the training losses [`arap_loss`] and [`joint_loss`], in the training's units
//! (`crate::train::config::LossWeights`: normalised device coordinates of the letterboxed S×S
//! working square), so the paper's α1 = 25, α2 = 50 weigh them as in training. L_user is in
//! working pixels — the user clicks pixels: in NDC as well, a drag costs so little beside the
//! fitted pose's own ARAP energy that the regularisers pull the pose back towards the rest and
//! the pin barely moves (docs/results.md "Drag units and step size"). Pins are given and results
//! returned in frame pixels.
//!
//! **Step size.** The paper's fixed η = 3·10⁻⁴ depends on how strongly its decoder reacts to
//! z; on ours a fixed η either barely moves the pin or diverges, because ARAP's curvature in z
//! dwarfs L_user's (docs/results.md "Drag units and step size"). So each step of eq. 9 starts
//! from the current η and backtracks: the step is taken only if it lowers L_deform, η then doubles;
//! otherwise η is quartered and the step retried. `PoseOptions::eta` is the first η.
//!
//! [`PoseEditor`] keeps the encoded frame, the fitted pose and the pins' bindings, so an
//! interactive editor can call [`PoseEditor::drag`] on every mouse move: each call continues from
//! the latent the previous one reached (a few steps each, as the paper's 2–5), and
//! [`PoseEditor::reset`] returns to the fit.

use std::sync::Arc;

use burn::tensor::{Device, Int, Tensor, TensorData};

use super::bind::{bind, Binding};
use super::pin::Pin;
use super::pin_overlay::draw_pins;
use crate::error::{Error, Result};
use crate::fit::{fit_latents, FitOptions};
use crate::geom::ArapEnergy;
use crate::model::decoder::Decoder;
use crate::model::Model;
use crate::objective::arap_op::arap_loss;
use crate::objective::{joint_loss, regularised_triangles};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::puppet::Puppet;
use crate::render::animation::{write_poses, AnimationWriter};

/// Settings of the latent optimisation (eq. 8–9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseOptions {
    /// Gradient steps per drag (paper: 2 to 5).
    pub steps: usize,
    /// Step size η of eq. 9 — the first step's; later steps adapt it (module doc).
    pub eta: f32,
    /// Weight α1 of the ARAP regulariser (paper: 25).
    pub alpha_reg: f32,
    /// Weight α2 of the joint term (paper: 50).
    pub alpha_joints: f32,
}

impl Default for PoseOptions {
    fn default() -> Self {
        PoseOptions {
            steps: 5,
            eta: DEFAULT_ETA,
            alpha_reg: 25.0,
            alpha_joints: 50.0,
        }
    }
}

/// The default first step size η (see [`PoseOptions::eta`]). Not the paper's 3·10⁻⁴: from
/// there the doubling needs more than the 2–5 steps of a drag to reach a useful step on our
/// models (measured on the demo's robot: 5 steps from 3·10⁻⁴ left L_deform unchanged to 4
/// digits, from 1 they lowered it 10 %); backtracking makes a large first step safe.
pub const DEFAULT_ETA: f32 = 1.0;

/// Step-size halvings (by 4) tried per gradient step before giving up.
const MAX_BACKTRACKS: usize = 12;

/// The adapted step size stays below this multiple of [`PoseOptions::eta`] (2^20: the doubling
/// may cover many orders of magnitude over a long interactive drag, but not run away).
const MAX_GROWTH: f32 = 1_048_576.0;

impl PoseOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// [`Error::Setting`] for 0 or more than 1000 steps, or a step size or weight that is
    /// negative or not finite.
    pub fn validate(&self) -> Result<()> {
        if self.steps == 0 || self.steps > 1000 {
            return Err(Error::setting("drag steps", self.steps, "from 1 to 1000"));
        }
        for (name, v) in [
            ("drag step size η", self.eta),
            ("drag weight α1 (ARAP)", self.alpha_reg),
            ("drag weight α2 (joints)", self.alpha_joints),
        ] {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::setting(name, v, "a finite number ≥ 0"));
            }
        }
        Ok(())
    }
}

/// What one drag produced.
#[derive(Clone, Debug)]
pub struct Dragged {
    /// The new pose, frame pixels, global numbering.
    pub vertices: Vec<[f32; 2]>,
    /// Each pin's remaining distance to its target, frame pixels.
    pub pin_error: Vec<f32>,
    /// L_deform before each gradient step and after the last (NDC², module doc).
    pub loss: Vec<f32>,
}

/// The regularisers' fixed data: the ARAP energy on the rest template (NDC) and the joints'
/// vertex pairs.
struct Regularisers {
    arap: Arc<ArapEnergy<f32>>,
    joints: Option<(Tensor<1, Int>, Tensor<1, Int>)>,
}

/// The model an editor works with: borrowed by a command that owns it for its run, or shared
/// behind an `Arc` by a long-lived owner (the web editor's sessions), which cannot lend a borrow.
enum HeldModel<'m> {
    Borrowed(&'m Model),
    Shared(Arc<Model>),
}

impl std::ops::Deref for HeldModel<'_> {
    type Target = Model;

    fn deref(&self) -> &Model {
        match self {
            HeldModel::Borrowed(m) => m,
            HeldModel::Shared(m) => m,
        }
    }
}

/// The fitted state of one frame under user pins (module doc).
pub struct PoseEditor<'m> {
    model: HeldModel<'m>,
    device: Device,
    z0: Tensor<2>,
    z: Tensor<2>,
    decoder: Decoder,
    fitted: Vec<[f32; 2]>,
    bindings: Vec<Binding>,
    /// Barycentric weights as a `[P, V]` matrix (p = W·v).
    weights: Option<Tensor<2>>,
    /// Working pixels → NDC.
    ndc_scale: f32,
    /// The current step size (adapted from [`PoseOptions::eta`]; NaN until the first drag).
    eta: f32,
    regularisers: Regularisers,
}

impl<'m> PoseEditor<'m> {
    /// Encodes and fits `frame`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if the frame is not the puppet's size, [`Error::Geometry`] if a
    /// template layer is degenerate (no ARAP energy).
    pub fn new(model: &'m Model, frame: &Picture, fit: &FitOptions, device: &Device) -> Result<Self> {
        Self::with_model(HeldModel::Borrowed(model), frame, fit, device)
    }

    /// Encodes and fits `frame`, the editor sharing `model` (for an owner that keeps editors
    /// longer than any borrow, such as the web editor's sessions).
    ///
    /// # Errors
    /// As [`PoseEditor::new`].
    pub fn shared(model: Arc<Model>, frame: &Picture, fit: &FitOptions, device: &Device) -> Result<PoseEditor<'static>> {
        PoseEditor::with_model(HeldModel::Shared(model), frame, fit, device)
    }

    /// An editor sharing `model` whose fit is the latent `z0` `[1, Z]` (a frame fitted earlier,
    /// perhaps by the same body in another outfit: the latent is the body's pose).
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `z0` is not one latent of the model's size; as [`PoseEditor::new`].
    pub fn shared_at(model: Arc<Model>, z0: Tensor<2>, device: &Device) -> Result<PoseEditor<'static>> {
        check_latent(&model, &z0)?;
        PoseEditor::at_latent(HeldModel::Shared(model), z0, device)
    }

    /// An editor borrowing `model` whose fit is the latent `z0` `[1, Z]` (a pose found
    /// another way than by fitting a frame: a retargeted pose's encoding, say).
    ///
    /// # Errors
    /// As [`PoseEditor::shared_at`].
    pub fn at(model: &'m Model, z0: Tensor<2>, device: &Device) -> Result<Self> {
        check_latent(model, &z0)?;
        Self::at_latent(HeldModel::Borrowed(model), z0, device)
    }

    /// [`PoseEditor::new`] for either way of holding the model.
    fn with_model(held: HeldModel<'m>, frame: &Picture, fit: &FitOptions, device: &Device) -> Result<Self> {
        let z0 = fit_latents(&held, &[frame], fit, device)?;
        Self::at_latent(held, z0, device)
    }

    /// The editor of the fit `z0`.
    fn at_latent(held: HeldModel<'m>, z0: Tensor<2>, device: &Device) -> Result<Self> {
        let model: &Model = &held;
        let fitted = model.to_frame_vertices(model.decode(z0.clone(), device)).pop().unwrap_or_default();
        let half = model.letterbox.size as f32 / 2.0;
        let puppet = &model.puppet;
        let rest_ndc: Vec<[f32; 2]> = puppet
            .rest_vertices()
            .into_iter()
            .map(|p| model.letterbox.to_work(p).map(|c| c / half))
            .collect();
        let arap = Arc::new(ArapEnergy::new(&rest_ndc, &regularised_triangles(puppet))?);
        let index = |side: fn(&crate::puppet::Joint) -> crate::puppet::VertexRef| {
            let v: Vec<i64> = puppet.joints.iter().map(|j| puppet.global_index(side(j)) as i64).collect();
            Tensor::<1, Int>::from_data(TensorData::new(v.clone(), [v.len()]), device)
        };
        let joints = (!puppet.joints.is_empty()).then(|| (index(|j| j.a), index(|j| j.b)));
        let decoder = model.decoder(device);
        Ok(PoseEditor {
            model: held,
            device: device.clone(),
            z: z0.clone(),
            z0,
            decoder,
            fitted,
            bindings: Vec::new(),
            weights: None,
            ndc_scale: 1.0 / half,
            eta: f32::NAN,
            regularisers: Regularisers { arap, joints },
        })
    }

    /// The fitted pose of the frame (frame pixels).
    pub fn fitted(&self) -> &[[f32; 2]] {
        &self.fitted
    }

    /// The fitted latent `[1, Z]`.
    pub fn fitted_latent(&self) -> &Tensor<2> {
        &self.z0
    }

    /// The current latent `[1, Z]`: the fit's, or where the last drag left it.
    pub fn latent(&self) -> &Tensor<2> {
        &self.z
    }

    /// Moves to latent `z` `[1, Z]` (a slider's pose; later drags continue from it) and returns
    /// its pose, frame pixels.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `z` is not one latent of the model's size; [`Error::Geometry`] if
    /// it is not finite.
    pub fn set_latent(&mut self, z: Tensor<2>) -> Result<Vec<[f32; 2]>> {
        if z.dims() != self.z0.dims() {
            return Err(Error::mismatch(
                "the latent",
                format!("{:?}", z.dims()),
                format!("{:?}", self.z0.dims()),
            ));
        }
        let values: Vec<f32> = z.to_data().convert::<f32>().try_to_vec::<f32>().unwrap_or_default();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(Error::geometry("the latent", "is not finite"));
        }
        self.z = z;
        Ok(self.pose())
    }

    /// The pose of the current latent, frame pixels.
    pub fn pose(&self) -> Vec<[f32; 2]> {
        self.model
            .to_frame_vertices(self.model.decode(self.z.clone(), &self.device))
            .pop()
            .unwrap_or_default()
    }

    /// The current bindings of the pins' source points (made on the fitted pose).
    pub fn bindings(&self) -> &[Binding] {
        &self.bindings
    }

    /// Binds the pins' source points (frame pixels) to the fitted mesh, replacing earlier pins,
    /// and returns to the fit.
    ///
    /// # Errors
    /// [`Error::WithPin`] naming each pin (1-based, as given) whose point is not on the character
    /// ([`Error::Partial`] when several).
    pub fn set_pins(&mut self, sources: &[[f32; 2]]) -> Result<()> {
        let mut bindings = Vec::with_capacity(sources.len());
        let mut problems = Vec::new();
        for (k, &p) in sources.iter().enumerate() {
            match bind(&self.model.puppet, &self.fitted, p) {
                Ok(b) => bindings.push(b),
                Err(e) => problems.push(e.with_pin(k + 1)),
            }
        }
        Error::collect(problems)?;
        self.set_bindings(bindings);
        Ok(())
    }

    /// Pins the vertices `vertices` themselves (global numbering), replacing earlier pins, and
    /// returns to the fit: a drag then pulls each towards its target, as a whole pose is pulled
    /// onto the manifold.
    ///
    /// # Errors
    /// [`Error::Mismatch`] naming a vertex the puppet does not have.
    pub fn pin_vertices(&mut self, vertices: &[usize]) -> Result<()> {
        let puppet = &self.model.puppet;
        let offsets = puppet.vertex_offsets();
        let bindings = vertices
            .iter()
            .map(|&v| {
                if v >= puppet.vertex_count() {
                    return Err(Error::mismatch("a pinned vertex", v, format!("below {}", puppet.vertex_count())));
                }
                Ok(Binding::at_vertex(offsets.partition_point(|&o| o <= v) - 1, v as u32))
            })
            .collect::<Result<Vec<_>>>()?;
        self.set_bindings(bindings);
        Ok(())
    }

    /// Takes `bindings` as the pins (eq. 7's `p_i(v)` as a `[P, V]` matrix) and returns to the fit.
    fn set_bindings(&mut self, bindings: Vec<Binding>) {
        let v = self.model.puppet.vertex_count();
        let mut w = vec![0.0f32; bindings.len() * v];
        for (i, b) in bindings.iter().enumerate() {
            for k in 0..3 {
                w[i * v + b.vertices[k] as usize] += b.weights[k];
            }
        }
        self.weights = (!bindings.is_empty()).then(|| Tensor::from_data(TensorData::new(w, [bindings.len(), v]), &self.device));
        self.bindings = bindings;
        self.reset();
    }

    /// The drag as an editor runs it: from the fit, `frames` updates along straight lines from
    /// each pin's source to its target (frame pixels), each continuing from the last; returns
    /// each update's pose and the pins as they stood.
    ///
    /// # Errors
    /// As [`PoseEditor::drag`]; [`Error::Setting`] for `frames == 0`.
    pub fn drag_along(&mut self, pins: &[Pin], frames: usize, options: &PoseOptions) -> Result<Vec<(Dragged, Vec<Pin>)>> {
        if frames == 0 {
            return Err(Error::setting("drag frames", 0, "at least 1"));
        }
        self.reset();
        (1..=frames)
            .map(|k| {
                let s = k as f32 / frames as f32;
                let shown: Vec<Pin> = pins
                    .iter()
                    .map(|p| Pin {
                        from: p.from,
                        to: [p.from[0] + s * (p.to[0] - p.from[0]), p.from[1] + s * (p.to[1] - p.from[1])],
                    })
                    .collect();
                let targets: Vec<[f32; 2]> = shown.iter().map(|p| p.to).collect();
                Ok((self.drag(&targets, options)?, shown))
            })
            .collect()
    }

    /// [`PoseEditor::drag_along`] rendered into `writer` by `drawn` (the editor's model, or the
    /// same body in another outfit: [`Model::wearing`]), the pins drawn over each update.
    ///
    /// # Errors
    /// As [`PoseEditor::drag_along`] and [`write_poses`].
    pub fn write_drag(
        &mut self,
        drawn: &Model,
        pins: &[Pin],
        frames: usize,
        options: &PoseOptions,
        writer: &mut AnimationWriter<'_>,
        progress: &dyn Progress,
    ) -> Result<()> {
        let steps = self.drag_along(pins, frames, options)?;
        let poses: Vec<Vec<[f32; 2]>> = steps.iter().map(|(d, _)| drawn.pose_from(&self.model, &d.vertices)).collect();
        write_poses(&drawn.puppet, &poses, writer, |k, p| draw_pins(&p, &steps[k].1), progress)
    }

    /// Returns to the fitted latent (and forgets the adapted step size).
    pub fn reset(&mut self) {
        self.z = self.z0.clone();
        self.eta = f32::NAN;
    }

    /// Runs `options.steps` gradient steps of eq. 9 from the current latent towards `targets`
    /// (one per pin, frame pixels) and decodes the result.
    ///
    /// # Errors
    /// [`Error::Setting`] if there are no pins or the options are invalid, [`Error::Mismatch`]
    /// if the target count differs from the pin count, [`Error::Geometry`] if a target is not
    /// finite.
    pub fn drag(&mut self, targets: &[[f32; 2]], options: &PoseOptions) -> Result<Dragged> {
        options.validate()?;
        if !self.eta.is_finite() {
            self.eta = options.eta;
        }
        let Some(weights) = self.weights.clone() else {
            return Err(Error::setting("drag pins", 0, "at least one pin, set before dragging"));
        };
        if targets.len() != self.bindings.len() {
            return Err(Error::mismatch(
                "the drag's target count",
                targets.len(),
                format!("{} (one per pin)", self.bindings.len()),
            ));
        }
        if targets.iter().flatten().any(|c| !c.is_finite()) {
            return Err(Error::geometry("a drag target", "is not finite"));
        }
        let lb = self.model.letterbox;
        let work: Vec<f32> = targets.iter().flat_map(|&t| lb.to_work(t).map(|c| c * self.ndc_scale)).collect();
        let target = Tensor::<2>::from_data(TensorData::new(work, [targets.len(), 2]), &self.device);
        let mut losses = Vec::with_capacity(options.steps + 1);
        for _ in 0..options.steps {
            let z = self.z.clone().autodiff().require_grad();
            let loss = self.deform_loss(z.clone(), &weights, &target, options)?;
            losses.push(loss.clone().into_scalar::<f32>());
            let grads = loss.backward();
            let g = z
                .grad(&grads)
                .ok_or_else(|| Error::backend("drag", "no gradient reached the latent"))?;
            // Eq. 9 with a backtracking step size (module doc): grow η after a step that lowers
            // L_deform, shrink it until one does.
            let before = *losses.last().unwrap_or(&f32::INFINITY);
            let eta_before = self.eta;
            let mut accepted = None;
            for _ in 0..MAX_BACKTRACKS {
                let candidate = self.z.clone() - g.clone().mul_scalar(self.eta);
                let after = self
                    .deform_loss(candidate.clone(), &weights, &target, options)?
                    .into_scalar::<f32>();
                if after.is_finite() && after < before {
                    accepted = Some(candidate);
                    self.eta = (self.eta * 2.0).min(options.eta * MAX_GROWTH);
                    break;
                }
                self.eta *= 0.25;
            }
            match accepted {
                Some(z) => self.z = z,
                None => {
                    // No step lowers the loss: a (local) minimum at this precision (a pin already
                    // on its target, say). The next drag starts from the step size this one had,
                    // not from the 4^-12 the search ended at, which would freeze every later drag.
                    self.eta = eta_before;
                    break;
                }
            }
        }
        let final_loss = self.deform_loss(self.z.clone(), &weights, &target, options)?;
        losses.push(final_loss.into_scalar::<f32>());
        let vertices = self.pose();
        let pin_error = self
            .bindings
            .iter()
            .zip(targets)
            .map(|(b, t)| {
                let p = b.position(&vertices);
                (p[0] - t[0]).hypot(p[1] - t[1])
            })
            .collect();
        Ok(Dragged {
            vertices,
            pin_error,
            loss: losses,
        })
    }

    /// L_deform (eq. 8) at latent `z` `[1, Z]`, NDC²; `target` `[P, 2]` in NDC.
    fn deform_loss(&self, z: Tensor<2>, weights: &Tensor<2>, target: &Tensor<2>, options: &PoseOptions) -> Result<Tensor<1>> {
        let v: Tensor<3> = self.decoder.vertices(&self.model.net, z).mul_scalar(self.ndc_scale);
        let [_, n, _] = v.dims();
        let points = weights.clone().matmul(v.clone().reshape([n, 2]));
        // Eq. 7 in working pixels (module doc): NDC² × (S/2)².
        let user = (points - target.clone()).powi_scalar(2).sum().mul_scalar(self.ndc_scale.powi(-2));
        let reg = arap_loss(v.clone(), &self.regularisers.arap)?.sum();
        let mut loss = user + reg.mul_scalar(options.alpha_reg);
        if let Some((a, b)) = &self.regularisers.joints {
            loss = loss + joint_loss(v, a.clone(), b.clone()).sum().mul_scalar(options.alpha_joints);
        }
        Ok(loss)
    }
}

/// The most body vertices [`body_pins`] pins: enough to hold every layer's shape, few enough
/// that the pins' matrix stays small.
pub const MAX_BODY_PINS: usize = 256;

/// The body vertices that pin a whole pose when one is pulled onto the learned manifold (a
/// retargeted pose, the prior's fit of a frame): every one, or evenly spaced ones past
/// [`MAX_BODY_PINS`].
pub fn body_pins(puppet: &Puppet) -> Vec<usize> {
    let free = puppet.free_vertices();
    let stride = free.len().div_ceil(MAX_BODY_PINS).max(1);
    free.into_iter().step_by(stride).collect()
}

/// Checks `z0` is one latent of `model`'s size.
fn check_latent(model: &Model, z0: &Tensor<2>) -> Result<()> {
    let expected = [1, model.config.latent];
    if z0.dims() != expected {
        return Err(Error::mismatch(
            "the editor's latent",
            format!("{:?}", z0.dims()),
            format!("{expected:?}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::test_support::small_model;

    #[test]
    fn gradient_steps_decrease_the_loss_and_move_the_pin_towards_its_target() {
        let (model, device) = small_model(0.3);
        let frame = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut editor = PoseEditor::new(&model, &frame, &FitOptions::one_pass(), &device).unwrap();
        // The weights are random (unseeded), so the pin is the centre of the arm tip's triangle
        // in this fit, not a fixed point the fit may miss.
        let arm = model.puppet.layer_index("arm_front").unwrap();
        let offset = model.puppet.vertex_offsets()[arm];
        let tip = *model.puppet.layers[arm].mesh.triangles.last().unwrap();
        let corners = tip.map(|i| editor.fitted()[offset + i as usize]);
        let from = [0, 1].map(|c| corners.iter().map(|p| p[c]).sum::<f32>() / 3.0);
        editor.set_pins(&[from]).unwrap();
        let start = editor.bindings()[0].position(editor.fitted());
        // A reachable target: where the pin is under a nearby latent — the nearest of a few
        // shifts that moves it by half a pixel or more (the random weights are not reproducible:
        // tests running beside this one draw from the same device RNG).
        let (target, away) = [0.5f32, 1.0, 2.0, 4.0]
            .iter()
            .map(|&d| {
                let shifted = editor.z0.clone() + Tensor::<2>::ones(editor.z0.dims(), &device).mul_scalar(d);
                let target = editor.bindings()[0].position(&model.to_frame_vertices(model.decode(shifted, &device))[0]);
                (target, (target[0] - start[0]).hypot(target[1] - start[1]))
            })
            .find(|&(_, away)| away > 0.5)
            .expect("some latent shift moves the pin");
        // L_user alone (the random decoder's pose is far from rigid, so the regularisers would
        // dominate). The step size suits this random decoder, whose last layer is small: the
        // gradient w.r.t. z scales with it (the CLI default is calibrated on trained models).
        let options = PoseOptions {
            steps: 20,
            eta: 30.0,
            alpha_reg: 0.0,
            alpha_joints: 0.0,
        };
        let out = editor.drag(&[target], &options).unwrap();
        println!("loss {:?}", out.loss);
        assert!(out.loss.last().unwrap() < &(0.5 * out.loss[0]), "{:?}", out.loss);
        assert!(out.pin_error[0] < 0.7 * away, "pin error {} of {away}", out.pin_error[0]);
        // A second drag continues from where the first stopped; reset returns to the fit.
        let again = editor.drag(&[target], &PoseOptions { steps: 1, ..options }).unwrap();
        assert!(again.loss[0] <= out.loss.last().unwrap() * 1.0001);
        editor.reset();
        let fresh = editor.drag(&[target], &PoseOptions { steps: 1, ..options }).unwrap();
        assert!((fresh.loss[0] - out.loss[0]).abs() <= 1e-3 * out.loss[0]);
    }

    #[test]
    fn the_arap_term_pulls_a_distorted_pose_towards_rigidity() {
        let (model, device) = small_model(0.05);
        let frame = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut editor = PoseEditor::new(&model, &frame, &FitOptions::one_pass(), &device).unwrap();
        let from = [40.0, 22.5];
        editor.set_pins(&[from]).unwrap();
        let here = editor.bindings()[0].position(editor.fitted());
        // The pin stays where it is: only the regulariser has a gradient.
        let options = PoseOptions {
            steps: 40,
            eta: 1.5e-2,
            alpha_reg: 25.0,
            alpha_joints: 0.0,
        };
        let out = editor.drag(&[here], &options).unwrap();
        assert!(out.loss.last().unwrap() < &(0.97 * out.loss[0]), "{:?}", out.loss);
        // Backtracking only takes steps that lower L_deform.
        assert!(out.loss.windows(2).all(|w| w[1] <= w[0]), "{:?}", out.loss);
    }

    #[test]
    fn bad_pins_and_options_are_refused() {
        let (model, device) = small_model(0.05);
        let frame = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), 48, 40).unwrap();
        let mut editor = PoseEditor::new(&model, &frame, &FitOptions::one_pass(), &device).unwrap();
        let err = editor.set_pins(&[[24.0, 20.0], [-50.0, 3.0]]).unwrap_err().to_string();
        assert!(err.contains("pin 2") && err.contains("not on the character"), "{err}");
        assert!(editor
            .drag(&[[1.0, 1.0]], &PoseOptions::default())
            .unwrap_err()
            .to_string()
            .contains("drag pins = 0"));
        editor.set_pins(&[[24.0, 20.0]]).unwrap();
        let zero = PoseOptions {
            steps: 0,
            ..PoseOptions::default()
        };
        assert!(editor
            .drag(&[[1.0, 1.0]], &zero)
            .unwrap_err()
            .to_string()
            .contains("drag steps = 0"));
        assert!(editor.drag(&[[1.0, 1.0], [2.0, 2.0]], &PoseOptions::default()).is_err());
        assert!(editor.drag(&[[f32::NAN, 1.0]], &PoseOptions::default()).is_err());
    }
}
