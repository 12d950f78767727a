//! What the web editor holds: the model (shared by every session), the frames a page can pick,
//! the layer textures as PNG, and the editing sessions — one [`PoseEditor`] per page, so two
//! pages never see each other's pins.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard};

use burn::tensor::Device;

use super::api::ApiError;
use crate::edit::pose::{Dragged, Pin, PoseEditor, PoseOptions};
use crate::error::{Error, Result};
use crate::fit::frame::frame_check;
use crate::fit::FitOptions;
use crate::model::Model;
use crate::picture::Picture;
use crate::puppet::sequence::Frames;
use crate::rng::Rng;
use crate::train::trainer::SplitRecord;

/// The most sessions kept unless [`ServeOptions::max_sessions`] says otherwise: each holds a
/// fitted latent and a decoder (a few MB on the demo's robot), so a page reloaded many times
/// must not grow the server without bound.
pub const DEFAULT_MAX_SESSIONS: usize = 16;

/// How the web editor fits and keeps sessions.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ServeOptions {
    /// How a picked frame is fitted before pins are set.
    pub fit: FitOptions,
    /// The most editing sessions kept; opening one more closes the least recently used.
    pub max_sessions: usize,
}

impl ServeOptions {
    /// Fitting with `fit`, at most [`DEFAULT_MAX_SESSIONS`] sessions.
    pub fn new(fit: FitOptions) -> Self {
        ServeOptions {
            fit,
            max_sessions: DEFAULT_MAX_SESSIONS,
        }
    }

    /// The same options keeping at most `max_sessions` sessions.
    pub fn with_max_sessions(self, max_sessions: usize) -> Self {
        ServeOptions { max_sessions, ..self }
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

/// One page's editing state: the editor fitted to its frame and the pins' source points it
/// was last given (the editor rebinds only when they change, so a drag continues from where
/// the previous request left the latent).
struct Session {
    editor: PoseEditor<'static>,
    sources: Vec<[f32; 2]>,
}

/// The open sessions, least recently used first.
struct Sessions {
    ids: Rng,
    open: VecDeque<(String, Arc<Mutex<Session>>)>,
}

/// The web editor's state, shared by every request.
pub struct App {
    model: Arc<Model>,
    device: Device,
    options: ServeOptions,
    frames: Vec<EditorFrame>,
    textures: Vec<Vec<u8>>,
    sessions: Mutex<Sessions>,
}

/// Locks `m`; a poisoned lock (a request that panicked while holding it) is taken as it is:
/// every value behind these locks is whole between statements, so the next request may use it.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl App {
    /// The editor's state for `model`, offering `frames` to pose; with no frames it offers the
    /// puppet's rest pose, rendered, so there is always something to pose.
    ///
    /// # Errors
    /// [`Error::Setting`] for `max_sessions` 0; [`Error::Mismatch`] for a frame not of the
    /// puppet's size; as [`Picture::png_bytes`] and [`crate::render::render_crisp`].
    pub fn new(model: Model, frames: Vec<EditorFrame>, options: ServeOptions, device: &Device) -> Result<Self> {
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
        let textures = model
            .puppet
            .layers
            .iter()
            .map(|l| l.texture.png_bytes(Path::new(&l.name)))
            .collect::<Result<_>>()?;
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        Ok(App {
            model: Arc::new(model),
            device: device.clone(),
            options,
            frames,
            textures,
            sessions: Mutex::new(Sessions {
                ids: Rng::new(seed),
                open: VecDeque::new(),
            }),
        })
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The frames a page can pick.
    pub fn frames(&self) -> &[EditorFrame] {
        &self.frames
    }

    /// Layer `i`'s texture as PNG bytes.
    pub fn texture_png(&self, i: usize) -> Option<&[u8]> {
        self.textures.get(i).map(Vec::as_slice)
    }

    /// How many sessions are open.
    pub fn session_count(&self) -> usize {
        lock(&self.sessions).open.len()
    }

    /// Fits frame `frame` and opens a session on it (closing the least recently used session
    /// beyond [`ServeOptions::max_sessions`]); returns its id and the fitted vertices (frame
    /// pixels, global numbering). Blocks for the fit: call it off the async runtime's threads.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a frame that does not exist; as [`PoseEditor::shared`].
    pub fn open_session(&self, frame: usize) -> std::result::Result<(String, Vec<[f32; 2]>), ApiError> {
        let Some(f) = self.frames.get(frame) else {
            return Err(ApiError::not_found(format!(
                "there is no frame {frame} (the frames are numbered 0 to {})",
                self.frames.len() - 1
            )));
        };
        let editor = PoseEditor::shared(self.model.clone(), &f.picture, &self.options.fit, &self.device)
            .map_err(|e| ApiError::from(e.with_frame(&f.name)))?;
        let fitted = editor.fitted().to_vec();
        let session = Arc::new(Mutex::new(Session {
            editor,
            sources: Vec::new(),
        }));
        let mut sessions = lock(&self.sessions);
        let id = format!("{:016x}", sessions.ids.next_u64());
        while sessions.open.len() >= self.options.max_sessions {
            sessions.open.pop_front();
        }
        sessions.open.push_back((id.clone(), session));
        Ok((id, fitted))
    }

    /// Drags session `id`'s pins (`(source, target)`, frame pixels) by the latent optimisation
    /// (eq. 7–9). Unchanged sources continue from the latent the last drag reached; changed
    /// ones are bound anew on the fit first. Blocks: call it off the async runtime's threads.
    ///
    /// # Errors
    /// [`ApiError`] 404 for an unknown (or closed) session; 422 naming each pin not on the
    /// character; as [`PoseEditor::drag`].
    pub fn drag(&self, id: &str, pins: &[Pin], options: &PoseOptions) -> std::result::Result<Dragged, ApiError> {
        let session = {
            let mut sessions = lock(&self.sessions);
            let Some(at) = sessions.open.iter().position(|(k, _)| k == id) else {
                return Err(ApiError::not_found(
                    "no such editing session (it may have been closed for a newer one): pick a frame again",
                ));
            };
            // Most recently used last: the next eviction spares it.
            let entry = sessions.open.remove(at).expect("position found above");
            let session = entry.1.clone();
            sessions.open.push_back(entry);
            session
        };
        let mut session = lock(&session);
        let sources: Vec<[f32; 2]> = pins.iter().map(|p| p.from).collect();
        if sources != session.sources {
            // Forget the old pins first: if a new one is off the character, the session keeps none.
            session.sources.clear();
            session.editor.set_pins(&sources)?;
            session.sources = sources;
        }
        let targets: Vec<[f32; 2]> = pins.iter().map(|p| p.to).collect();
        Ok(session.editor.drag(&targets, options)?)
    }
}
