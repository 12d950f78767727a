//! "What to draw next" in the editor (issue 57): the poses whose drawings would teach the model
//! most ([`crate::edit::suggest`]), each with the picture an artist traces over; the artist's
//! drawing of one, sent back as an upload, joining a copy of the model's frames in a folder of
//! the editor's own beside the model (`<model>-next/frames/`); and the model continued on them
//! in the background as `puppet train --from` continues it, into a new folder of that one. The
//! model being served is only read, and so is the folder of frames it trained on.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::http::StatusCode;
use burn::tensor::Device;
use serde::Serialize;

use super::error::ApiError;
use super::session::lock;
use crate::atomic_file::{record, Outputs};
use crate::edit::suggest::{suggest, trace_picture, Candidate, Ranking, SuggestOptions};
use crate::model::{Model, ModelFolder};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::train::config::canonical;
use crate::train::trainer::SplitRecord;
use crate::train::{train, TrainConfig, TrainOptions};
use crate::user_file;

/// The most suggestions one request asks for (`puppet suggest -n` has no bound; a page shows a
/// handful).
pub const MAX_SUGGESTIONS: usize = 8;

/// The most steps a continuation started from a page may run.
pub const MAX_CONTINUE_STEPS: u64 = 100_000;

/// What the folder of drawings and continued models is called beside the model's own.
const NEXT_SUFFIX: &str = "-next";

/// A suggested pose as the editor keeps it.
pub struct Suggestion {
    /// The pose (frame pixels, the model's own numbering: outfit 0) and its scores.
    pub candidate: Candidate,
    /// The trace-over picture, PNG.
    pub trace: Vec<u8>,
}

/// The suggestions of the latest request.
pub struct Suggested {
    /// The picks, best first.
    pub suggestions: Vec<Suggestion>,
    /// How many candidate poses were scored.
    pub candidates: usize,
    /// How long the request took, seconds.
    pub seconds: f64,
}

/// The folder the drawings join: a copy of the model's frames, held for as long as the editor
/// runs (another process writing into it meanwhile is refused).
struct Folder {
    /// `<model>-next`.
    dir: PathBuf,
    /// `<model>-next/frames`.
    frames: PathBuf,
    /// The names of the model's frames copied into it.
    copies: Vec<String>,
    /// The drawings in it, in the order they came.
    drawings: Vec<String>,
    outputs: Outputs,
}

/// Where a continuation stands, as a page polls it.
#[derive(Clone, Debug, Serialize)]
pub struct TrainingStatus {
    /// `running`, `stopping` (asked to stop: it ends at its next step), `done`, `stopped`
    /// (checkpointed before its last step: `puppet train <output>/train.toml --resume` finishes
    /// it) or
    /// `failed`.
    pub state: &'static str,
    /// The steps done, of `steps`.
    pub step: u64,
    /// The steps the run makes in all.
    pub steps: u64,
    /// The trainer's latest status line (its losses).
    pub message: String,
    /// What the trainer warned of.
    pub warnings: Vec<String>,
    /// The folder the continued model is written to.
    pub output: PathBuf,
    /// What went wrong, if it failed.
    pub error: Option<String>,
    /// Seconds since it started (until it ended).
    pub seconds: f64,
}

/// A continuation running in the background: the [`Progress`] the trainer reports to.
struct Training {
    started: Instant,
    output: PathBuf,
    status: Mutex<TrainingStatus>,
    /// Set by [`Next::stop`]; the trainer ends at its next step.
    stop: AtomicBool,
}

impl Training {
    fn status(&self) -> TrainingStatus {
        let mut status = lock(&self.status).clone();
        if status.state == "running" {
            status.seconds = self.started.elapsed().as_secs_f64();
            if self.stop.load(Ordering::Relaxed) {
                status.state = "stopping";
            }
        }
        status
    }

    /// Whether the trainer has not ended yet (asked to stop or not).
    fn is_running(&self) -> bool {
        lock(&self.status).state == "running"
    }

    /// Records how the run ended: `Ok(finished)` or the error's text.
    fn end(&self, outcome: std::result::Result<bool, String>) {
        let mut status = lock(&self.status);
        status.seconds = self.started.elapsed().as_secs_f64();
        match outcome {
            Ok(true) => status.state = "done",
            Ok(false) => status.state = "stopped",
            Err(e) => {
                status.state = "failed";
                status.error = Some(e);
            }
        }
    }
}

impl Progress for Training {
    fn stage(&self, _name: &str, total: u64) {
        lock(&self.status).steps = total;
    }

    fn advance(&self, n: u64) {
        lock(&self.status).step += n;
    }

    fn message(&self, text: &str) {
        lock(&self.status).message = text.to_string();
    }

    fn warn(&self, text: &str) {
        lock(&self.status).warnings.push(text.to_string());
    }

    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// What a page is told of the drawings and the continuation.
#[derive(Clone, Debug, Serialize)]
pub struct NextStatus {
    /// Whether drawings can join the model's frames here (the editor knows the model's folder
    /// and the frames it trained on).
    pub available: bool,
    /// Why not, when they cannot.
    pub unavailable: Option<String>,
    /// The folder of drawings, once the first came.
    pub folder: Option<PathBuf>,
    /// The frames in it: the model's and the drawings.
    pub frames: usize,
    /// The drawings' file names.
    pub drawings: Vec<String>,
    /// Steps a continuation runs unless told otherwise.
    pub default_steps: Option<u64>,
    /// The command that continues the model on the folder (what the page's button runs).
    pub command: Option<String>,
    /// The continuation started from a page, if any.
    pub training: Option<TrainingStatus>,
}

/// The editor's suggestions, drawings and continuation.
pub struct Next {
    /// The model's folder and its training config, or why drawings cannot join its frames.
    model: std::result::Result<(PathBuf, TrainConfig), String>,
    suggested: Mutex<Option<Arc<Suggested>>>,
    folder: Mutex<Option<Folder>>,
    training: Mutex<Option<Arc<Training>>>,
}

/// 422 with `message`.
fn unprocessable(message: impl Into<String>) -> ApiError {
    ApiError::unprocessable(message)
}

/// 409 with `message`.
fn conflict(message: impl Into<String>) -> ApiError {
    ApiError {
        status: StatusCode::CONFLICT,
        message: message.into(),
    }
}

/// `path` as a word of a POSIX shell command (quoted when it needs to be).
fn shell_word(path: &Path) -> String {
    let text = path.display().to_string();
    let plain = !text.is_empty() && text.chars().all(|c| c.is_ascii_alphanumeric() || "/._-+,:@%".contains(c));
    if plain {
        text
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
}

impl Next {
    /// The suggestions and drawings of the model in `model_dir` (`None`: a model given without
    /// its folder, whose frames drawings cannot join).
    pub fn new(model_dir: Option<&Path>) -> Self {
        let model = match model_dir {
            None => Err("this editor was not started on a model folder, so drawings have no training frames to join".to_string()),
            Some(dir) => {
                let dir = canonical(dir);
                ModelFolder::open(&dir)
                    .and_then(|folder| TrainConfig::load(&folder.config()))
                    .map(|config| (dir, config))
                    .map_err(|e| format!("{e}: the model cannot be continued, so drawings have nothing to join"))
            }
        };
        Next {
            model,
            suggested: Mutex::new(None),
            folder: Mutex::new(None),
            training: Mutex::new(None),
        }
    }

    /// The folder drawings join: `<model>-next` beside the model's folder.
    fn dir_of(model_dir: &Path) -> PathBuf {
        let name = model_dir
            .file_name()
            .map_or_else(|| "model".into(), |n| n.to_string_lossy().into_owned());
        model_dir.with_file_name(format!("{name}{NEXT_SUFFIX}"))
    }

    /// Steps a continuation of `config`'s model runs by default: a third of its own, as the
    /// measured continuations do (bench/suggest_gain.sh: 400 steps after 1200).
    fn default_steps(config: &TrainConfig) -> u64 {
        config.train.steps.div_ceil(3).max(1)
    }

    /// Suggests `count` poses of `model` to draw from its drawn `frames` (the training frames the
    /// editor was given), with their trace-over pictures; kept for [`Next::trace`]. Blocks for
    /// seconds.
    ///
    /// # Errors
    /// [`ApiError`] 400 for a count past 1 to [`MAX_SUGGESTIONS`]; 422 when no frame trains or
    /// no candidate could be scored; as [`suggest`] and [`trace_picture`].
    pub fn suggest(&self, model: &Model, frames: &[&Picture], count: usize, device: &Device) -> Result<Arc<Suggested>, ApiError> {
        if !(1..=MAX_SUGGESTIONS).contains(&count) {
            return Err(ApiError::bad_request(format!("count is {count}; give from 1 to {MAX_SUGGESTIONS}")));
        }
        let started = Instant::now();
        if frames.is_empty() {
            return Err(unprocessable(
                "every frame the editor was given is held out: there is no drawn frame to suggest from",
            ));
        }
        let options = SuggestOptions {
            count,
            ..SuggestOptions::default()
        };
        let ranking = suggest(model, frames, None, &options, device)?;
        if ranking.picked.is_empty() {
            return Err(unprocessable(ranking.why_none(options.separation_degrees)));
        }
        let Ranking { candidates, picked, .. } = ranking;
        let suggestions = picked
            .iter()
            .map(|&i| {
                let candidate = candidates[i].clone();
                let trace = trace_picture(&model.puppet, &candidate.pose)?.png_bytes(Path::new("trace-over.png"))?;
                Ok(Suggestion { candidate, trace })
            })
            .collect::<Result<_, ApiError>>()?;
        let suggested = Arc::new(Suggested {
            suggestions,
            candidates: candidates.len(),
            seconds: started.elapsed().as_secs_f64(),
        });
        *lock(&self.suggested) = Some(suggested.clone());
        Ok(suggested)
    }

    /// Suggestion `k`'s trace-over picture (PNG) of the latest request.
    ///
    /// # Errors
    /// [`ApiError`] 404 when there is no such suggestion.
    pub fn trace(&self, k: usize) -> Result<Vec<u8>, ApiError> {
        let suggested = lock(&self.suggested).clone();
        let Some(suggested) = suggested else {
            return Err(ApiError::not_found("nothing was suggested yet: ask for suggestions first"));
        };
        suggested.suggestions.get(k).map(|s| s.trace.clone()).ok_or_else(|| {
            ApiError::not_found(format!(
                "there is no suggestion {k} (the latest are numbered 0 to {})",
                suggested.suggestions.len() - 1
            ))
        })
    }

    /// The model's folder and training config.
    ///
    /// # Errors
    /// [`ApiError`] 422 saying why drawings cannot join its frames.
    fn model(&self) -> Result<(&Path, &TrainConfig), ApiError> {
        match &self.model {
            Ok((dir, config)) => Ok((dir, config)),
            Err(why) => Err(unprocessable(why.clone())),
        }
    }

    /// Adds `drawing` (read and checked by the editor, `name` naming it in messages) of
    /// suggestion `suggestion` (or of no suggestion) to the folder of drawings, making that
    /// folder first — the model's frames copied into `<model>-next/frames/` — if this editor
    /// has not. The drawing is written as `drawn_next_<k>.png` (`drawn.png` for none), never
    /// over a file there. Nothing is written when anything is wrong.
    ///
    /// # Errors
    /// [`ApiError`] 404 for a suggestion that does not exist; 422 when the model's folder, its
    /// split or its frames are not known; 409 when `<model>-next` exists and puppet did not
    /// make it, or another process is writing into it.
    pub fn add_drawing(&self, drawing: &Picture, suggestion: Option<usize>, name: &str) -> Result<String, ApiError> {
        let (model_dir, _) = self.model()?;
        // The drawing is written as PNG whatever it came as: the trainer reads PNG frames.
        let png = drawing.png_bytes(Path::new(name))?;
        let stem = match suggestion {
            Some(k) => {
                let count = lock(&self.suggested).as_ref().map_or(0, |s| s.suggestions.len());
                if k >= count {
                    return Err(ApiError::not_found(format!(
                        "there is no suggestion {k} ({count} suggested): ask for suggestions again"
                    )));
                }
                format!("drawn_next_{}", k + 1)
            }
            None => "drawn".to_string(),
        };
        let mut folder = lock(&self.folder);
        if folder.is_none() {
            *folder = Some(open_folder(model_dir)?);
        }
        let folder = folder.as_mut().expect("opened above");
        let taken = |file: &str| folder.copies.iter().any(|c| c == file) || folder.frames.join(file).exists();
        let file = std::iter::once(format!("{stem}.png"))
            .chain((2..).map(|n| format!("{stem}_{n}.png")))
            .find(|f| !taken(f))
            .expect("an unbounded list of names has a free one");
        folder.outputs.write(&folder.frames.join(&file), &png)?;
        folder.drawings.push(file.clone());
        Ok(file)
    }

    /// Continues the model on the folder of drawings for `steps` steps (default: a third of its
    /// own) in a background thread, into a new folder in `<model>-next` (`model`, else
    /// `model_2`, …), as `puppet train --from` does: the model's weights and settings, its
    /// held-out frames held out, every other frame of the folder trained.
    ///
    /// # Errors
    /// [`ApiError`] 400 for steps past 1 to [`MAX_CONTINUE_STEPS`]; 422 when the model cannot be
    /// continued or no drawing came yet; 409 while a continuation runs, or as
    /// [`Next::add_drawing`] for the folder.
    pub fn start(&self, steps: Option<u64>) -> Result<(), ApiError> {
        let (model_dir, config) = self.model()?;
        let steps = steps.unwrap_or_else(|| Self::default_steps(config));
        if !(1..=MAX_CONTINUE_STEPS).contains(&steps) {
            return Err(ApiError::bad_request(format!(
                "steps is {steps}; give from 1 to {MAX_CONTINUE_STEPS}"
            )));
        }
        let mut training = lock(&self.training);
        if let Some(t) = training.as_ref().filter(|t| t.is_running()) {
            return Err(conflict(format!(
                "a continuation is running already (into {}): wait for it to end",
                t.output.display()
            )));
        }
        let mut folder = lock(&self.folder);
        if folder.is_none() && Self::dir_of(model_dir).is_dir() {
            // Drawings sent to an earlier editor on this model.
            *folder = Some(open_folder(model_dir)?);
        }
        let Some(folder) = folder.as_ref().filter(|f| !f.drawings.is_empty()) else {
            return Err(unprocessable(
                "no drawing has joined the frames yet: draw a suggestion and send it first",
            ));
        };
        let output = next_output(&folder.dir);
        let mut config = config
            .clone()
            .replacing_paths(None, Some(&folder.frames), Some(&output))
            .continuing(model_dir);
        config.train.steps = steps;
        let run = Arc::new(Training {
            started: Instant::now(),
            output: output.clone(),
            status: Mutex::new(TrainingStatus {
                state: "running",
                step: 0,
                steps,
                message: String::new(),
                warnings: Vec::new(),
                output,
                error: None,
                seconds: 0.0,
            }),
            stop: AtomicBool::new(false),
        });
        *training = Some(run.clone());
        std::thread::spawn(move || {
            // A panic in the trainer must not leave the page polling a run that never ends.
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                train(&config, &TrainOptions::default(), run.as_ref()).map(|summary| summary.finished)
            }));
            run.end(match outcome {
                Ok(Ok(finished)) => Ok(finished),
                Ok(Err(e)) => Err(e.to_string()),
                Err(_) => Err("the trainer stopped on an internal error".to_string()),
            });
        });
        Ok(())
    }

    /// Asks the running continuation to stop: it ends after its current step, checkpointed, and
    /// `puppet train <folder>/train.toml --resume` finishes it.
    ///
    /// # Errors
    /// [`ApiError`] 409 when no continuation is running.
    pub fn stop(&self) -> Result<(), ApiError> {
        let training = lock(&self.training);
        let run = training
            .as_ref()
            .filter(|t| t.is_running())
            .ok_or_else(|| conflict("no continuation is running"))?;
        run.stop.store(true, Ordering::Relaxed);
        Ok(())
    }

    /// Where the drawings and the continuation stand.
    pub fn status(&self) -> NextStatus {
        let training = lock(&self.training).as_ref().map(|t| t.status());
        let (model_dir, config) = match &self.model {
            Ok((dir, config)) => (dir, config),
            Err(why) => {
                return NextStatus {
                    available: false,
                    unavailable: Some(why.clone()),
                    folder: None,
                    frames: 0,
                    drawings: Vec::new(),
                    default_steps: None,
                    command: None,
                    training,
                }
            }
        };
        let folder = lock(&self.folder);
        let steps = Self::default_steps(config);
        let command = folder.as_ref().map(|f| {
            format!(
                "puppet train --from {} --frames {} -o {} --steps {steps}",
                shell_word(model_dir),
                shell_word(&f.frames),
                shell_word(&next_output(&f.dir))
            )
        });
        NextStatus {
            available: true,
            unavailable: None,
            folder: folder.as_ref().map(|f| f.dir.clone()),
            frames: folder.as_ref().map_or(0, |f| f.copies.len() + f.drawings.len()),
            drawings: folder.as_ref().map_or_else(Vec::new, |f| f.drawings.clone()),
            default_steps: Some(steps),
            command,
            training,
        }
    }
}

/// The first of `dir/model`, `dir/model_2`, … that does not exist: a continuation never writes
/// over an earlier one.
fn next_output(dir: &Path) -> PathBuf {
    std::iter::once(dir.join("model"))
        .chain((2..).map(|n| dir.join(format!("model_{n}"))))
        .find(|p| !p.exists())
        .expect("an unbounded list of names has a free one")
}

/// Makes (or, if puppet made it, takes again) `<model>-next` beside `model_dir` and copies into
/// its `frames/` the frames the model trained on and held out, as its split record names them;
/// the drawings already there (sent to an earlier editor) are kept. Every frame is read before
/// anything is written.
fn open_folder(model_dir: &Path) -> Result<Folder, ApiError> {
    let Some(split) = SplitRecord::load(model_dir)? else {
        return Err(unprocessable(format!(
            "{}: no split.json, so the frames the model trained on are not known",
            model_dir.display()
        )));
    };
    if !split.frames.is_dir() {
        return Err(unprocessable(format!(
            "{}: the frames the model trained on are not there any more",
            split.frames.display()
        )));
    }
    let dir = Next::dir_of(model_dir);
    if canonical(&dir).starts_with(canonical(&split.frames)) {
        return Err(unprocessable(format!(
            "{} would be inside the model's frames folder {}: move the model out of it",
            dir.display(),
            split.frames.display()
        )));
    }
    let copies: Vec<String> = split.train.iter().chain(&split.test).cloned().collect();
    let bytes = copies
        .iter()
        .map(|name| user_file::read_bytes(&split.frames.join(name), user_file::DATA))
        .collect::<crate::error::Result<Vec<_>>>()?;
    let frames = dir.join("frames");
    let outputs = Outputs::new(false);
    for folder in [&dir, &frames] {
        outputs.claim_folder(folder)?;
        // Listed as puppet's: a later editor on this model may take it again.
        record(folder)?;
    }
    for (name, bytes) in copies.iter().zip(&bytes) {
        outputs.write(&frames.join(name), bytes)?;
    }
    let mut drawings: Vec<String> = std::fs::read_dir(&frames)
        .map_err(|e| crate::error::Error::io(&frames, e))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| n.to_ascii_lowercase().ends_with(".png") && !copies.contains(n))
        .collect();
    drawings.sort();
    Ok(Folder {
        dir,
        frames,
        copies,
        drawings,
        outputs,
    })
}
