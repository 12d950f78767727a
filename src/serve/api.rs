//! The HTTP routes of the web editor: the page, the puppet and its textures, the frames, and the
//! editing sessions. Every request is validated before it reaches the editor (finite numbers,
//! bounded counts, no unknown fields), and every refusal is a 4xx with `{"error": "…"}` in plain
//! words; the library's errors keep their own messages.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, PathRejection};
use axum::extract::{DefaultBodyLimit, Path, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::json;

use super::state::App;
use crate::edit::pose::{Pin, PoseOptions};
use crate::error::Error;
use crate::puppet::LayerKind;

/// The page: one HTML file with its script, part of the binary.
const PAGE: &str = include_str!("page.html");

/// The most pins one drag may carry (a person pins a handful; the bound keeps a request's work
/// small).
pub const MAX_PINS: usize = 64;

/// The largest request body, bytes: 64 pins are about 5 KB of JSON.
pub const MAX_BODY: usize = 64 * 1024;

/// The largest drag weight α accepted (the paper's are 25 and 50).
pub const MAX_ALPHA: f32 = 10_000.0;

/// A refused or failed request: its status and a message in plain words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ApiError {
    /// The HTTP status.
    pub status: StatusCode,
    /// What was wrong.
    pub message: String,
}

impl ApiError {
    /// 400: the request itself is malformed.
    pub fn bad_request(message: impl Into<String>) -> Self {
        ApiError {
            status: StatusCode::BAD_REQUEST,
            message: message.into(),
        }
    }

    /// 404: what it names does not exist.
    pub fn not_found(message: impl Into<String>) -> Self {
        ApiError {
            status: StatusCode::NOT_FOUND,
            message: message.into(),
        }
    }
}

/// The status for a library error: what the user asked for that cannot be done is 422 (a point
/// off the character) or 400 (a bad number); anything else is the server's fault, 500.
fn status_of(err: &Error) -> StatusCode {
    match err {
        Error::WithPath { err, .. } | Error::WithFrame { err, .. } | Error::WithKey { err, .. } | Error::WithPin { err, .. } => {
            status_of(err)
        }
        Error::Partial(errors) => errors
            .iter()
            .map(status_of)
            .max_by_key(|s| s.as_u16())
            .unwrap_or(StatusCode::INTERNAL_SERVER_ERROR),
        Error::OffCharacter { .. } => StatusCode::UNPROCESSABLE_ENTITY,
        Error::Setting { .. } | Error::Mismatch { .. } | Error::Geometry { .. } | Error::Limit { .. } => StatusCode::BAD_REQUEST,
        _ => StatusCode::INTERNAL_SERVER_ERROR,
    }
}

impl From<Error> for ApiError {
    fn from(err: Error) -> Self {
        ApiError {
            status: status_of(&err),
            message: err.to_string(),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.status, Json(json!({ "error": self.message }))).into_response()
    }
}

/// The routes over `app` (see the module doc of [`crate::serve`] for the list).
pub fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/api/puppet", get(puppet))
        .route("/api/texture/{file}", get(texture))
        .route("/api/frames", get(frames))
        .route("/api/frame/{file}", get(frame))
        .route("/api/session", post(session))
        .route("/api/drag", post(drag))
        .fallback(|| async { ApiError::not_found("no such page or API route") })
        .method_not_allowed_fallback(|| async {
            ApiError {
                status: StatusCode::METHOD_NOT_ALLOWED,
                message: "this route does not take that method (the API reads with GET and edits with POST)".into(),
            }
        })
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .with_state(app)
}

async fn page() -> Html<&'static str> {
    Html(PAGE)
}

/// The puppet as the page draws it: per layer its name, kind, triangles, UVs, rest vertices and
/// the offset of its vertices in the global numbering the poses use.
async fn puppet(State(app): State<Arc<App>>) -> Response {
    let puppet = &app.model().puppet;
    let offsets = puppet.vertex_offsets();
    let layers: Vec<_> = puppet
        .layers
        .iter()
        .enumerate()
        .map(|(i, l)| {
            json!({
                "name": l.name,
                "kind": match l.kind { LayerKind::Body => "body", LayerKind::Accessory => "accessory" },
                "offset": offsets[i],
                "triangles": l.mesh.triangles,
                "uvs": l.uvs,
                "rest": l.mesh.vertices,
                "texture": format!("/api/texture/{i}.png"),
            })
        })
        .collect();
    Json(json!({
        "width": puppet.width,
        "height": puppet.height,
        "vertex_count": puppet.vertex_count(),
        "layers": layers,
    }))
    .into_response()
}

/// The index in a `<i>.png` path segment.
fn png_index(file: Result<Path<String>, PathRejection>, what: &str) -> Result<usize, ApiError> {
    let Ok(Path(file)) = file else {
        return Err(ApiError::bad_request(format!("the {what} path is not readable")));
    };
    file.strip_suffix(".png")
        .and_then(|i| i.parse::<usize>().ok())
        .ok_or_else(|| ApiError::not_found(format!("{file:?} is not a {what} (ask for <number>.png)")))
}

fn png(bytes: Vec<u8>) -> Response {
    ([(header::CONTENT_TYPE, "image/png")], bytes).into_response()
}

async fn texture(State(app): State<Arc<App>>, file: Result<Path<String>, PathRejection>) -> Result<Response, ApiError> {
    let i = png_index(file, "layer texture")?;
    app.texture_png(i).map(|b| png(b.to_vec())).ok_or_else(|| {
        ApiError::not_found(format!(
            "there is no layer {i} (the puppet has {} layers)",
            app.model().puppet.layers.len()
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
    let i = png_index(file, "frame")?;
    let f = app
        .frames()
        .get(i)
        .ok_or_else(|| ApiError::not_found(format!("there is no frame {i} ({} frames)", app.frames().len())))?;
    Ok(png(f.picture.png_bytes(std::path::Path::new(&f.name))?))
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

/// `POST /api/session`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SessionRequest {
    /// The frame to fit, an index into `/api/frames`.
    frame: usize,
}

async fn session(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: SessionRequest = parse(body)?;
    let (id, vertices) = blocking(move || app.open_session(request.frame)).await?;
    Ok(Json(json!({ "session": id, "vertices": vertices })).into_response())
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
}

impl DragRequest {
    /// The pins and options, checked: 1 to [`MAX_PINS`] pins with finite points near the frame
    /// (within a frame's size of its edges), weights from 0 to [`MAX_ALPHA`].
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
        Ok((self.pins.iter().map(|p| Pin { from: p.from, to: p.to }).collect(), options))
    }
}

async fn drag(State(app): State<Arc<App>>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let request: DragRequest = parse(body)?;
    let puppet = &app.model().puppet;
    let (pins, options) = request.validate(puppet.width, puppet.height)?;
    let session = request.session;
    let dragged = blocking(move || app.drag(&session, &pins, &options)).await?;
    Ok(Json(json!({ "vertices": dragged.vertices, "pin_error": dragged.pin_error })).into_response())
}

#[cfg(test)]
mod tests {
    use axum::body::Body;
    use axum::http::Request;
    use serde_json::Value;
    use tower::ServiceExt as _;

    use super::*;
    use crate::fit::FitOptions;
    use crate::serve::{EditorFrame, ServeOptions};

    /// The tiny test character with a small untrained model whose decoder's last layer is random
    /// (an untrained one predicts the rest pose whatever the latent, so no drag could move it),
    /// offering two frames: the rest render and a copy shifted 2 px right.
    fn app(max_sessions: usize) -> Arc<App> {
        let (model, device) = crate::edit::test_support::small_model(0.3);
        let rest = model.puppet.rest_vertices();
        let shifted: Vec<[f32; 2]> = rest.iter().map(|v| [v[0] + 2.0, v[1]]).collect();
        let frames = [("rest.png", &rest), ("shifted.png", &shifted)]
            .into_iter()
            .map(|(name, v)| EditorFrame {
                name: name.into(),
                held_out: name == "shifted.png",
                picture: crate::render::render_crisp(&model.puppet, v, 48, 40).unwrap(),
            })
            .collect();
        let options = ServeOptions::new(FitOptions::one_pass()).with_max_sessions(max_sessions);
        Arc::new(App::new(model, frames, options, &device).unwrap())
    }

    /// Sends one request to the router in-process; returns the status and the body (JSON parsed
    /// where it is JSON, else `Value::Null`) and the raw bytes.
    async fn call(app: &Arc<App>, method: &str, uri: &str, body: &str) -> (StatusCode, Value, Vec<u8>) {
        let request = Request::builder()
            .method(method)
            .uri(uri)
            .header("content-type", "application/json")
            .body(Body::from(body.to_string()))
            .unwrap();
        let response = router(app.clone()).oneshot(request).await.unwrap();
        let status = response.status();
        let bytes = axum::body::to_bytes(response.into_body(), 1 << 26).await.unwrap().to_vec();
        (status, serde_json::from_slice(&bytes).unwrap_or(Value::Null), bytes)
    }

    fn points(v: &Value) -> Vec<[f32; 2]> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap() as f32, p[1].as_f64().unwrap() as f32])
            .collect()
    }

    /// The centre of the arm tip's last triangle in `vertices` (on the character in any pose).
    fn arm_tip(app: &App, vertices: &[[f32; 2]]) -> [f32; 2] {
        let puppet = &app.model().puppet;
        let arm = puppet.layer_index("arm_front").unwrap();
        let offset = puppet.vertex_offsets()[arm];
        let tip = *puppet.layers[arm].mesh.triangles.last().unwrap();
        let corners = tip.map(|i| vertices[offset + i as usize]);
        [0, 1].map(|c| corners.iter().map(|p| p[c]).sum::<f32>() / 3.0)
    }

    #[tokio::test]
    async fn the_page_puppet_textures_and_frames_are_served() {
        let app = app(4);
        let (status, _, page) = call(&app, "GET", "/", "").await;
        assert_eq!(status, StatusCode::OK);
        assert!(String::from_utf8(page).unwrap().contains("/api/drag"));
        let (status, puppet, _) = call(&app, "GET", "/api/puppet", "").await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!((puppet["width"].as_u64(), puppet["height"].as_u64()), (Some(48), Some(40)));
        let layers = puppet["layers"].as_array().unwrap();
        let names: Vec<&str> = layers.iter().map(|l| l["name"].as_str().unwrap()).collect();
        assert_eq!(names, ["arm_back", "torso", "head", "arm_front"]);
        let total: usize = layers.iter().map(|l| l["rest"].as_array().unwrap().len()).sum();
        assert_eq!(total as u64, puppet["vertex_count"].as_u64().unwrap());
        for l in layers {
            assert_eq!(l["uvs"].as_array().unwrap().len(), l["rest"].as_array().unwrap().len());
            let (status, _, png) = call(&app, "GET", l["texture"].as_str().unwrap(), "").await;
            assert_eq!(status, StatusCode::OK);
            assert!(png.starts_with(b"\x89PNG"), "{}", l["name"]);
        }
        let (_, frames, _) = call(&app, "GET", "/api/frames", "").await;
        let frames = frames["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 2);
        assert_eq!(
            (frames[1]["name"].as_str(), frames[1]["held_out"].as_bool()),
            (Some("shifted.png"), Some(true))
        );
        let (status, _, png) = call(&app, "GET", "/api/frame/1.png", "").await;
        assert_eq!(status, StatusCode::OK);
        let picture = image::load_from_memory(&png).unwrap();
        assert_eq!((picture.width(), picture.height()), (48, 40));
    }

    #[tokio::test]
    async fn a_drag_moves_the_pinned_point_towards_its_target_and_continues() {
        let app = app(4);
        let (status, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
        assert_eq!(status, StatusCode::OK, "{opened}");
        let session = opened["session"].as_str().unwrap().to_string();
        let fitted = points(&opened["vertices"]);
        assert_eq!(fitted.len(), app.model().puppet.vertex_count());
        let from = arm_tip(&app, &fitted);
        let to = [from[0], from[1] - 1.5];
        // Only L_user: the random decoder's poses are far from rigid, so the regularisers would
        // hold the pin (the editor's own tests do the same).
        let body = json!({ "session": session, "pins": [{ "from": from, "to": to }], "alpha_reg": 0, "alpha_joints": 0 }).to_string();
        let binding = crate::edit::bind(&app.model().puppet, &fitted, from).unwrap();
        let mut errors = Vec::new();
        for _ in 0..4 {
            let (status, dragged, _) = call(&app, "POST", "/api/drag", &body).await;
            assert_eq!(status, StatusCode::OK, "{dragged}");
            assert_eq!(points(&dragged["vertices"]).len(), fitted.len());
            let e = dragged["pin_error"][0].as_f64().unwrap();
            // The reported error is the pin's distance to its target in the returned pose.
            // The pinned point, bound to the fit as the editor binds it, in the returned pose:
            // moved from where it was grabbed, and `pin_error` from its target.
            let pin = binding.position(&points(&dragged["vertices"]));
            let (moved, away) = ((pin[0] - from[0]).hypot(pin[1] - from[1]), (pin[0] - to[0]).hypot(pin[1] - to[1]));
            assert!(
                moved > 1.0 && (f64::from(away) - e).abs() < 1e-3,
                "moved {moved}, {away} from the target, reported {e}"
            );
            errors.push(e);
        }
        println!("pin error over the drags: {errors:?}");
        assert!(errors[3] < 0.8 * 1.5, "{errors:?}");
        assert!(
            errors.windows(2).all(|w| w[1] <= w[0] + 1e-3),
            "each drag continues from the last: {errors:?}"
        );
    }

    #[tokio::test]
    async fn two_sessions_do_not_share_pins_and_the_oldest_is_closed() {
        let app = app(2);
        let open = |frame: usize| {
            let app = app.clone();
            async move {
                let (status, v, _) = call(&app, "POST", "/api/session", &json!({ "frame": frame }).to_string()).await;
                assert_eq!(status, StatusCode::OK, "{v}");
                (v["session"].as_str().unwrap().to_string(), points(&v["vertices"]))
            }
        };
        let (a, fit_a) = open(0).await;
        let (b, fit_b) = open(1).await;
        assert_ne!(a, b);
        let pin_a = arm_tip(&app, &fit_a);
        let drag = |session: &str, pins: Value| json!({ "session": session, "pins": pins, "alpha_reg": 0, "alpha_joints": 0 }).to_string();
        let far = json!([{ "from": pin_a, "to": [pin_a[0] + 3.0, pin_a[1]] }]);
        let (status, dragged_a, _) = call(&app, "POST", "/api/drag", &drag(&a, far)).await;
        assert_eq!(status, StatusCode::OK, "{dragged_a}");
        // Session b has its own pins: two of them, bound on its own fit; a's one pin does not
        // reach it, and b's drag does not move a's latent.
        let tip_b = arm_tip(&app, &fit_b);
        let torso = app.model().puppet.layer_index("torso").unwrap();
        let offset = app.model().puppet.vertex_offsets()[torso];
        let t = app.model().puppet.layers[torso].mesh.triangles[0];
        let c = [0, 1].map(|k| t.iter().map(|&i| fit_b[offset + i as usize][k]).sum::<f32>() / 3.0);
        let two = json!([{ "from": tip_b, "to": tip_b }, { "from": c, "to": c }]);
        let (status, dragged_b, _) = call(&app, "POST", "/api/drag", &drag(&b, two)).await;
        assert_eq!(status, StatusCode::OK, "{dragged_b}");
        assert_eq!(dragged_b["pin_error"].as_array().unwrap().len(), 2);
        let again = json!([{ "from": pin_a, "to": [pin_a[0] + 3.0, pin_a[1]] }]);
        let (_, again_a, _) = call(&app, "POST", "/api/drag", &drag(&a, again)).await;
        assert_eq!(again_a["pin_error"].as_array().unwrap().len(), 1);
        assert!(again_a["pin_error"][0].as_f64() <= dragged_a["pin_error"][0].as_f64().map(|e| e + 1e-3));
        // A third session closes the least recently used (b: a was used last).
        let (_c, _) = open(0).await;
        assert_eq!(app.session_count(), 2);
        let (status, gone, _) = call(&app, "POST", "/api/drag", &drag(&b, json!([{ "from": tip_b, "to": tip_b }]))).await;
        assert_eq!(status, StatusCode::NOT_FOUND, "{gone}");
        assert!(gone["error"].as_str().unwrap().contains("pick a frame again"));
        let (status, _, _) = call(&app, "POST", "/api/drag", &drag(&a, json!([{ "from": pin_a, "to": pin_a }]))).await;
        assert_eq!(status, StatusCode::OK);
    }

    #[tokio::test]
    async fn malformed_requests_get_a_4xx_with_a_message_and_the_server_keeps_serving() {
        let app = app(4);
        let (_, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
        let session = opened["session"].as_str().unwrap().to_string();
        let on = arm_tip(&app, &points(&opened["vertices"]));
        let many: Vec<Value> = (0..MAX_PINS + 1).map(|_| json!({ "from": on, "to": on })).collect();
        let pin = |from: Value, to: Value| json!({ "session": session, "pins": [{ "from": from, "to": to }] }).to_string();
        let cases: Vec<(&str, &str, String, &str)> = vec![
            ("POST", "/api/drag", "{not json".into(), "not the JSON"),
            ("POST", "/api/drag", "".into(), "not the JSON"),
            ("POST", "/api/drag", "[1, 2]".into(), "not the JSON"),
            ("POST", "/api/drag", pin(json!("NaN"), json!([1, 2])), "not the JSON"),
            ("POST", "/api/drag", pin(json!(on), json!([1e39, 2])), "out of range"),
            ("POST", "/api/drag", pin(json!(on), json!([-1e6, 2])), "not a point near"),
            (
                "POST",
                "/api/drag",
                r#"{"session": "x", "pins": [{"from": [NaN, 1], "to": [1, 1]}]}"#.into(),
                "not the JSON",
            ),
            ("POST", "/api/drag", pin(json!([-30, -30]), json!([1, 1])), "not on the character"),
            ("POST", "/api/drag", pin(json!([2, 2]), json!([1, 1])), "not on the character"),
            ("POST", "/api/drag", pin(json!([1]), json!([1, 1])), "not the JSON"),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": [] }).to_string(),
                "from 1 to",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": many }).to_string(),
                "from 1 to",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": "nope", "pins": [{ "from": on, "to": on }] }).to_string(),
                "no such editing session",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": [{ "from": on, "to": on }], "alpha_reg": -1 }).to_string(),
                "alpha_reg",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": [{ "from": on, "to": on }], "alpha_joints": 1e30 }).to_string(),
                "alpha_joints",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": [{ "from": on, "to": on }], "eta": 3 }).to_string(),
                "unknown field",
            ),
            (
                "POST",
                "/api/drag",
                json!({ "session": session, "pins": [{ "from": on, "to": on, "weight": 2 }] }).to_string(),
                "unknown field",
            ),
            ("POST", "/api/drag", "x".repeat(MAX_BODY + 1), "cannot be read"),
            ("POST", "/api/session", r#"{"frame": 99}"#.into(), "no frame 99"),
            ("POST", "/api/session", r#"{"frame": -1}"#.into(), "not the JSON"),
            ("POST", "/api/session", r#"{"frame": 18446744073709551616}"#.into(), "not the JSON"),
            ("POST", "/api/session", r#"{"frame": 0, "model": "other"}"#.into(), "unknown field"),
            ("GET", "/api/texture/9.png", String::new(), "no layer 9"),
            ("GET", "/api/texture/x.png", String::new(), "not a layer texture"),
            ("GET", "/api/frame/99999999999999999999.png", String::new(), "not a frame"),
            ("GET", "/api/nothing", String::new(), "no such page"),
            ("GET", "/api/drag", String::new(), "does not take that method"),
        ];
        for round in 0..40 {
            for (method, uri, body, says) in &cases {
                let (status, answer, _) = call(&app, method, uri, body).await;
                assert!(status.is_client_error(), "{method} {uri} {body:.80}: {status} {answer}");
                let message = answer["error"].as_str().unwrap_or_default();
                assert!(message.contains(says), "{method} {uri} {body:.80}: {message:?} should say {says:?}");
                if round > 0 {
                    continue;
                }
                println!("{status} {message}");
            }
        }
        // Still serving, the session still there and working.
        let (status, dragged, _) = call(&app, "POST", "/api/drag", &pin(json!(on), json!(on))).await;
        assert_eq!(status, StatusCode::OK, "{dragged}");
        assert_eq!(app.session_count(), 1);
    }
}
