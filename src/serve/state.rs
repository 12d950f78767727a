//! What the web editor holds: the model and the outfits it can draw (one body, shared by every
//! session), the frames a page can pick and their fitted latents, the layer textures as PNG, the
//! training frames' principal latent directions, and the editing sessions.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, RwLock};

use burn::tensor::{Device, Tensor, TensorData};

use super::error::ApiError;
use super::next::Next;
use super::session::{lock, Session, Sessions};
use crate::appearance::AppearanceStage;
use crate::edit::directions::LatentDirections;
use crate::edit::inbetween::Interpolator;
use crate::edit::manifold_path::Waypoints;
use crate::edit::pin::Pin;
use crate::edit::pose::{Dragged, PoseEditor, PoseOptions};
use crate::edit::prior_start::{starting_latent, StartChoice, PULL_STEPS};
use crate::error::{Error, Result};
use crate::fit::frame::{check_cut_out, frame_check};
use crate::fit::{fit_latents, FitOptions};
use crate::model::Model;
use crate::picture::Picture;
use crate::prior::TrainedNet;
use crate::puppet::sequence::Frames;
use crate::puppet::Puppet;
use crate::rig::outfit::outfits_in;
use crate::train::trainer::SplitRecord;

/// The most sessions kept unless [`ServeOptions::max_sessions`] says otherwise: each holds a
/// fitted latent and a decoder (a few MB on the demo's robot), so a page reloaded many times
/// must not grow the server without bound.
pub const DEFAULT_MAX_SESSIONS: usize = 16;

/// The most latent sliders offered: the directions past the first few carry little of the
/// frames' spread, and a page of sliders is not a tool.
pub const MAX_SLIDERS: usize = 8;

/// The largest latent coordinate a page may send (the encoder's are of order 1–10; far beyond,
/// the decoder's poses stop being finite).
pub const MAX_LATENT: f32 = 1000.0;

/// The most frames a page may upload (each stays until the server stops; the bound keeps its
/// memory bounded).
pub const MAX_UPLOADS: usize = 32;

/// Frames encoded per batch for the latent directions (bounds the memory of a large folder).
const ENCODE_BATCH: usize = 16;

/// How the web editor fits and keeps sessions.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ServeOptions {
    /// How a picked frame is fitted before pins are set.
    pub fit: FitOptions,
    /// The most editing sessions kept; opening one more closes the least recently used.
    pub max_sessions: usize,
    /// The model's appearance stage (neural-puppet.md §3.3), if the page may redraw poses with it.
    pub appearance: Option<AppearanceStage>,
    /// The model's folder, if drawings of suggested poses may join its frames and continue it
    /// ([`super::next`]).
    pub model_folder: Option<PathBuf>,
    /// The prior an uploaded frame is also fitted from, if any.
    pub prior: Option<Arc<UploadPrior>>,
}

/// How an uploaded frame — a drawing the network may never have seen a pose like — is also
/// fitted from the character-agnostic prior ([`crate::edit::prior_start`]).
#[derive(Debug)]
pub struct UploadPrior {
    /// The prior.
    pub net: TrainedNet,
    /// The latent-free stages of its zero-shot fit.
    pub zero_shot: FitOptions,
    /// The drag that pulls that fit onto the model's manifold.
    pub pull: PoseOptions,
}

impl UploadPrior {
    /// Fitting from `net` by `zero_shot`'s latent-free stages, pulled by [`PULL_STEPS`] drag
    /// steps.
    pub fn new(net: TrainedNet, zero_shot: FitOptions) -> Self {
        UploadPrior {
            net,
            zero_shot,
            pull: PoseOptions {
                steps: PULL_STEPS,
                ..PoseOptions::default()
            },
        }
    }
}

impl ServeOptions {
    /// Fitting with `fit`, at most [`DEFAULT_MAX_SESSIONS`] sessions.
    pub fn new(fit: FitOptions) -> Self {
        ServeOptions {
            fit,
            max_sessions: DEFAULT_MAX_SESSIONS,
            appearance: None,
            model_folder: None,
            prior: None,
        }
    }

    /// The same options also fitting each uploaded frame from `prior`.
    pub fn with_prior(self, prior: UploadPrior) -> Self {
        ServeOptions {
            prior: Some(Arc::new(prior)),
            ..self
        }
    }

    /// The same options keeping at most `max_sessions` sessions.
    pub fn with_max_sessions(self, max_sessions: usize) -> Self {
        ServeOptions { max_sessions, ..self }
    }

    /// The same options taking drawings into a copy of the frames of the model in `dir` and
    /// continuing it there (beside `dir`, which is only read).
    pub fn with_model_folder(self, dir: &Path) -> Self {
        ServeOptions {
            model_folder: Some(dir.to_path_buf()),
            ..self
        }
    }

    /// The same options redrawing poses with `stage` on request.
    pub fn with_appearance(self, stage: AppearanceStage) -> Self {
        ServeOptions {
            appearance: Some(stage),
            ..self
        }
    }
}

/// A frame a page can pick to pose.
#[derive(Clone, Debug)]
pub struct EditorFrame {
    /// Its name (the frame's file name, or "rest pose").
    pub name: String,
    /// Whether the model held it out of training.
    pub held_out: bool,
    /// The picture, at the puppet's frame size.
    pub picture: Picture,
}

/// The frames of a model: those of its split record (the sequence it trained on, training and
/// held-out frames both) when that folder is still there, else none. Frames that cannot be read
/// are returned apart, each naming its file.
///
/// # Errors
/// As [`SplitRecord::load`]; as [`Frames::load_each`] when the recorded folder exists but none of
/// its frames can be read.
pub fn model_frames(model_dir: &Path, model: &Model) -> Result<(Vec<EditorFrame>, Vec<Error>)> {
    let Some(split) = SplitRecord::load(model_dir)? else {
        return Ok((Vec::new(), Vec::new()));
    };
    if !split.frames.is_dir() {
        return Ok((Vec::new(), Vec::new()));
    }
    folder_frames(&split.frames, model, &split.test)
}

/// The outfits of the model in `model_dir`: the folders of the `outfits/` folder beside the frames
/// it trained on (its split.json names them), by name; none if it has none.
///
/// # Errors
/// As [`SplitRecord::load`] and [`outfits_in`].
pub fn model_outfits(model_dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let Some(split) = SplitRecord::load(model_dir)? else {
        return Ok(Vec::new());
    };
    match split.frames.parent() {
        Some(character) => outfits_in(character),
        None => Ok(Vec::new()),
    }
}

/// The frames in `dir` (or `dir/frames`), natural order, those named in `held_out` marked so.
/// Frames that cannot be read are returned apart, each naming its file.
///
/// # Errors
/// As [`Frames::load_each`].
pub fn folder_frames(dir: &Path, model: &Model, held_out: &[String]) -> Result<(Vec<EditorFrame>, Vec<Error>)> {
    let (frames, bad) = Frames::load_each(dir, &frame_check(model))?;
    let names = frames.names();
    let frames = names
        .into_iter()
        .zip(frames.frames)
        .map(|(name, picture)| EditorFrame {
            held_out: held_out.contains(&name),
            name,
            picture,
        })
        .collect();
    Ok((frames, bad.into_iter().map(|(_, e)| e).collect()))
}

/// Reads `l` (see [`lock`] on poisoning).
fn read<T>(l: &RwLock<T>) -> std::sync::RwLockReadGuard<'_, T> {
    l.read().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Writes `l` (see [`lock`] on poisoning).
fn write<T>(l: &RwLock<T>) -> std::sync::RwLockWriteGuard<'_, T> {
    l.write().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A way to draw the character: the model's own accessories, or another outfit on the same body.
pub struct Outfit {
    /// Its name (the model's own is "as trained").
    pub name: String,
    /// The model drawing it: the same network, this outfit's puppet.
    pub model: Arc<Model>,
    textures: Vec<Vec<u8>>,
    /// The latents of the frames offered that the model did not hold out (its training frames,
    /// unless others were given), decoded in this outfit: where in-betweens may pass.
    waypoints: Waypoints,
}

impl Outfit {
    fn new(name: String, model: Model, trained: &Tensor<2>, device: &Device) -> Result<Self> {
        let waypoints = Waypoints::of_latents(&model, trained.clone(), device);
        let textures = model
            .puppet
            .layers
            .iter()
            .map(|l| l.texture.png_bytes(Path::new(&l.name)))
            .collect::<Result<_>>()?;
        Ok(Outfit {
            name,
            model: Arc::new(model),
            textures,
            waypoints,
        })
    }

    /// Layer `i`'s texture as PNG bytes.
    pub fn texture_png(&self, i: usize) -> Option<&[u8]> {
        self.textures.get(i).map(Vec::as_slice)
    }
}

/// A frame's fitted latent `[1, Z]`, and for an upload fitted with the prior beside the
/// network, which start was kept.
type FrameFit = (Tensor<2>, Option<StartChoice>);

/// A pose as a page receives it: vertices in frame pixels (the session outfit's numbering) and
/// the latent that decodes to them (a page keeps it to undo to).
#[derive(Clone, Debug)]
pub struct EditorPose {
    /// The vertices, frame pixels.
    pub vertices: Vec<[f32; 2]>,
    /// The latent `z`.
    pub latent: Vec<f32>,
}

/// A motion a page played, as its downloads draw it.
pub struct PlayedMotion {
    /// The outfit the poses are of.
    pub outfit: usize,
    /// Each frame's pose, frame pixels.
    pub poses: Vec<Vec<[f32; 2]>>,
}

/// The web editor's state, shared by every request.
pub struct App {
    outfits: Vec<Outfit>,
    device: Device,
    options: ServeOptions,
    /// The frames given, then those pages uploaded.
    frames: RwLock<Vec<Arc<EditorFrame>>>,
    given: usize,
    /// Per frame, its fit once a page has asked for it.
    latents: Mutex<Vec<Option<FrameFit>>>,
    directions: LatentDirections,
    sessions: Sessions,
    next: Next,
    /// The motion played last, for downloads.
    motion: Mutex<Option<Arc<PlayedMotion>>>,
}

/// The values of a latent `[1, Z]`.
fn values(z: &Tensor<2>) -> Vec<f32> {
    z.to_data().convert::<f32>().try_to_vec::<f32>().unwrap_or_default()
}

impl App {
    /// The editor's state for `model`, offering `frames` to pose and `outfits` (named puppets of
    /// the model's body in other accessories, see [`crate::rig::outfit::dress`]) to draw; with no
    /// frames it offers the puppet's rest pose, rendered, so there is always something to pose.
    ///
    /// # Errors
    /// [`Error::Setting`] for `max_sessions` 0; [`Error::Mismatch`] for a frame not of the
    /// puppet's size; as [`Model::wearing`] for an outfit, naming it; as [`Picture::png_bytes`]
    /// and [`crate::render::render_crisp`].
    pub fn new(
        model: Model,
        frames: Vec<EditorFrame>,
        outfits: Vec<(String, Puppet)>,
        options: ServeOptions,
        device: &Device,
    ) -> Result<Self> {
        if options.max_sessions == 0 {
            return Err(Error::setting("editing sessions", 0, "at least 1"));
        }
        let (w, h) = (model.puppet.width, model.puppet.height);
        for f in &frames {
            model.check_frame(&f.picture).map_err(|e| e.with_frame(&f.name))?;
        }
        let frames = if frames.is_empty() {
            let rest = crate::render::render_crisp(&model.puppet, &model.puppet.rest_vertices(), w, h)?;
            vec![EditorFrame {
                name: "rest pose".into(),
                held_out: false,
                picture: rest,
            }]
        } else {
            frames
        };
        let training: Vec<&Picture> = frames.iter().filter(|f| !f.held_out).map(|f| &f.picture).collect();
        let mut latents = Vec::with_capacity(training.len());
        let mut encoded = Vec::new();
        for batch in training.chunks(ENCODE_BATCH) {
            let z = model.encode(batch, device)?;
            let [n, dim] = z.dims();
            let flat = values(&z);
            latents.extend((0..n).map(|i| flat[i * dim..(i + 1) * dim].to_vec()));
            encoded.push(z);
        }
        let directions = LatentDirections::of(&latents, MAX_SLIDERS)?;
        let trained = if encoded.is_empty() {
            Tensor::zeros([0, model.config.latent], device)
        } else {
            Tensor::cat(encoded, 0)
        };
        let mut worn = Vec::with_capacity(outfits.len() + 1);
        for (name, puppet) in outfits {
            let model = model.wearing(puppet).map_err(|e| e.with_key(format!("outfit {name:?}")))?;
            worn.push(Outfit::new(name, model, &trained, device)?);
        }
        worn.insert(0, Outfit::new("as trained".into(), model, &trained, device)?);
        Ok(App {
            next: Next::new(options.model_folder.as_deref()),
            motion: Mutex::new(None),
            outfits: worn,
            device: device.clone(),
            latents: Mutex::new(vec![None; frames.len()]),
            sessions: Sessions::new(options.max_sessions),
            options,
            given: frames.len(),
            frames: RwLock::new(frames.into_iter().map(Arc::new).collect()),
            directions,
        })
    }

    /// The model (as trained: its own accessories).
    pub fn model(&self) -> &Model {
        &self.outfits[0].model
    }

    /// The outfits, the model's own first.
    pub fn outfits(&self) -> &[Outfit] {
        &self.outfits
    }

    /// The frames a page can pick: those given, then those uploaded.
    pub fn frames(&self) -> Vec<Arc<EditorFrame>> {
        read(&self.frames).clone()
    }

    /// Frame `k`.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a frame that does not exist.
    pub fn frame(&self, k: usize) -> std::result::Result<Arc<EditorFrame>, ApiError> {
        let frames = read(&self.frames);
        frames
            .get(k)
            .cloned()
            .ok_or_else(|| ApiError::not_found(format!("there is no frame {k} (the frames are numbered 0 to {})", frames.len() - 1)))
    }

    /// Adds a frame a page sent (PNG or another image format the reader knows, `name` naming it
    /// in messages); returns its index.
    ///
    /// # Errors
    /// [`ApiError`] 400 for bytes that are not a readable image, an image not of the puppet's
    /// size or opaque everywhere (frames are cut-out characters); 409 past [`MAX_UPLOADS`].
    pub fn upload(&self, name: &str, bytes: &[u8]) -> std::result::Result<usize, ApiError> {
        let picture = self.read_frame(name, bytes)?;
        let mut frames = write(&self.frames);
        if frames.len() - self.given >= MAX_UPLOADS {
            return Err(ApiError {
                status: axum::http::StatusCode::CONFLICT,
                message: format!("{MAX_UPLOADS} frames were uploaded already, the most one editor keeps: restart it to upload more"),
            });
        }
        frames.push(Arc::new(EditorFrame {
            name: name.to_string(),
            held_out: false,
            picture,
        }));
        lock(&self.latents).push(None);
        Ok(frames.len() - 1)
    }

    /// The frame in `bytes` (PNG or another image format the reader knows, `name` naming it in
    /// messages), checked as a frame of the puppet: its size, a cut-out character.
    ///
    /// # Errors
    /// [`ApiError`] 400 for bytes that are not a readable image, an image not of the puppet's
    /// size or opaque everywhere.
    pub(crate) fn read_frame(&self, name: &str, bytes: &[u8]) -> std::result::Result<Picture, ApiError> {
        let path = Path::new(name);
        let (w, h) = (self.model().puppet.width, self.model().puppet.height);
        let size = Picture::header_size(bytes, path)?;
        if size != (w, h) {
            return Err(ApiError::bad_request(format!(
                "{name} is {}×{}; the puppet's frames are {w}×{h}",
                size.0, size.1
            )));
        }
        let picture = Picture::decode(bytes, path)?;
        check_cut_out(&picture, path)?;
        Ok(picture)
    }

    /// The frames given that the model did not hold out (its training frames, or the rest pose
    /// when none were given): what suggestions start from.
    pub fn training_frames(&self) -> Vec<Arc<EditorFrame>> {
        read(&self.frames)[..self.given].iter().filter(|f| !f.held_out).cloned().collect()
    }

    /// The suggestions of what to draw next, the drawings sent back and the continuation.
    pub fn next(&self) -> &Next {
        &self.next
    }

    /// Keeps `poses` (of outfit `outfit`, frame pixels) as the motion played last.
    pub fn keep_motion(&self, outfit: usize, poses: Vec<Vec<[f32; 2]>>) {
        *lock(&self.motion) = Some(Arc::new(PlayedMotion { outfit, poses }));
    }

    /// The motion played last.
    ///
    /// # Errors
    /// [`ApiError`] 404 before any motion was played.
    pub fn motion(&self) -> std::result::Result<Arc<PlayedMotion>, ApiError> {
        lock(&self.motion)
            .clone()
            .ok_or_else(|| ApiError::not_found("no motion has been played yet: load a BVH file first"))
    }

    /// The device the editor computes on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The principal directions of the training frames' latents (the sliders).
    pub fn directions(&self) -> &LatentDirections {
        &self.directions
    }

    /// The soft rasterizer's σ the editor fits with, in frame px² (the fit's is in working-square
    /// px²).
    pub fn soft_sigma(&self) -> f32 {
        self.options.fit.sigma / self.model().letterbox.scale.powi(2)
    }

    /// The appearance stage and the device it runs on.
    ///
    /// # Errors
    /// [`ApiError`] 422 when the editor was started without one.
    pub fn appearance(&self) -> std::result::Result<(&AppearanceStage, &Device), ApiError> {
        match &self.options.appearance {
            Some(stage) => Ok((stage, &self.device)),
            None => Err(ApiError::unprocessable(
                "this editor has no appearance stage: train one for the model, then start the editor with it",
            )),
        }
    }

    /// How many sessions are open.
    pub fn session_count(&self) -> usize {
        self.sessions.count()
    }

    /// Outfit `k`.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an outfit that does not exist.
    pub fn outfit(&self, k: usize) -> std::result::Result<&Outfit, ApiError> {
        self.outfits.get(k).ok_or_else(|| {
            ApiError::not_found(format!(
                "there is no outfit {k} (the outfits are numbered 0 to {})",
                self.outfits.len() - 1
            ))
        })
    }

    /// Frame `k`'s fitted latent `[1, Z]` (fitted by the model as trained, which draws what the
    /// frames show; an uploaded frame also from the prior, if the options have one, the closer
    /// start kept and said), kept for the next request. Blocks for the fit.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a frame that does not exist; as [`fit_latents`] and
    /// [`starting_latent`].
    fn fitted_latent(&self, frame: usize) -> std::result::Result<FrameFit, ApiError> {
        let f = self.frame(frame)?;
        let mut latents = lock(&self.latents);
        if let Some(fit) = &latents[frame] {
            return Ok(fit.clone());
        }
        let (model, options) = (self.model(), &self.options.fit);
        let fit = match &self.options.prior {
            Some(prior) if frame >= self.given => {
                starting_latent(&prior.net, model, &f.picture, options, &prior.zero_shot, &prior.pull, &self.device)
                    .map(|(z, choice)| (z, Some(choice)))
            }
            _ => fit_latents(model, &[&f.picture], options, &self.device).map(|z| (z, None)),
        }
        .map_err(|e| ApiError::from(e.with_frame(&f.name)))?;
        latents[frame] = Some(fit.clone());
        Ok(fit)
    }

    /// Fits frame `frame` and opens a session on it drawn in outfit `outfit` (closing the least
    /// recently used session beyond [`ServeOptions::max_sessions`]); returns its id, the fit,
    /// and for an upload fitted with the prior beside the network, which start was kept.
    /// Blocks for the fit: call it off the async runtime's threads.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a frame or an outfit that does not exist; as [`fit_latents`].
    pub fn open_session(&self, frame: usize, outfit: usize) -> std::result::Result<(String, EditorPose, Option<StartChoice>), ApiError> {
        let worn = self.outfit(outfit)?.model.clone();
        let (z0, choice) = self.fitted_latent(frame)?;
        let editor = PoseEditor::shared_at(worn, z0, &self.device)?;
        let fit = EditorPose {
            vertices: editor.fitted().to_vec(),
            latent: values(editor.fitted_latent()),
        };
        let id = self.sessions.open(Session {
            editor,
            outfit,
            sources: Vec::new(),
        });
        Ok((id, fit, choice))
    }

    /// Drags session `id`'s pins (`(source, target)`, frame pixels) by the latent optimisation
    /// (eq. 7–9) from its current latent; new source points are bound on the fit first. Blocks:
    /// call it off the async runtime's threads.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown (or closed) session; 422 naming each pin not on the
    /// character; as [`PoseEditor::drag`].
    pub fn drag(&self, id: &str, pins: &[Pin], options: &PoseOptions) -> std::result::Result<(Dragged, Vec<f32>), ApiError> {
        let session = self.sessions.get(id)?;
        let mut session = lock(&session);
        let sources: Vec<[f32; 2]> = pins.iter().map(|p| p.from).collect();
        if sources != session.sources {
            // Forget the old pins first: if a new one is off the character, the session keeps none.
            session.sources.clear();
            // Binding returns to the fit; the drag goes on from the pose the page shows.
            let shown = session.editor.latent().clone();
            session.editor.set_pins(&sources)?;
            session.editor.set_latent(shown)?;
            session.sources = sources;
        }
        let targets: Vec<[f32; 2]> = pins.iter().map(|p| p.to).collect();
        let dragged = session.editor.drag(&targets, options)?;
        Ok((dragged, values(session.editor.latent())))
    }

    /// Moves session `id` to `latent` plus `weights` along the latent directions (one weight per
    /// direction, in standard deviations of the training frames; none for the latent itself).
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown session; 400 for a latent of the wrong length or with a
    /// value past ±[`MAX_LATENT`], or weights not one per direction; 422 if the latent draws no
    /// finite pose.
    pub fn set_latent(&self, id: &str, latent: &[f32], weights: &[f32]) -> std::result::Result<EditorPose, ApiError> {
        let dim = self.model().config.latent;
        if latent.len() != dim {
            return Err(ApiError::bad_request(format!(
                "the latent has {} values; this model's has {dim}",
                latent.len()
            )));
        }
        if let Some(v) = latent.iter().find(|v| !(v.is_finite() && v.abs() <= MAX_LATENT)) {
            return Err(ApiError::bad_request(format!(
                "a latent value is {v}; give numbers from -{MAX_LATENT} to {MAX_LATENT}"
            )));
        }
        let mut z = latent.to_vec();
        if !weights.is_empty() {
            for (zi, oi) in z.iter_mut().zip(self.directions.offset(weights)?) {
                *zi += oi;
            }
        }
        let session = self.sessions.get(id)?;
        let mut session = lock(&session);
        let tensor = Tensor::<2>::from_data(TensorData::new(z, [1, dim]), &self.device);
        let vertices = session.editor.set_latent(tensor)?;
        if vertices.iter().flatten().any(|c| !c.is_finite()) {
            let fit = session.editor.fitted_latent().clone();
            session.editor.set_latent(fit)?;
            return Err(ApiError::unprocessable(
                "that latent draws no finite pose (the editor went back to the fit)",
            ));
        }
        Ok(EditorPose {
            vertices,
            latent: values(session.editor.latent()),
        })
    }

    /// Draws session `id` in outfit `outfit` from now on, at the pose it has; the pins are bound
    /// anew on the next drag. Returns the fit and the current pose in the outfit's numbering.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown session or outfit.
    pub fn wear(&self, id: &str, outfit: usize) -> std::result::Result<(EditorPose, EditorPose), ApiError> {
        let worn = self.outfit(outfit)?.model.clone();
        let session = self.sessions.get(id)?;
        let mut session = lock(&session);
        let mut editor = PoseEditor::shared_at(worn, session.editor.fitted_latent().clone(), &self.device)?;
        let vertices = editor.set_latent(session.editor.latent().clone())?;
        let fit = EditorPose {
            vertices: editor.fitted().to_vec(),
            latent: values(editor.fitted_latent()),
        };
        let now = EditorPose {
            vertices,
            latent: values(editor.latent()),
        };
        *session = Session {
            editor,
            outfit,
            sources: Vec::new(),
        };
        Ok((fit, now))
    }

    /// Session `id`'s outfit and current pose.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown session.
    pub fn current_pose(&self, id: &str) -> std::result::Result<(usize, Vec<[f32; 2]>), ApiError> {
        let session = self.sessions.get(id)?;
        let session = lock(&session);
        Ok((session.outfit, session.editor.pose()))
    }

    /// The in-betweens from frame `a`'s fit to frame `b`'s at each of `t`, drawn in outfit
    /// `outfit` (frame pixels): `puppet inbetween`'s default path, along the manifold through the
    /// training frames between them, as-rigid-as-possible between its corners. Blocks for the
    /// fits of frames not fitted yet.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a frame or an outfit that does not exist; as [`fit_latents`] and
    /// [`Interpolator::manifold_rigid_poses`].
    pub fn inbetween(&self, a: usize, b: usize, t: &[f32], outfit: usize) -> std::result::Result<Vec<Vec<[f32; 2]>>, ApiError> {
        let outfit = self.outfit(outfit)?;
        let (za, zb) = (self.fitted_latent(a)?.0, self.fitted_latent(b)?.0);
        let interpolator = Interpolator::between(&outfit.model, za, zb, &self.device).through(&outfit.waypoints);
        Ok(interpolator.manifold_rigid_poses(&outfit.model, t)?)
    }
}
