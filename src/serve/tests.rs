//! The editor's routes in-process: what each answers, that sessions stay apart, and that every
//! malformed request gets a 4xx with a message while the server keeps serving.

use std::sync::Arc;

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use serde_json::{json, Value};
use tower::ServiceExt as _;

use super::api::{MAX_BODY, MAX_INBETWEENS, MAX_PINS};
use super::next::MAX_CONTINUE_STEPS;
use super::{router, App, EditorFrame, HostGuard, ServeOptions};
use crate::appearance::AppearanceStage;
use crate::fit::FitOptions;
use crate::model::appearance::AppearanceNetConfig;

/// The tiny test character with a small untrained model whose decoder's last layer is random
/// (an untrained one predicts the rest pose whatever the latent, so no drag could move it),
/// offering three frames: the rest render, a copy shifted 2 px right (held out) and one 3 px up.
fn app(max_sessions: usize) -> Arc<App> {
    app_with(ServeOptions::new(FitOptions::one_pass()).with_max_sessions(max_sessions))
}

/// [`app`] with `options`.
fn app_with(options: ServeOptions) -> Arc<App> {
    let (model, device) = crate::edit::test_support::small_model(0.3);
    let rest = model.puppet.rest_vertices();
    let shifted: Vec<[f32; 2]> = rest.iter().map(|v| [v[0] + 2.0, v[1]]).collect();
    let up: Vec<[f32; 2]> = rest.iter().map(|v| [v[0], v[1] - 3.0]).collect();
    let frames = [("rest.png", &rest), ("shifted.png", &shifted), ("up.png", &up)]
        .into_iter()
        .map(|(name, v)| EditorFrame {
            name: name.into(),
            held_out: name == "shifted.png",
            picture: crate::render::render_crisp(&model.puppet, v, 48, 40).unwrap(),
        })
        .collect();
    Arc::new(App::new(model, frames, Vec::new(), options, &device).unwrap())
}

/// The guard of an editor on 127.0.0.1:8080.
fn local() -> HostGuard {
    HostGuard::new(([127, 0, 0, 1], 8080).into())
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
    let response = router(app.clone(), local()).oneshot(request).await.unwrap();
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
    let outfits = puppet["outfits"].as_array().unwrap();
    assert_eq!(outfits.len(), 1, "the model's own only");
    assert_eq!(puppet["sliders"].as_u64(), Some(1), "two training frames span one direction");
    let layers = outfits[0]["layers"].as_array().unwrap();
    let names: Vec<&str> = layers.iter().map(|l| l["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["arm_back", "torso", "head", "arm_front"]);
    let total: usize = layers.iter().map(|l| l["rest"].as_array().unwrap().len()).sum();
    assert_eq!(total as u64, outfits[0]["vertex_count"].as_u64().unwrap());
    for l in layers {
        assert_eq!(l["uvs"].as_array().unwrap().len(), l["rest"].as_array().unwrap().len());
        let (status, _, png) = call(&app, "GET", l["texture"].as_str().unwrap(), "").await;
        assert_eq!(status, StatusCode::OK);
        assert!(png.starts_with(b"\x89PNG"), "{}", l["name"]);
    }
    let (_, frames, _) = call(&app, "GET", "/api/frames", "").await;
    let frames = frames["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
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
    let latent = opened["latent"].clone();
    let short: Vec<f32> = vec![0.0; 3];
    let between = |v: Value| json!({ "format": "gif", "inbetween": v }).to_string();
    /// A POST case: the route, the body (JSON text or value), what the refusal must say.
    fn post(uri: &'static str, body: impl ToString, says: &'static str) -> (&'static str, &'static str, String, &'static str) {
        ("POST", uri, body.to_string(), says)
    }
    // One pin on the character, with one more field.
    let one_pin_and = |key: &str, value: Value| {
        let mut request = json!({ "session": session, "pins": [{ "from": on, "to": on }] });
        request[key] = value;
        request
    };
    let cases: Vec<(&str, &str, String, &str)> = vec![
        post("/api/drag", one_pin_and("steps", json!(0)), "steps is 0"),
        post("/api/drag", one_pin_and("steps", json!(101)), "steps is 101"),
        post("/api/latent", json!({ "session": session, "latent": short }), "this model's has 16"),
        post(
            "/api/latent",
            json!({ "session": session, "latent": latent.as_array().unwrap().iter().map(|_| 1e9).collect::<Vec<_>>() }),
            "give numbers from",
        ),
        post(
            "/api/latent",
            json!({ "session": session, "latent": latent, "sliders": [1, 2] }),
            "slider count",
        ),
        post(
            "/api/latent",
            json!({ "session": "nope", "latent": latent }),
            "no such editing session",
        ),
        post("/api/latent", json!({ "session": session }), "missing field"),
        post("/api/outfit", json!({ "session": session, "outfit": 5 }), "no outfit 5"),
        post("/api/session", r#"{"frame": 0, "outfit": 1}"#, "no outfit 1"),
        post("/api/inbetween", r#"{"from": 0, "to": 99}"#, "no frame 99"),
        post("/api/inbetween", r#"{"from": 0, "to": 2, "count": 0}"#, "at least 1"),
        post(
            "/api/inbetween",
            json!({ "from": 0, "to": 2, "count": MAX_INBETWEENS + 1 }),
            "limit",
        ),
        post("/api/inbetween", r#"{"from": 0, "to": 2, "count": 1e30}"#, "not the JSON"),
        post("/api/inbetween", r#"{"from": 0, "to": 2, "easing": "bounce"}"#, "not an easing"),
        post(
            "/api/inbetween",
            r#"{"from": 0, "to": 2, "spacing": [0.5, 0.2]}"#,
            "spacing value 2",
        ),
        post("/api/inbetween", r#"{"from": 0, "to": 2, "spacing": []}"#, "at least one value"),
        post(
            "/api/inbetween",
            r#"{"from": 0, "to": 2, "spacing": [0.5], "count": 3}"#,
            "not both",
        ),
        post("/api/inbetween", r#"{"from": 0, "to": 2, "outfit": 3}"#, "no outfit 3"),
        post("/api/export", r#"{"format": "psd", "session": "x"}"#, "not a download format"),
        post("/api/export", r#"{"format": "png"}"#, "give one of a session"),
        post(
            "/api/export",
            json!({ "format": "png", "session": session, "inbetween": { "from": 0, "to": 2 } }),
            "give one of a session",
        ),
        post(
            "/api/export",
            json!({ "format": "png", "session": session, "background": "red" }),
            "background",
        ),
        post(
            "/api/export",
            json!({ "format": "png", "session": session, "delay_ms": 0 }),
            "delay_ms is 0",
        ),
        post(
            "/api/export",
            json!({ "format": "png", "session": session, "hidden": ["nothing"] }),
            "nothing",
        ),
        post(
            "/api/export",
            json!({ "format": "png", "session": "gone" }),
            "no such editing session",
        ),
        post(
            "/api/export",
            json!({ "format": "png", "session": session, "render": "blurry" }),
            "crisp or soft",
        ),
        post(
            "/api/export",
            json!({ "format": "gif", "session": session, "render": "soft" }),
            "PNG of the pose only",
        ),
        post("/api/export", between(json!({ "from": 0, "to": 2, "count": 100_000 })), "limit"),
        post(
            "/api/export",
            between(json!({ "from": 0, "to": 2, "easing": "ease" })),
            "not an easing",
        ),
        post("/api/drag", "{not json", "not the JSON"),
        post("/api/drag", "", "not the JSON"),
        post("/api/drag", "[1, 2]", "not the JSON"),
        post("/api/drag", pin(json!("NaN"), json!([1, 2])), "not the JSON"),
        post("/api/drag", pin(json!(on), json!([1e39, 2])), "out of range"),
        post("/api/drag", pin(json!(on), json!([-1e6, 2])), "not a point near"),
        post(
            "/api/drag",
            r#"{"session": "x", "pins": [{"from": [NaN, 1], "to": [1, 1]}]}"#,
            "not the JSON",
        ),
        post("/api/drag", pin(json!([-30, -30]), json!([1, 1])), "not on the character"),
        post("/api/drag", pin(json!([2, 2]), json!([1, 1])), "not on the character"),
        post("/api/drag", pin(json!([1]), json!([1, 1])), "not the JSON"),
        post("/api/drag", json!({ "session": session, "pins": [] }), "from 1 to"),
        post("/api/drag", json!({ "session": session, "pins": many }), "from 1 to"),
        post(
            "/api/drag",
            json!({ "session": "nope", "pins": [{ "from": on, "to": on }] }),
            "no such editing session",
        ),
        post("/api/drag", one_pin_and("alpha_reg", json!(-1)), "alpha_reg"),
        post("/api/drag", one_pin_and("alpha_joints", json!(1e30)), "alpha_joints"),
        post("/api/drag", one_pin_and("eta", json!(3)), "unknown field"),
        post(
            "/api/drag",
            json!({ "session": session, "pins": [{ "from": on, "to": on, "weight": 2 }] }),
            "unknown field",
        ),
        post("/api/drag", "x".repeat(MAX_BODY + 1), "cannot be read"),
        post("/api/session", r#"{"frame": 99}"#, "no frame 99"),
        post("/api/session", r#"{"frame": -1}"#, "not the JSON"),
        post("/api/session", r#"{"frame": 18446744073709551616}"#, "not the JSON"),
        post("/api/session", r#"{"frame": 0, "model": "other"}"#, "unknown field"),
        ("GET", "/api/texture/0/9.png", String::new(), "no layer 9"),
        ("GET", "/api/texture/0/x.png", String::new(), "not a layer texture"),
        ("GET", "/api/texture/1/0.png", String::new(), "no outfit 1"),
        ("GET", "/api/texture/x/0.png", String::new(), "both numbers"),
        ("GET", "/api/texture/0.png", String::new(), "no such page"),
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

/// The pose of a session as `/api/latent` and `/api/drag` report it.
async fn set_latent(app: &Arc<App>, session: &str, latent: &Value, sliders: &[f32]) -> Vec<[f32; 2]> {
    let body = json!({ "session": session, "latent": latent, "sliders": sliders }).to_string();
    let (status, answer, _) = call(app, "POST", "/api/latent", &body).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
    points(&answer["vertices"])
}

fn farthest(a: &[[f32; 2]], b: &[[f32; 2]]) -> f32 {
    a.iter().zip(b).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f32::max)
}

#[tokio::test]
async fn a_latent_sent_back_undoes_exactly_and_sliders_move_along_the_frames_spread() {
    let app = app(4);
    let (_, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
    let session = opened["session"].as_str().unwrap().to_string();
    let fitted = points(&opened["fitted"]);
    assert_eq!(opened["latent"], opened["fitted_latent"]);
    let from = arm_tip(&app, &fitted);
    let body = json!({ "session": session, "pins": [{ "from": from, "to": [from[0] + 2.0, from[1]] }], "alpha_reg": 0, "alpha_joints": 0 });
    let (_, dragged, _) = call(&app, "POST", "/api/drag", &body.to_string()).await;
    let moved = points(&dragged["vertices"]);
    assert!(farthest(&moved, &fitted) > 0.5, "the drag moved the pose");
    // Undo: the fit's latent gives the fit back; redo: the drag's gives the drag's pose back.
    assert!(farthest(&set_latent(&app, &session, &opened["fitted_latent"], &[]).await, &fitted) < 1e-4);
    assert!(farthest(&set_latent(&app, &session, &dragged["latent"], &[]).await, &moved) < 1e-4);
    // A slider at 0 is the pose itself; at ±1 it moves it, in opposite ways.
    assert!(farthest(&set_latent(&app, &session, &opened["fitted_latent"], &[0.0]).await, &fitted) < 1e-4);
    // The untrained test model's frames differ little (σ of order 1e-3), so the check is that
    // a slider's 1 is one σ along its direction, and moves the pose to either side.
    let body_plus = json!({ "session": session, "latent": opened["fitted_latent"], "sliders": [1.0] }).to_string();
    let (_, plus_answer, _) = call(&app, "POST", "/api/latent", &body_plus).await;
    let step: f32 = plus_answer["latent"]
        .as_array()
        .unwrap()
        .iter()
        .zip(opened["fitted_latent"].as_array().unwrap())
        .map(|(p, q)| (p.as_f64().unwrap() - q.as_f64().unwrap()).powi(2) as f32)
        .sum::<f32>()
        .sqrt();
    let sigma = app.directions().sigma[0];
    assert!(sigma > 0.0 && (step - sigma).abs() < 1e-3 * sigma + 1e-6, "step {step}, σ {sigma}");
    let plus = points(&plus_answer["vertices"]);
    let minus = set_latent(&app, &session, &opened["fitted_latent"], &[-1.0]).await;
    assert!(farthest(&plus, &fitted) > 0.0 && farthest(&minus, &fitted) > 0.0);
    let mid: Vec<[f32; 2]> = plus
        .iter()
        .zip(&minus)
        .map(|(p, q)| [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0])
        .collect();
    assert!(
        farthest(&mid, &fitted) < 0.5 * farthest(&plus, &fitted),
        "±1 lie on either side of the pose"
    );
    // A drag after the slider continues from the slid pose, not from the fit.
    let (_, after, _) = call(&app, "POST", "/api/drag", &body.to_string()).await;
    assert_ne!(after["latent"], dragged["latent"]);
}

#[tokio::test]
async fn inbetweens_run_from_one_fit_to_the_other_timed_as_asked() {
    let app = app(4);
    let fit = |frame: usize| {
        let app = app.clone();
        async move { points(&call(&app, "POST", "/api/session", &json!({ "frame": frame }).to_string()).await.1["fitted"]) }
    };
    let (a, b) = (fit(0).await, fit(2).await);
    let (status, eased, _) = call(
        &app,
        "POST",
        "/api/inbetween",
        r#"{"from": 0, "to": 2, "count": 3, "easing": "ease-in-out"}"#,
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{eased}");
    let t: Vec<f64> = eased["t"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(t.len(), 5);
    assert!(t[1] < 0.25 && (t[2] - 0.5).abs() < 1e-6 && t[3] > 0.75, "slow in, slow out: {t:?}");
    let poses = eased["poses"].as_array().unwrap();
    assert!(farthest(&points(&poses[0]), &a) < 1e-4 && farthest(&points(&poses[4]), &b) < 1e-4);
    let (_, spaced, _) = call(&app, "POST", "/api/inbetween", r#"{"from": 0, "to": 2, "spacing": [0.25]}"#).await;
    assert_eq!(spaced["t"], json!([0.0, 0.25, 1.0]));
}

#[tokio::test]
async fn downloads_are_files_named_for_what_they_hold() {
    let app = app(4);
    let (_, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
    let session = opened["session"].as_str().unwrap();
    let request = |body: Value| {
        Request::builder()
            .method("POST")
            .uri("/api/export")
            .body(Body::from(body.to_string()))
            .unwrap()
    };
    let response = router(app.clone(), local())
        .oneshot(request(json!({ "format": "png", "session": session, "background": "#ffffff" })))
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    let disposition = response.headers()[header::CONTENT_DISPOSITION].to_str().unwrap().to_string();
    assert_eq!(disposition, "attachment; filename=\"pose_000.png\"");
    let png = axum::body::to_bytes(response.into_body(), 1 << 26).await.unwrap();
    let picture = image::load_from_memory(&png).unwrap().to_rgba8();
    assert_eq!(picture.dimensions(), (48, 40));
    assert!(picture.pixels().all(|p| p[3] == 255), "a white background is opaque");
    let response = router(app.clone(), local())
        .oneshot(request(
            json!({ "format": "sheet", "inbetween": { "from": 0, "to": 2, "count": 2 } }),
        ))
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    assert_eq!(response.headers()[header::CONTENT_TYPE], "application/zip");
}

/// Uploads `bytes` as `name`; the status and the answer.
async fn upload(app: &Arc<App>, query: &str, bytes: Vec<u8>) -> (StatusCode, Value) {
    call_with(app, "POST", &format!("/api/upload{query}"), &[("content-type", "image/png")], bytes).await
}

#[tokio::test]
async fn an_uploaded_frame_can_be_posed_and_in_betweened_and_bad_uploads_are_refused() {
    let app = app(4);
    let puppet = &app.model().puppet;
    let left: Vec<[f32; 2]> = puppet.rest_vertices().iter().map(|v| [v[0] - 2.0, v[1]]).collect();
    let frame = crate::render::render_crisp(puppet, &left, 48, 40).unwrap();
    let png = frame.png_bytes(std::path::Path::new("left.png")).unwrap();
    let (status, answer) = upload(&app, "?name=left.png", png.clone()).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
    assert_eq!(answer["index"], json!(3));
    let (_, frames, _) = call(&app, "GET", "/api/frames", "").await;
    assert_eq!(frames["frames"][3]["name"], json!("left.png"));
    let (status, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 3}"#).await;
    assert_eq!(status, StatusCode::OK, "{opened}");
    let (status, between, _) = call(&app, "POST", "/api/inbetween", r#"{"from": 0, "to": 3, "count": 2}"#).await;
    assert_eq!(status, StatusCode::OK, "{between}");
    assert!(farthest(&points(&between["poses"][3]), &points(&opened["fitted"])) < 1e-4);

    let opaque = crate::picture::Picture::filled(48, 40, [1.0, 0.0, 0.0, 1.0])
        .png_bytes(std::path::Path::new("o.png"))
        .unwrap();
    let small = crate::picture::Picture::filled(8, 8, [0.0; 4])
        .png_bytes(std::path::Path::new("s.png"))
        .unwrap();
    for (query, bytes, says) in [
        ("?name=notes.txt", b"not a picture".to_vec(), "notes.txt"),
        ("?name=small.png", small, "the puppet's frames are 48×40"),
        ("?name=red.png", opaque, "opaque everywhere"),
        ("?name=x.png&model=y", png.clone(), "one query parameter"),
        ("?name=big.png", vec![0u8; super::api::MAX_UPLOAD_BODY + 1], "cannot be read"),
    ] {
        let (status, answer) = upload(&app, query, bytes).await;
        let message = answer["error"].as_str().unwrap_or_default();
        assert!(status.is_client_error() && message.contains(says), "{query}: {status} {message:?}");
    }
    for _ in 1..super::state::MAX_UPLOADS {
        assert_eq!(upload(&app, "", png.clone()).await.0, StatusCode::OK);
    }
    let (status, answer) = upload(&app, "?name=one_more.png", png).await;
    assert_eq!(status, StatusCode::CONFLICT, "{answer}");
    assert!(answer["error"].as_str().unwrap().contains("restart"));
}

/// The app of [`app`] with an untrained appearance stage (pix2pix's random weights: its redraw
/// is not the render, so a route answering with the render would be caught).
#[tokio::test]
async fn an_upload_is_also_fitted_from_the_prior_and_starts_from_the_closer_fit() {
    let zero_shot = FitOptions {
        latent_steps: 0,
        vertex_steps: 10,
        ..FitOptions::default()
    };
    let prior = super::UploadPrior::new(crate::prior::shipped(&crate::backend::device()).unwrap(), zero_shot);
    let app = app_with(
        ServeOptions::new(FitOptions {
            latent_steps: 5,
            ..FitOptions::one_pass()
        })
        .with_prior(prior),
    );
    let puppet = &app.model().puppet;
    let left: Vec<[f32; 2]> = puppet.rest_vertices().iter().map(|v| [v[0] - 2.0, v[1]]).collect();
    let frame = crate::render::render_crisp(puppet, &left, 48, 40).unwrap();
    let (status, answer) = upload(&app, "?name=left.png", frame.png_bytes(std::path::Path::new("left.png")).unwrap()).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
    let (status, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 3}"#).await;
    assert_eq!(status, StatusCode::OK, "{opened}");
    let start = &opened["start"];
    let (network, prior) = (start["network_l2"].as_f64().unwrap(), start["prior_l2"].as_f64().unwrap());
    assert_eq!(start["kept"], json!(if prior < network { "prior" } else { "network" }), "{start}");
    // The session starts from the pose kept: it renders at the smaller of the two L2s.
    let fitted = crate::render::render_crisp(puppet, &points(&opened["fitted"]), 48, 40).unwrap();
    let drawn = crate::metrics::l2(&fitted, &frame);
    assert!(
        (drawn - network.min(prior)).abs() <= 1e-3 * drawn.max(1.0),
        "{drawn} against {start}"
    );
    // A frame the editor was given is fitted by the network alone, as before.
    let (_, given, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
    assert!(given.get("start").is_none() && given.get("fitted").is_some(), "{given}");
}

fn app_with_appearance() -> (Arc<App>, AppearanceStage) {
    let (model, device) = crate::edit::test_support::small_model(0.3);
    let config = AppearanceNetConfig::new(model.letterbox.size as usize).with_max_channels(16);
    let stage = AppearanceStage::new(config.clone(), config.init_generator(&device), model.letterbox);
    let rest = model.puppet.rest_vertices();
    let up: Vec<[f32; 2]> = rest.iter().map(|v| [v[0], v[1] - 3.0]).collect();
    let frames = [("rest.png", &rest), ("up.png", &up)]
        .into_iter()
        .map(|(name, v)| EditorFrame {
            name: name.into(),
            held_out: false,
            picture: crate::render::render_crisp(&model.puppet, v, 48, 40).unwrap(),
        })
        .collect();
    let options = ServeOptions::new(FitOptions::one_pass()).with_appearance(stage.clone());
    (Arc::new(App::new(model, frames, Vec::new(), options, &device).unwrap()), stage)
}

/// Frame `k` of a strip of frames `width` wide.
fn strip_frame(strip: &image::RgbaImage, k: u32, width: u32) -> image::RgbaImage {
    image::imageops::crop_imm(strip, k * width, 0, width, strip.height()).to_image()
}

#[tokio::test]
async fn the_appearance_stage_redraws_the_pose_and_every_inbetween_and_downloads_them() {
    let (app, stage) = app_with_appearance();
    let device = crate::backend::device();
    let (_, puppet, _) = call(&app, "GET", "/api/puppet", "").await;
    assert_eq!(puppet["appearance"], json!(true));
    let (_, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
    let session = opened["session"].as_str().unwrap_or_else(|| panic!("{opened}"));
    let pose = points(&opened["vertices"]);
    let expected = |pose: &[[f32; 2]]| {
        let redrawn = stage.render_and_redraw(&app.model().puppet, &[pose.to_vec()], &device).unwrap();
        let (render, generated) = &redrawn[0];
        (render.to_rgba8(), generated.to_rgba8())
    };

    let (status, _, png) = call(&app, "POST", "/api/appearance", &json!({ "session": session }).to_string()).await;
    assert_eq!(status, StatusCode::OK);
    let one = image::load_from_memory(&png).unwrap().to_rgba8();
    let (render, generated) = expected(&pose);
    assert_eq!(one.dimensions(), (48, 40));
    assert!(
        one == generated && one != render,
        "the redraw of the session's pose, not its render"
    );

    let keys = json!({ "from": 0, "to": 1, "count": 2 });
    let (_, between, _) = call(&app, "POST", "/api/inbetween", &keys.to_string()).await;
    let (status, _, png) = call(&app, "POST", "/api/appearance", &json!({ "inbetween": keys }).to_string()).await;
    assert_eq!(status, StatusCode::OK);
    let strip = image::load_from_memory(&png).unwrap().to_rgba8();
    assert_eq!(strip.dimensions(), (4 * 48, 40), "keys and two in-betweens side by side");
    for k in [0, 3] {
        let pose = points(&between["poses"][k]);
        assert!(strip_frame(&strip, k as u32, 48) == expected(&pose).1, "frame {k}");
    }

    let gif = json!({ "format": "gif", "session": session, "appearance": true }).to_string();
    let (status, _, bytes) = call(&app, "POST", "/api/export", &gif).await;
    assert!(status == StatusCode::OK && bytes.starts_with(b"GIF89a"), "{status}");
    for (body, says) in [
        (json!({ "format": "spine", "session": session, "appearance": true }), "Spine"),
        (
            json!({ "format": "png", "session": session, "appearance": true, "render": "soft" }),
            "soft",
        ),
    ] {
        let (status, answer, _) = call(&app, "POST", "/api/export", &body.to_string()).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
        assert!(answer["error"].as_str().unwrap().contains(says), "{answer}");
    }
    for (body, says) in [
        (json!({}), "give one of a session"),
        (
            json!({ "session": session, "inbetween": { "from": 0, "to": 1 } }),
            "give one of a session",
        ),
        (json!({ "session": "nope" }), "session"),
        (json!({ "session": session, "hidden": ["nothing"] }), "nothing"),
        (json!({ "session": session, "colour": "red" }), "colour"),
    ] {
        let (status, answer, _) = call(&app, "POST", "/api/appearance", &body.to_string()).await;
        assert!(status.is_client_error(), "{body}: {status}");
        assert!(answer["error"].as_str().unwrap().contains(says), "{body}: {answer}");
    }
}

#[tokio::test]
async fn an_editor_without_an_appearance_stage_says_how_to_get_one() {
    let app = app(2);
    let (_, puppet, _) = call(&app, "GET", "/api/puppet", "").await;
    assert_eq!(puppet["appearance"], json!(false));
    let (_, opened, _) = call(&app, "POST", "/api/session", r#"{"frame": 0}"#).await;
    let session = opened["session"].as_str().unwrap();
    for (route, body) in [
        ("/api/appearance", json!({ "session": session })),
        ("/api/export", json!({ "format": "png", "session": session, "appearance": true })),
    ] {
        let (status, answer, _) = call(&app, "POST", route, &body.to_string()).await;
        assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{route}");
        assert!(
            answer["error"].as_str().unwrap().contains("no appearance stage"),
            "{route}: {answer}"
        );
    }
}

/// Sends `method uri` with `headers` and `body`; the status and the answer (JSON, or null).
async fn call_with(app: &Arc<App>, method: &str, uri: &str, headers: &[(&str, &str)], body: impl Into<Body>) -> (StatusCode, Value) {
    let mut request = Request::builder().method(method).uri(uri);
    for (name, value) in headers {
        request = request.header(*name, *value);
    }
    let response = router(app.clone(), local())
        .oneshot(request.body(body.into()).unwrap())
        .await
        .unwrap();
    let status = response.status();
    let bytes = axum::body::to_bytes(response.into_body(), 1 << 26).await.unwrap();
    (status, serde_json::from_slice(&bytes).unwrap_or(Value::Null))
}

#[tokio::test]
async fn a_foreign_host_name_is_refused_so_a_rebound_page_cannot_read_the_artwork() {
    let app = app(4);
    for uri in ["/api/puppet", "/api/texture/0/0.png", "/api/frames", "/"] {
        let (status, answer) = call_with(&app, "GET", uri, &[("host", "evil.example.com:8080")], "").await;
        assert_eq!(status, StatusCode::FORBIDDEN, "{uri}");
        assert!(answer["error"].as_str().unwrap().contains("evil.example.com"), "{answer}");
    }
    for host in ["127.0.0.1:8080", "localhost:8080"] {
        let (status, _) = call_with(&app, "GET", "/api/puppet", &[("host", host)], "").await;
        assert_eq!(status, StatusCode::OK, "{host}");
    }
}

#[tokio::test]
async fn changes_from_another_origin_are_refused_and_nothing_changes() {
    let app = app(4);
    let frames = |app: &Arc<App>| app.frames().len();
    let before = frames(&app);
    let puppet = &app.model().puppet;
    let png = crate::render::render_crisp(puppet, &puppet.rest_vertices(), 48, 40)
        .unwrap()
        .png_bytes(std::path::Path::new("x.png"))
        .unwrap();
    let foreign = [
        ("host", "127.0.0.1:8080"),
        ("origin", "http://evil.example.com"),
        ("content-type", "text/plain"),
    ];
    let (status, _) = call_with(&app, "POST", "/api/upload?name=x.png", &foreign, png).await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    assert_eq!(frames(&app), before, "the refused upload added no frame");
    let (status, _) = call_with(&app, "POST", "/api/session", &foreign, r#"{"frame": 0}"#).await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    let cross_site = [("host", "127.0.0.1:8080"), ("sec-fetch-site", "cross-site")];
    let (status, _) = call_with(&app, "POST", "/api/session", &cross_site, r#"{"frame": 0}"#).await;
    assert_eq!(status, StatusCode::FORBIDDEN);
    let own = [
        ("host", "127.0.0.1:8080"),
        ("origin", "http://127.0.0.1:8080"),
        ("content-type", "application/json"),
    ];
    let (status, answer) = call_with(&app, "POST", "/api/session", &own, r#"{"frame": 0}"#).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
}

#[tokio::test]
async fn suggestions_come_with_their_poses_words_and_trace_over_pictures() {
    let app = app(4);
    let (status, answer, _) = call(&app, "GET", "/api/suggestion/0.png", "").await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{answer}");
    assert!(answer["error"].as_str().unwrap().contains("nothing was suggested yet"));
    let started = std::time::Instant::now();
    let (status, suggested, _) = call(&app, "POST", "/api/suggest", r#"{"count": 2}"#).await;
    println!("suggest on the tiny model: {:.2} s", started.elapsed().as_secs_f64());
    assert_eq!(status, StatusCode::OK, "{suggested}");
    let list = suggested["suggestions"].as_array().unwrap();
    assert!(!list.is_empty() && list.len() <= 2, "{suggested}");
    assert!(suggested["candidates"].as_u64().unwrap() >= list.len() as u64);
    let puppet = &app.model().puppet;
    for (k, s) in list.iter().enumerate() {
        assert_eq!(points(&s["vertices"]).len(), puppet.vertex_count());
        assert!(s["misread_px"].as_f64().unwrap().is_finite() && s["distance_degrees"].as_f64().unwrap() >= 0.0);
        assert!(s["coverage_px"].as_f64().unwrap() >= 0.0);
        // The tiny character has no joints: in-betweens and latent directions only.
        let origin = s["origin"].as_str().unwrap();
        assert!(origin.contains("drawn frames"), "{origin}");
        assert!(s["origin_detail"]["kind"].is_string(), "{s}");
        let (status, _, png) = call(&app, "GET", s["picture"].as_str().unwrap(), "").await;
        assert_eq!(status, StatusCode::OK, "suggestion {k}");
        let picture = image::load_from_memory(&png).unwrap();
        // Scaled up to at least 384 px a side, by a whole factor: 8 × 48×40.
        assert_eq!((picture.width(), picture.height()), (384, 320));
    }
    let (status, _, _) = call(&app, "GET", &format!("/api/suggestion/{}.png", list.len()), "").await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    for (body, says) in [
        (r#"{"count": 0}"#, "count is 0"),
        (r#"{"count": 9}"#, "count is 9"),
        (r#"{"n": 2}"#, "unknown field"),
    ] {
        let (status, answer, _) = call(&app, "POST", "/api/suggest", body).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
        assert!(answer["error"].as_str().unwrap().contains(says), "{body}: {answer}");
    }
    // Without its model's folder, the editor has no frames for a drawing to join.
    let (_, next, _) = call(&app, "GET", "/api/next", "").await;
    assert_eq!(next["available"], json!(false), "{next}");
    let png = crate::render::render_crisp(puppet, &puppet.rest_vertices(), 48, 40)
        .unwrap()
        .png_bytes(std::path::Path::new("d.png"))
        .unwrap();
    let (status, answer) = call_with(&app, "POST", "/api/drawing?suggestion=0&name=d.png", &[], png).await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{answer}");
    assert!(
        answer["error"].as_str().unwrap().contains("not started on a model folder"),
        "{answer}"
    );
}

/// Trains a model of the tiny hinged character for 2 steps into `dir/model`, on four frames in
/// `dir/frames` (one held out), as `puppet train` writes it: what `puppet serve --model` loads.
fn model_on_disk(dir: &std::path::Path) -> std::path::PathBuf {
    let puppet = crate::test_util::hinged_puppet();
    crate::puppet::format::save(&puppet, &dir.join("puppet")).unwrap();
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for (k, shift) in [[0.0, 0.0], [2.0, 0.0], [0.0, -2.0], [-2.0, 1.0]].iter().enumerate() {
        let pose: Vec<[f32; 2]> = puppet.rest_vertices().iter().map(|v| [v[0] + shift[0], v[1] + shift[1]]).collect();
        crate::render::render_crisp(&puppet, &pose, 48, 40)
            .unwrap()
            .save_png(&frames.join(format!("f{k}.png")))
            .unwrap();
    }
    let text = "puppet = \"puppet\"\nframes = \"frames\"\noutput = \"model\"\ntest_fraction = 0.25\n\
                [model]\ninput_size = 32\nlatent = 16\n[train]\nsteps = 2\nbatch = 3\nsigma = [1.0, 1.0]\n";
    let path = dir.join("train.toml");
    std::fs::write(&path, text).unwrap();
    let config = crate::train::TrainConfig::parse(text, &path).unwrap();
    crate::train::train(&config, &crate::train::TrainOptions::default(), &crate::progress::Silent).unwrap();
    dir.join("model")
}

/// The status of `/api/next` once the continuation is no longer running (at most 2 minutes).
async fn continued(app: &Arc<App>) -> Value {
    let started = std::time::Instant::now();
    loop {
        let (_, next, _) = call(app, "GET", "/api/next", "").await;
        if next["training"]["state"] != json!("running") && next["training"]["state"] != json!("stopping") {
            return next;
        }
        assert!(started.elapsed().as_secs() < 120, "the continuation still runs: {next}");
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    }
}

/// The files of `dir` and their bytes, sorted.
fn contents(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    files.sort();
    files
}

#[tokio::test]
async fn a_drawing_joins_a_copy_of_the_frames_and_continues_the_model_into_a_new_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let model_dir = model_on_disk(t);
    let device = crate::backend::device();
    let model = crate::model::Model::load(&model_dir, &device).unwrap();
    let (frames, bad) = super::model_frames(&model_dir, &model).unwrap();
    assert!(bad.is_empty() && frames.len() == 4);
    let options = ServeOptions::new(FitOptions::one_pass()).with_model_folder(&model_dir);
    let app = Arc::new(App::new(model, frames, Vec::new(), options, &device).unwrap());
    let served = contents(&model_dir);
    let (frames_before, split_before) = (contents(&t.join("frames")), std::fs::read(model_dir.join("split.json")).unwrap());
    let next_dir = t.join("model-next");

    let (_, next, _) = call(&app, "GET", "/api/next", "").await;
    assert_eq!(
        (next["available"].clone(), next["folder"].clone()),
        (json!(true), Value::Null),
        "{next}"
    );
    assert_eq!(next["default_steps"], json!(1), "a third of the model's 2 steps, rounded up");
    let (status, answer, _) = call(&app, "POST", "/api/continue", "{}").await;
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{answer}");
    assert!(answer["error"].as_str().unwrap().contains("no drawing"), "{answer}");
    let (status, suggested, _) = call(&app, "POST", "/api/suggest", r#"{"count": 1}"#).await;
    assert_eq!(status, StatusCode::OK, "{suggested}");
    // The artist's drawing of suggestion 0: here, its crisp render.
    let pose = points(&suggested["suggestions"][0]["vertices"]);
    let puppet = &app.model().puppet;
    let drawing = crate::render::render_crisp(puppet, &pose, 48, 40)
        .unwrap()
        .png_bytes(std::path::Path::new("mine.png"))
        .unwrap();
    let small = crate::picture::Picture::filled(8, 8, [0.0; 4])
        .png_bytes(std::path::Path::new("s.png"))
        .unwrap();
    let send = |query: &str, bytes: Vec<u8>| {
        let (app, uri) = (app.clone(), format!("/api/drawing{query}"));
        async move { call_with(&app, "POST", &uri, &[("content-type", "image/png")], bytes).await }
    };
    for (query, bytes, status, says) in [
        (
            "?suggestion=0&name=small.png",
            small,
            StatusCode::BAD_REQUEST,
            "the puppet's frames are 48×40",
        ),
        (
            "?suggestion=0&name=notes.txt",
            b"a note".to_vec(),
            StatusCode::BAD_REQUEST,
            "notes.txt",
        ),
        (
            "?suggestion=3&name=mine.png",
            drawing.clone(),
            StatusCode::NOT_FOUND,
            "no suggestion 3",
        ),
        ("?name=mine.png&x=1", drawing.clone(), StatusCode::BAD_REQUEST, "query parameters"),
    ] {
        let (got, answer) = send(query, bytes).await;
        assert_eq!(got, status, "{query}: {answer}");
        assert!(answer["error"].as_str().unwrap().contains(says), "{query}: {answer}");
        assert!(!next_dir.exists(), "{query}: nothing is written");
    }
    // A folder of the user's where the drawings would go is left alone.
    std::fs::create_dir(&next_dir).unwrap();
    std::fs::write(next_dir.join("notes.txt"), "mine").unwrap();
    let (status, answer) = send("?suggestion=0&name=mine.png", drawing.clone()).await;
    assert_eq!(status, StatusCode::CONFLICT, "{answer}");
    assert!(
        answer["error"].as_str().unwrap().contains("model-next") && answer["error"].as_str().unwrap().contains("not made by puppet"),
        "{answer}"
    );
    assert_eq!(contents(&next_dir), [("notes.txt".to_string(), b"mine".to_vec())]);
    std::fs::remove_dir_all(&next_dir).unwrap();

    let (status, joined) = send("?suggestion=0&name=mine.png", drawing.clone()).await;
    assert_eq!(status, StatusCode::OK, "{joined}");
    assert_eq!(joined["drawing"], json!("drawn_next_1.png"));
    assert_eq!(
        (joined["frames"].clone(), joined["drawings"].clone()),
        (json!(5), json!(["drawn_next_1.png"]))
    );
    let copies = contents(&next_dir.join("frames"));
    let names: Vec<&str> = copies.iter().map(|(n, _)| n.as_str()).filter(|n| !n.starts_with('.')).collect();
    assert_eq!(names, ["drawn_next_1.png", "f0.png", "f1.png", "f2.png", "f3.png"]);
    for (name, bytes) in &frames_before {
        assert!(copies.contains(&(name.clone(), bytes.clone())), "{name} is copied as it is");
    }
    let (status, again) = send("?name=mine.png", drawing).await;
    assert_eq!(status, StatusCode::OK, "{again}");
    assert_eq!(again["drawing"], json!("drawn.png"));
    let command = again["command"].as_str().unwrap();
    assert!(
        command.starts_with("puppet train --from ") && command.ends_with(&format!("{} --steps 1", next_dir.join("model").display())),
        "{command}"
    );

    let (status, answer, _) = call(&app, "POST", "/api/continue", r#"{"steps": 0}"#).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{answer}");
    let (status, started, _) = call(&app, "POST", "/api/continue", r#"{"steps": 2}"#).await;
    assert_eq!(status, StatusCode::OK, "{started}");
    assert_eq!(started["training"]["steps"], json!(2), "{started}");
    let done = continued(&app).await;
    assert_eq!(done["training"]["state"], json!("done"), "{done}");
    let output = next_dir.join("model");
    assert_eq!(done["training"]["output"], json!(output));
    let split = |dir: &std::path::Path| -> Value { serde_json::from_slice(&std::fs::read(dir.join("split.json")).unwrap()).unwrap() };
    let (before, after) = (split(&model_dir), split(&output));
    assert_eq!(after["test"], before["test"], "the frames the model held out stay held out");
    let trained = after["train"].as_array().unwrap();
    assert!(
        trained.contains(&json!("drawn_next_1.png")) && trained.contains(&json!("drawn.png")),
        "{after}"
    );
    assert!(crate::model::Model::load(&output, &device).is_ok());
    // A second continuation writes beside the first, never over it.
    let (status, _, _) = call(&app, "POST", "/api/continue", r#"{"steps": 1}"#).await;
    assert_eq!(status, StatusCode::OK);
    let done = continued(&app).await;
    assert_eq!(
        (done["training"]["state"].clone(), done["training"]["output"].clone()),
        (json!("done"), json!(next_dir.join("model_2")))
    );
    // A continuation stopped from the page ends checkpointed, and `train --resume` on its
    // config finishes it; with none running, a stop is refused.
    let (status, _, _) = call(&app, "POST", "/api/continue", &format!(r#"{{"steps": {MAX_CONTINUE_STEPS}}}"#)).await;
    assert_eq!(status, StatusCode::OK);
    let (status, stopping, _) = call(&app, "POST", "/api/continue/stop", "").await;
    assert_eq!(status, StatusCode::OK, "{stopping}");
    let stopped = continued(&app).await;
    let output = next_dir.join("model_3");
    assert_eq!(stopped["training"]["state"], json!("stopped"), "{stopped}");
    assert!(stopped["training"]["step"].as_u64().unwrap() < MAX_CONTINUE_STEPS, "{stopped}");
    assert!(output.join("checkpoints").is_dir() && output.join("train.toml").is_file());
    let (status, answer, _) = call(&app, "POST", "/api/continue/stop", "").await;
    assert_eq!(status, StatusCode::CONFLICT, "{answer}");
    let mut config = crate::train::TrainConfig::load(&output.join("train.toml")).unwrap();
    config.train.steps = stopped["training"]["step"].as_u64().unwrap() + 1;
    let resumed = crate::train::TrainOptions {
        resume: true,
        ..crate::train::TrainOptions::default()
    };
    assert!(crate::train::train(&config, &resumed, &crate::progress::Silent).unwrap().finished);
    assert_eq!(contents(&model_dir), served, "the model being served is only read");
    assert_eq!(contents(&t.join("frames")), frames_before, "so is the folder of its frames");
    assert_eq!(std::fs::read(model_dir.join("split.json")).unwrap(), split_before);
}

/// Sends the motion `bytes` with `query`; the status and the answer.
async fn motion(app: &Arc<App>, query: &str, bytes: Vec<u8>) -> (StatusCode, Value) {
    call_with(app, "POST", &format!("/api/motion{query}"), &[], bytes).await
}

#[tokio::test]
async fn a_bvh_walk_plays_on_the_character_and_bad_motions_are_refused_by_name() {
    let app = app(4);
    let walk = std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/motion/walk.bvh")).unwrap();
    let started = std::time::Instant::now();
    let (status, answer, _) = call(&app, "POST", "/api/export", r#"{"format": "gif", "motion": true}"#).await;
    assert_eq!(status, StatusCode::NOT_FOUND, "{answer}");
    assert!(answer["error"].as_str().unwrap().contains("no motion"), "{answer}");
    let (status, played) = motion(&app, "?name=walk.bvh&view=side", walk.clone()).await;
    println!("walk.bvh on the tiny model: {:.2} s", started.elapsed().as_secs_f64());
    assert_eq!(status, StatusCode::OK, "{played}");
    assert_eq!(played["frames"], json!(36), "one cycle of 36 frames");
    assert!((played["frame_time"].as_f64().unwrap() - 1.0 / 30.0).abs() < 1e-6);
    let poses: Vec<Vec<[f32; 2]>> = played["poses"].as_array().unwrap().iter().map(points).collect();
    assert_eq!(poses.len(), 36);
    assert!(poses.iter().all(|p| p.len() == app.model().puppet.vertex_count()));
    let pairs = played["pairs"].as_array().unwrap();
    assert!(pairs.iter().any(|p| p["layer"] == json!("head")), "{played}");
    let moved = poses.iter().map(|p| farthest(p, &poses[0])).fold(0.0, f32::max);
    assert!(moved > 0.5, "the walk moves the character: {moved} px at most");
    // The motion played last downloads as an animation.
    let (status, _, gif) = call(&app, "POST", "/api/export", r#"{"format": "gif", "motion": true, "delay_ms": 33}"#).await;
    assert_eq!(status, StatusCode::OK);
    assert!(gif.starts_with(b"GIF89a"));
    let frames = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(gif)).unwrap();
    assert_eq!(image::AnimationDecoder::into_frames(frames).count(), 36, "one GIF frame per pose");
    let (status, answer, _) = call(&app, "POST", "/api/export", r#"{"format": "gif", "motion": true, "session": "x"}"#).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{answer}");
    let (status, slow) = motion(&app, "?name=walk.bvh&view=side&fps=10&rigid=true&in_place=true", walk.clone()).await;
    assert_eq!(status, StatusCode::OK, "{slow}");
    assert_eq!(slow["frames"], json!(12), "1.17 s at 10 frames a second");

    let png = crate::picture::Picture::filled(4, 4, [0.0; 4])
        .png_bytes(std::path::Path::new("x.png"))
        .unwrap();
    let no_match = b"HIERARCHY\nROOT Foo\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Bar\n{\nOFFSET 0 1 0\n\
                     CHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0 0 0 0\n"
        .to_vec();
    let mut long = b"HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nJOINT Head\n{\nOFFSET 0 1 0\n\
                     CHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1000\nFrame Time: 0.04\n"
        .to_vec();
    long.extend(b"0 0 0 0 0 0\n".repeat(1000));
    for (query, bytes, status, says) in [
        ("?name=walk.png", png, StatusCode::BAD_REQUEST, "walk.png: a PNG image"),
        (
            "?name=long.bvh",
            long,
            StatusCode::BAD_REQUEST,
            "long.bvh has 1000 frames at 25 frames a second; the editor plays up to 900",
        ),
        (
            "?name=notes.txt",
            b"dear diary".to_vec(),
            StatusCode::BAD_REQUEST,
            "notes.txt: not a BVH file",
        ),
        ("?name=cut.bvh", walk[..400].to_vec(), StatusCode::BAD_REQUEST, "cut.bvh"),
        ("?name=odd.bvh", no_match.clone(), StatusCode::UNPROCESSABLE_ENTITY, "Foo"),
        ("?name=walk.bvh&view=top", walk.clone(), StatusCode::BAD_REQUEST, "front or side"),
        ("?name=walk.bvh&fps=0", walk.clone(), StatusCode::BAD_REQUEST, "fps is 0"),
        ("?name=walk.bvh&fps=fast", walk.clone(), StatusCode::BAD_REQUEST, "query parameters"),
        ("?name=walk.bvh&outfit=3", walk.clone(), StatusCode::NOT_FOUND, "no outfit 3"),
        (
            "?name=huge.bvh",
            vec![b' '; super::motion::MAX_MOTION_BYTES + 1],
            StatusCode::PAYLOAD_TOO_LARGE,
            "cannot be read",
        ),
    ] {
        let (got, answer) = motion(&app, query, bytes).await;
        let message = answer["error"].as_str().unwrap_or_default();
        assert!(got == status && message.contains(says), "{query}: {got} {message:?}");
    }
    let (_, answer) = motion(&app, "?name=odd.bvh", no_match).await;
    let message = answer["error"].as_str().unwrap();
    assert!(
        message.contains("Bar") && message.contains("torso"),
        "names the joints and the layers: {message}"
    );
}
