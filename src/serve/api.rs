//! The HTTP routes of the web editor: the page, the puppet (in every outfit) and its textures,
//! the frames, the editing sessions, in-betweens, downloads and the appearance stage's redraws.
//! Every request is validated
//! before it reaches the editor (finite numbers, bounded counts, no unknown fields), and every
//! refusal is a 4xx with `{"error": "…"}` in plain words; the library's errors keep their own
//! messages.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, PathRejection, QueryRejection};
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::json;

use super::error::ApiError;
use super::export::{export, redrawn_strip, ExportStyle, Format};
use super::guard::{check, HostGuard};
use super::motion::{play, PlayOptions, MAX_MOTION_BYTES};
use super::state::{App, EditorPose};
use crate::edit::inbetween::MAX_STEPS;
use crate::edit::pin::Pin;
use crate::edit::pose::PoseOptions;
use crate::edit::retarget::View;
use crate::edit::timing::{eased_t, spacing_t, Easing};
use crate::picture::Picture;
use crate::prior::Start;
use crate::puppet::LayerKind;
use crate::render::Background;

/// The page: one HTML file with its script, part of the binary.
const PAGE: &str = include_str!("page.html");

/// The most pins one drag may carry (a person pins a handful; the bound keeps a request's work
/// small).
pub const MAX_PINS: usize = 64;

/// The largest request body, bytes: 64 pins are about 5 KB of JSON, a 512-value latent 10 KB.
pub const MAX_BODY: usize = 64 * 1024;

/// The largest upload, bytes (a frame of a few hundred pixels a side is well under 1 MB as PNG).
pub const MAX_UPLOAD_BODY: usize = 16 << 20;

/// The largest drag weight α accepted (the paper's are 25 and 50).
pub const MAX_ALPHA: f32 = 10_000.0;

/// The most gradient steps one drag request may ask for (a page asks for more than the
/// default once, when the mouse is released, to settle the pose).
pub const MAX_DRAG_STEPS: usize = 100;

/// The most in-betweens one request makes (10 s at 25 fps; the command line makes up to
/// [`MAX_STEPS`]).
pub const MAX_INBETWEENS: usize = 250;

/// The most accessory layers a request may hide (more than any outfit has).
pub const MAX_HIDDEN: usize = 256;

/// The longest frame time of a download, milliseconds (APNG's limit is 65,535).
pub const MAX_DELAY_MS: u32 = 10_000;

/// The routes over `app` (see the module doc of [`crate::serve`] for the list), answering only
/// what `guard` lets through (its own host names; changes from its own pages).
pub fn router(app: Arc<App>, guard: HostGuard) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/puppet", get(puppet))
        .route("/api/texture/{outfit}/{file}", get(texture))
        .route("/api/frames", get(frames))
        .route("/api/frame/{file}", get(frame))
        .route("/api/upload", post(upload).layer(DefaultBodyLimit::max(MAX_UPLOAD_BODY)))
        .route("/api/session", post(session))
        .route("/api/drag", post(drag))
        .route("/api/latent", post(latent))
        .route("/api/outfit", post(outfit))
        .route("/api/inbetween", post(inbetween))
        .route("/api/export", post(download))
        .route("/api/appearance", post(appearance))
        .route("/api/suggest", post(suggest))
        .route("/api/suggestion/{file}", get(suggestion))
        .route("/api/drawing", post(drawing).layer(DefaultBodyLimit::max(MAX_UPLOAD_BODY)))
        .route("/api/next", get(next))
        .route("/api/continue", post(continue_training))
        .route("/api/continue/stop", post(stop_training))
        .route("/api/motion", post(motion).layer(DefaultBodyLimit::max(MAX_MOTION_BYTES)))
        .fallback(|| async { ApiError::not_found("no such page or API route") })
        .method_not_allowed_fallback(|| async {
            ApiError {
                status: StatusCode::METHOD_NOT_ALLOWED,
                message: "this route does not take that method (the API reads with GET and edits with POST)".into(),
            }
        })
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .with_state(app)
        .layer(axum::middleware::from_fn_with_state(guard, check))
}

async fn page() -> Html<&'static str> {
    Html(PAGE)
}

/// The puppet as the page draws it, in every outfit: per layer its name, kind, triangles, UVs,
/// rest vertices, the offset of its vertices in the global numbering the poses use, and (for a
/// rigged accessory) the vertices the rig pins.
async fn puppet(State(app): State<Arc<App>>) -> Response {
    let outfits: Vec<_> = app
        .outfits()
        .iter()
        .enumerate()
        .map(|(k, outfit)| {
            let puppet = &outfit.model.puppet;
            let offsets = puppet.vertex_offsets();
            let layers: Vec<_> = puppet
                .layers
                .iter()
                .enumerate()
                .map(|(i, l)| {
                    let rig_pins: Vec<u32> = puppet
                        .rig
                        .iter()
                        .flat_map(|r| &r.accessories)
                        .filter(|a| a.layer == i)
                        .flat_map(|a| a.pins.iter().map(|p| p.vertex))
                        .collect();
                    json!({
                        "name": l.name,
                        "kind": match l.kind { LayerKind::Body => "body", LayerKind::Accessory => "accessory" },
                        "offset": offsets[i],
                        "triangles": l.mesh.triangles,
                        "uvs": l.uvs,
                        "rest": l.mesh.vertices,
                        "texture": format!("/api/texture/{k}/{i}.png"),
                        "rig_pins": rig_pins,
                    })
                })
                .collect();
            json!({ "name": outfit.name, "vertex_count": puppet.vertex_count(), "layers": layers })
        })
        .collect();
    let model = app.model();
    Json(json!({
        "width": model.puppet.width,
        "height": model.puppet.height,
        "latent": model.config.latent,
        "sliders": app.directions().directions.len(),
        "easings": Easing::ALL.iter().map(|(_, n)| *n).collect::<Vec<_>>(),
        "max_inbetweens": MAX_INBETWEENS,
        "appearance": app.appearance().is_ok(),
        "outfits": outfits,
    }))
    .into_response()
}

/// The index in a `<i>.png` path segment.
fn png_index(file: &str, what: &str) -> Result<usize, ApiError> {
    file.strip_suffix(".png")
        .and_then(|i| i.parse::<usize>().ok())
        .ok_or_else(|| ApiError::not_found(format!("{file:?} is not a {what} (ask for <number>.png)")))
}

fn png(bytes: Vec<u8>) -> Response {
    ([(header::CONTENT_TYPE, "image/png")], bytes).into_response()
}

async fn texture(State(app): State<Arc<App>>, path: Result<Path<(usize, String)>, PathRejection>) -> Result<Response, ApiError> {
    let Ok(Path((outfit, file))) = path else {
        return Err(ApiError::not_found("a texture is /api/texture/<outfit>/<layer>.png, both numbers"));
    };
    let i = png_index(&file, "layer texture")?;
    let outfit = app.outfit(outfit)?;
    outfit.texture_png(i).map(|b| png(b.to_vec())).ok_or_else(|| {
        ApiError::not_found(format!(
            "there is no layer {i} (outfit {:?} has {} layers)",
            outfit.name,
            outfit.model.puppet.layers.len()
        ))
    })
}

async fn frames(State(app): State<Arc<App>>) -> Response {
    let frames: Vec<_> = app
        .frames()
        .iter()
        .enumerate()
        .map(|(i, f)| json!({ "index": i, "name": f.name, "held_out": f.held_out, "picture": format!("/api/frame/{i}.png") }))
        .collect();
    Json(json!({ "frames": frames })).into_response()
}

async fn frame(State(app): State<Arc<App>>, file: Result<Path<String>, PathRejection>) -> Result<Response, ApiError> {
    let Ok(Path(file)) = file else {
        return Err(ApiError::bad_request("the frame path is not readable"));
    };
    let f = app.frame(png_index(&file, "frame")?)?;
    Ok(png(f.picture.png_bytes(std::path::Path::new(&f.name))?))
}

/// `POST /api/upload?name=<file name>` with the image as the body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct UploadQuery {
    name: Option<String>,
}

/// The body of an upload.
fn uploaded(body: Result<Bytes, BytesRejection>) -> Result<Bytes, ApiError> {
    body.map_err(|e| ApiError {
        status: e.status(),
        message: format!("the upload cannot be read: {}", e.body_text()),
    })
}

/// The name an upload gave its file, made fit to label it in messages (printable, short), or
/// `otherwise`.
fn label(given: Option<String>, otherwise: &str) -> String {
    let clean: String = given.unwrap_or_default().chars().filter(|c| !c.is_control()).take(80).collect();
    if clean.trim().is_empty() {
        otherwise.to_string()
    } else {
        clean
    }
}

async fn upload(
    State(app): State<Arc<App>>,
    query: Result<Query<UploadQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let Ok(Query(query)) = query else {
        return Err(ApiError::bad_request("an upload takes one query parameter, name (the file's name)"));
    };
    let bytes = uploaded(body)?;
    let name = label(query.name, "uploaded frame");
    let index = blocking(move || app.upload(&name, &bytes)).await?;
    Ok(Json(json!({ "index": index, "picture": format!("/api/frame/{index}.png") })).into_response())
}

/// Parses a JSON body, refusing unknown fields (the types say `deny_unknown_fields`).
fn parse<T: DeserializeOwned>(body: Result<Bytes, BytesRejection>) -> Result<T, ApiError> {
    let body = body.map_err(|e| ApiError {
        status: e.status(),
        message: format!("the request body cannot be read: {}", e.body_text()),
    })?;
    serde_json::from_slice(&body).map_err(|e| ApiError::bad_request(format!("the request is not the JSON expected: {e}")))
}

/// Runs `work` on a blocking thread (fits and drags take milliseconds to seconds of CPU).
async fn blocking<T: Send + 'static>(work: impl FnOnce() -> Result<T, ApiError> + Send + 'static) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(work).await.map_err(|e| ApiError {
        status: StatusCode::INTERNAL_SERVER_ERROR,
        message: format!("the editor failed on this request: {e}"),
    })?
}

fn pose_json(fit: Option<&EditorPose>, now: &EditorPose) -> serde_json::Value {
    let mut out = json!({ "vertices": now.vertices, "latent": now.latent });
    if let Some(fit) = fit {
        out["fitted"] = json!(fit.vertices);
        out["fitted_latent"] = json!(fit.latent);
    }
    out
}

/// `POST /api/session`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SessionRequest {
    /// The frame to fit, an index into `/api/frames`.
    frame: usize,
    /// The outfit to draw, an index into `/api/puppet`'s outfits (default 0, the model's own).
    #[serde(default)]
    outfit: usize,
}

async fn session(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: SessionRequest = parse(body)?;
    let (id, fit, choice) = blocking(move || app.open_session(request.frame, request.outfit)).await?;
    let mut out = pose_json(Some(&fit), &fit);
    out["session"] = json!(id);
    if let Some(c) = choice {
        let start = match c.start {
            Start::Prior => "prior",
            Start::Network => "network",
        };
        out["start"] = json!({ "kept": start, "network_l2": c.network_l2, "prior_l2": c.prior_l2 });
    }
    Ok(Json(out).into_response())
}

/// One pin of `POST /api/drag`, frame pixels.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PinRequest {
    from: [f32; 2],
    to: [f32; 2],
}

/// `POST /api/drag`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DragRequest {
    session: String,
    pins: Vec<PinRequest>,
    alpha_reg: Option<f32>,
    alpha_joints: Option<f32>,
    steps: Option<usize>,
}

impl DragRequest {
    /// The pins and options, checked: 1 to [`MAX_PINS`] pins with finite points near the frame
    /// (within a frame's size of its edges), weights from 0 to [`MAX_ALPHA`], 1 to
    /// [`MAX_DRAG_STEPS`] steps.
    fn validate(&self, width: u32, height: u32) -> Result<(Vec<Pin>, PoseOptions), ApiError> {
        if self.pins.is_empty() || self.pins.len() > MAX_PINS {
            return Err(ApiError::bad_request(format!(
                "a drag has {} pins; give from 1 to {MAX_PINS}",
                self.pins.len()
            )));
        }
        let (w, h) = (width as f32, height as f32);
        for (k, pin) in self.pins.iter().enumerate() {
            for (which, p) in [("point", pin.from), ("target", pin.to)] {
                let near = p[0].is_finite() && p[1].is_finite() && (-w..=2.0 * w).contains(&p[0]) && (-h..=2.0 * h).contains(&p[1]);
                if !near {
                    return Err(ApiError::bad_request(format!(
                        "pin {}: its {which} ({}, {}) is not a point near the {width}×{height} frame",
                        k + 1,
                        p[0],
                        p[1]
                    )));
                }
            }
        }
        let mut options = PoseOptions::default();
        for (name, given, slot) in [
            ("alpha_reg", self.alpha_reg, &mut options.alpha_reg),
            ("alpha_joints", self.alpha_joints, &mut options.alpha_joints),
        ] {
            if let Some(v) = given {
                if !(v.is_finite() && (0.0..=MAX_ALPHA).contains(&v)) {
                    return Err(ApiError::bad_request(format!("{name} is {v}; give a number from 0 to {MAX_ALPHA}")));
                }
                *slot = v;
            }
        }
        if let Some(steps) = self.steps {
            if !(1..=MAX_DRAG_STEPS).contains(&steps) {
                return Err(ApiError::bad_request(format!("steps is {steps}; give from 1 to {MAX_DRAG_STEPS}")));
            }
            options.steps = steps;
        }
        Ok((self.pins.iter().map(|p| Pin { from: p.from, to: p.to }).collect(), options))
    }
}

async fn drag(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: DragRequest = parse(body)?;
    let puppet = &app.model().puppet;
    let (pins, options) = request.validate(puppet.width, puppet.height)?;
    let session = request.session;
    let (dragged, latent) = blocking(move || app.drag(&session, &pins, &options)).await?;
    Ok(Json(json!({ "vertices": dragged.vertices, "pin_error": dragged.pin_error, "latent": latent })).into_response())
}

/// `POST /api/latent`: a pose by its latent (undo, redo, reset), moved along the sliders.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LatentRequest {
    session: String,
    latent: Vec<f32>,
    #[serde(default)]
    sliders: Vec<f32>,
}

async fn latent(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: LatentRequest = parse(body)?;
    let pose = blocking(move || app.set_latent(&request.session, &request.latent, &request.sliders)).await?;
    Ok(Json(pose_json(None, &pose)).into_response())
}

/// `POST /api/outfit`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutfitRequest {
    session: String,
    outfit: usize,
}

async fn outfit(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: OutfitRequest = parse(body)?;
    let (fit, now) = blocking(move || app.wear(&request.session, request.outfit)).await?;
    Ok(Json(pose_json(Some(&fit), &now)).into_response())
}

/// `POST /api/inbetween`, and the in-between of a download.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InbetweenRequest {
    /// The first key, a frame index.
    from: usize,
    /// The second key.
    to: usize,
    /// In-betweens between the keys, uniform steps eased by `easing` (default 8).
    count: Option<usize>,
    /// `linear` (default), `ease-in`, `ease-out` or `ease-in-out`.
    easing: Option<String>,
    /// In-betweens placed by hand (each in (0, 1), increasing), instead of `count` and `easing`.
    spacing: Option<Vec<f32>>,
    /// The outfit to draw (default 0).
    #[serde(default)]
    outfit: usize,
}

impl InbetweenRequest {
    /// The interpolation parameters, keys included.
    fn t(&self) -> Result<Vec<f32>, ApiError> {
        if let Some(spacing) = &self.spacing {
            if self.count.is_some() || self.easing.is_some() {
                return Err(ApiError::bad_request("give either spacing, or count and easing, not both"));
            }
            return Ok(spacing_t(spacing, MAX_INBETWEENS)?);
        }
        let easing = match &self.easing {
            Some(name) => name.parse::<Easing>().map_err(ApiError::bad_request)?,
            None => Easing::Linear,
        };
        Ok(eased_t(self.count.unwrap_or(8), easing, MAX_INBETWEENS.min(MAX_STEPS))?)
    }

    /// The poses at `t`, keys included, in the request's outfit. Blocks for fits.
    fn poses(&self, app: &App, t: &[f32]) -> Result<Vec<Vec<[f32; 2]>>, ApiError> {
        app.inbetween(self.from, self.to, t, self.outfit)
    }
}

async fn inbetween(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: InbetweenRequest = parse(body)?;
    let t = request.t()?;
    let poses = {
        let t = t.clone();
        blocking(move || request.poses(&app, &t)).await?
    };
    Ok(Json(json!({ "t": t, "poses": poses })).into_response())
}

/// `POST /api/export`: the session's pose or an in-between, as a file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExportRequest {
    /// `png`, `gif`, `apng`, `sheet` or `spine`.
    format: String,
    /// The session whose current pose to export…
    session: Option<String>,
    /// …or an in-between…
    inbetween: Option<InbetweenRequest>,
    /// …or the motion played last.
    #[serde(default)]
    motion: bool,
    /// Accessory layers to leave out.
    #[serde(default)]
    hidden: Vec<String>,
    /// `transparent` (default) or `#rrggbb`.
    background: Option<String>,
    /// Frame time, ms (default 80).
    delay_ms: Option<u32>,
    /// `crisp` (default) or `soft`: a PNG of the pose as the soft rasterizer draws it at the
    /// σ the editor fits with (what the network compares frames with).
    render: Option<String>,
    /// Each frame as the appearance stage redraws its crisp render (not for Spine or soft).
    #[serde(default)]
    appearance: bool,
}

async fn download(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: ExportRequest = parse(body)?;
    let format: Format = request.format.parse()?;
    let background = match &request.background {
        Some(b) => b
            .parse::<Background>()
            .map_err(|e| ApiError::bad_request(format!("background {e}")))?,
        None => Background::Transparent,
    };
    let delay_ms = request.delay_ms.unwrap_or(80);
    if !(1..=MAX_DELAY_MS).contains(&delay_ms) {
        return Err(ApiError::bad_request(format!(
            "delay_ms is {delay_ms}; give from 1 to {MAX_DELAY_MS}"
        )));
    }
    if request.hidden.len() > MAX_HIDDEN {
        return Err(ApiError::bad_request(format!("more than {MAX_HIDDEN} hidden layers")));
    }
    let sigma = match request.render.as_deref() {
        None | Some("crisp") => 0.0,
        Some("soft") if format == Format::Png && request.session.is_some() => app.soft_sigma(),
        Some("soft") => return Err(ApiError::bad_request("a soft render is a PNG of the pose only")),
        Some(other) => return Err(ApiError::bad_request(format!("render {other:?}: give crisp or soft"))),
    };
    let file = blocking(move || {
        let style = ExportStyle {
            hidden: request.hidden.clone(),
            background,
            delay_ms,
            sigma,
            appearance: if request.appearance { Some(app.appearance()?) } else { None },
        };
        let d = drawn(
            &app,
            request.session.as_deref(),
            request.inbetween.as_ref(),
            request.motion,
            "export",
        )?;
        Ok(export(&app.outfit(d.outfit)?.model, d.poses, format, &style, d.stem)?)
    })
    .await?;
    let disposition = format!("attachment; filename=\"{}\"", file.name);
    Ok((
        [
            (header::CONTENT_TYPE, file.media_type.to_string()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        file.bytes,
    )
        .into_response())
}

/// What a download or a redraw draws.
struct Drawn {
    /// The outfit.
    outfit: usize,
    /// The poses, frame pixels.
    poses: Vec<Vec<[f32; 2]>>,
    /// The file stem naming them.
    stem: &'static str,
}

/// What a download or a redraw asks for: the session's current pose, an in-between (keys
/// included) or the motion played last. Blocks for fits.
fn drawn(app: &App, session: Option<&str>, inbetween: Option<&InbetweenRequest>, motion: bool, what: &str) -> Result<Drawn, ApiError> {
    match (session, inbetween, motion) {
        (None, None, true) => {
            let motion = app.motion()?;
            Ok(Drawn {
                outfit: motion.outfit,
                poses: motion.poses.clone(),
                stem: "motion",
            })
        }
        (Some(id), None, false) => {
            let (outfit, pose) = app.current_pose(id)?;
            Ok(Drawn {
                outfit,
                poses: vec![pose],
                stem: "pose",
            })
        }
        (None, Some(between), false) => Ok(Drawn {
            outfit: between.outfit,
            poses: between.poses(app, &between.t()?)?,
            stem: "inbetween",
        }),
        _ => Err(ApiError::bad_request(format!(
            "give one of a session (its pose), an inbetween or motion = true to {what}"
        ))),
    }
}

/// `POST /api/appearance`: the session's pose or an in-between as the appearance stage redraws
/// it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AppearanceRequest {
    /// The session whose current pose to redraw…
    session: Option<String>,
    /// …or an in-between…
    inbetween: Option<InbetweenRequest>,
    /// …or the motion played last.
    #[serde(default)]
    motion: bool,
    /// Accessory layers to leave out.
    #[serde(default)]
    hidden: Vec<String>,
}

/// One PNG of straight-alpha frames side by side (frame k at x = k × width).
async fn appearance(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: AppearanceRequest = parse(body)?;
    if request.hidden.len() > MAX_HIDDEN {
        return Err(ApiError::bad_request(format!("more than {MAX_HIDDEN} hidden layers")));
    }
    let bytes = blocking(move || {
        let (stage, device) = app.appearance()?;
        let d = drawn(
            &app,
            request.session.as_deref(),
            request.inbetween.as_ref(),
            request.motion,
            "redraw",
        )?;
        let strip = redrawn_strip(&app.outfit(d.outfit)?.model, &d.poses, &request.hidden, stage, device)?;
        Ok(strip.png_bytes(std::path::Path::new("appearance.png"))?)
    })
    .await?;
    Ok(png(bytes))
}

/// `POST /api/suggest`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuggestRequest {
    /// Suggestions wanted (default 3).
    count: Option<usize>,
}

/// The poses worth drawing next, best first: each with its trace-over picture, pose, scores and
/// origin in words.
async fn suggest(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: SuggestRequest = parse(body)?;
    let count = request.count.unwrap_or(3);
    let suggested = {
        let app = app.clone();
        blocking(move || {
            let frames = app.training_frames();
            let pictures: Vec<&Picture> = frames.iter().map(|f| &f.picture).collect();
            app.next().suggest(app.model(), &pictures, count, app.device())
        })
        .await?
    };
    let suggestions: Vec<_> = suggested
        .suggestions
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let c = &s.candidate;
            json!({
                "index": k,
                "picture": format!("/api/suggestion/{k}.png"),
                "vertices": c.pose,
                "misread_px": c.misread,
                "coverage_px": c.coverage,
                "distance_degrees": c.distance,
                "origin": c.origin.to_string(),
                "origin_detail": c.origin,
            })
        })
        .collect();
    Ok(Json(json!({
        "suggestions": suggestions,
        "candidates": suggested.candidates,
        "seconds": suggested.seconds,
    }))
    .into_response())
}

async fn suggestion(State(app): State<Arc<App>>, file: Result<Path<String>, PathRejection>) -> Result<Response, ApiError> {
    let Ok(Path(file)) = file else {
        return Err(ApiError::bad_request("the suggestion path is not readable"));
    };
    Ok(png(app.next().trace(png_index(&file, "suggestion")?)?))
}

/// `POST /api/drawing?suggestion=<k>&name=<file>` with the drawing as the body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DrawingQuery {
    /// The suggestion drawn (an index into the latest suggestions), if any.
    suggestion: Option<usize>,
    name: Option<String>,
}

/// The artist's drawing joins the frames in the folder of drawings; answers with that folder's
/// status and the drawing's file name there.
async fn drawing(
    State(app): State<Arc<App>>,
    query: Result<Query<DrawingQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let Ok(Query(query)) = query else {
        return Err(ApiError::bad_request(
            "a drawing takes the query parameters suggestion (its number) and name (the file's name)",
        ));
    };
    let bytes = uploaded(body)?;
    let name = label(query.name, "drawing");
    let (file, status) = blocking(move || {
        let drawing = app.read_frame(&name, &bytes)?;
        let file = app.next().add_drawing(&drawing, query.suggestion, &name)?;
        Ok((file, app.next().status()))
    })
    .await?;
    let mut out = json!(status);
    out["drawing"] = json!(file);
    Ok(Json(out).into_response())
}

async fn next(State(app): State<Arc<App>>) -> Response {
    Json(json!(app.next().status())).into_response()
}

/// `POST /api/continue`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContinueRequest {
    /// Optimiser steps (default: the status's `default_steps`).
    steps: Option<u64>,
}

/// Starts the continuation in the background; answers with the status to poll at `/api/next`.
async fn continue_training(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: ContinueRequest = parse(body)?;
    let status = blocking(move || {
        app.next().start(request.steps)?;
        Ok(app.next().status())
    })
    .await?;
    Ok(Json(json!(status)).into_response())
}

/// Asks the running continuation to stop after its step; answers with the status.
async fn stop_training(State(app): State<Arc<App>>) -> Result<Response, ApiError> {
    app.next().stop()?;
    Ok(Json(json!(app.next().status())).into_response())
}

/// `POST /api/motion?name=<file>&view=front|side&rigid=&in_place=&fps=&outfit=` with the BVH
/// file as the body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionQuery {
    name: Option<String>,
    view: Option<String>,
    #[serde(default)]
    rigid: bool,
    #[serde(default)]
    in_place: bool,
    fps: Option<f32>,
    #[serde(default)]
    outfit: usize,
}

/// A motion played on the character: its poses and frame time, and which joint drives which
/// layer.
async fn motion(
    State(app): State<Arc<App>>,
    query: Result<Query<MotionQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let query = match query {
        Ok(Query(query)) => query,
        Err(e) => {
            return Err(ApiError::bad_request(format!(
                "a motion takes the query parameters name, view (front or side), rigid, in_place (true or false), fps and outfit: {}",
                e.body_text()
            )))
        }
    };
    let view = match query.view.as_deref() {
        None | Some("front") => View::Front,
        Some("side") => View::Side,
        Some(other) => return Err(ApiError::bad_request(format!("view {other:?}: give front or side"))),
    };
    let options = PlayOptions {
        view,
        rigid: query.rigid,
        in_place: query.in_place,
        fps: query.fps,
        outfit: query.outfit,
    };
    let bytes = uploaded(body)?;
    let name = label(query.name, "motion");
    let started = std::time::Instant::now();
    let played = {
        let name = name.clone();
        blocking(move || play(&app, &name, &bytes, &options)).await?
    };
    let pairs: Vec<_> = played
        .pairs
        .iter()
        .map(|(joint, layer)| json!({ "joint": joint, "layer": layer }))
        .collect();
    Ok(Json(json!({
        "name": name,
        "frames": played.poses.len(),
        "frame_time": played.frame_time,
        "joints": played.joints,
        "pairs": pairs,
        "warnings": played.warnings,
        "poses": played.poses,
        "seconds": started.elapsed().as_secs_f64(),
    }))
    .into_response())
}
