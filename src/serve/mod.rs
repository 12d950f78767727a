//! The web editor (issue 18): a local HTTP server with one page that draws the puppet from its
//! mesh and textures and poses it by drag pins — the latent optimisation of neural-puppet.md
//! §4.2 (eq. 7–9), one [`crate::edit::pose::PoseEditor`] per page — by sliders along the
//! training frames' principal latent directions, and plays timed in-betweens (§4.1); it swaps
//! outfits on the same body (accessory-rigs.md), shows what the appearance stage (§3.3) draws
//! of each pose when the model has one, and downloads what it shows. Issue 57 adds "what to
//! draw next" ([`next`]: suggested poses to trace over, the artist's drawing joining a copy of
//! the model's frames, the model continued on them in the background) and motions played on
//! the character ([`motion`]: a BVH file retargeted to the layers).
//!
//! Routes (JSON unless a picture or a download; every refusal is a 4xx with `{"error": "…"}`):
//!
//! ```text
//! GET  /                          the page (part of the binary)
//! GET  /api/puppet                width, height, latent (its length), sliders (their count),
//!                                 easings, max_inbetweens, appearance (whether the editor can
//!                                 redraw with the appearance stage), outfits: [{name, vertex_count,
//!                                 layers back to front: [{name, kind, offset, triangles, uvs,
//!                                 rest, texture, rig_pins}]}] — outfit 0 is the model's own
//! GET  /api/texture/<k>/<i>.png   outfit k's layer i texture (straight-alpha RGBA)
//! GET  /api/frames                {frames: [{index, name, held_out, picture}]}
//! GET  /api/frame/<i>.png         frame i
//! POST /api/upload?name=<file>    the body an image of the puppet's size → {index, picture}
//! POST /api/session               {frame, outfit?} → {session, fitted, fitted_latent, vertices, latent,
//!                                 start?: {kept: prior|network, network_l2, prior_l2} for an upload}
//! POST /api/drag                  {session, pins: [{from: [x, y], to: [x, y]}], alpha_reg?,
//!                                 alpha_joints?, steps?} → {vertices, pin_error, latent}
//! POST /api/latent                {session, latent, sliders?} → {vertices, latent}
//! POST /api/outfit                {session, outfit} → {fitted, fitted_latent, vertices, latent}
//! POST /api/inbetween             {from, to, count?, easing?, spacing?, outfit?} → {t, poses}
//! POST /api/export                {format: png|gif|apng|sheet|spine, session | inbetween | motion,
//!                                 hidden?, background?, delay_ms?, render?, appearance?}
//!                                 → the file (several: a ZIP)
//! POST /api/appearance            {session | inbetween | motion, hidden?} → one PNG: each pose rendered
//!                                 and redrawn by the appearance stage, side by side
//! POST /api/suggest               {count?} → {suggestions: [{index, picture, vertices, misread_px,
//!                                 distance_degrees, origin (words), origin_detail}], candidates,
//!                                 seconds}: the poses worth drawing next, best first
//! GET  /api/suggestion/<k>.png    suggestion k's trace-over picture (the latest request's)
//! POST /api/drawing?suggestion=<k>&name=<file>
//!                                 the body the artist's drawing (an image of the puppet's size)
//!                                 → the status below + {drawing}: it joins a copy of the model's
//!                                 frames in <model>-next/frames/
//! GET  /api/next                  {available, unavailable, folder, frames, drawings,
//!                                 default_steps, command, training: {state, step, steps,
//!                                 message, warnings, output, error, seconds}}
//! POST /api/continue              {steps?} → the status: `puppet train --from` on that folder in
//!                                 the background, into <model>-next/model (model_2, … after)
//! POST /api/continue/stop         → the status: the continuation ends after its step,
//!                                 checkpointed (`puppet train <output>/train.toml --resume`
//!                                 finishes it)
//! POST /api/motion?name=<file>&view=front|side&rigid=&in_place=&fps=&outfit=
//!                                 the body a BVH file → {name, frames, frame_time, joints,
//!                                 pairs: [{joint, layer}], warnings, poses, seconds}
//! ```
//!
//! Points and vertices are frame pixels (origin top-left, y down) in the global numbering of
//! the outfit drawn (layer `offset` + the layer's vertex). A drag whose pins have the same `from`
//! points as the session's last continues from the latent that drag reached, so a page sends
//! the whole pin list on every mouse move; new points are bound on the fit and the drag goes on
//! from the current latent. A page keeps the latents it was sent to undo and redo by
//! `/api/latent`; `sliders` there are offsets along the directions in standard deviations of the
//! training frames' latents.

pub mod api;
pub mod error;
pub mod export;
pub mod guard;
pub mod motion;
pub mod next;
mod session;
pub mod state;
#[cfg(test)]
mod tests;

pub use api::router;
pub use error::ApiError;
pub use guard::HostGuard;
pub use state::{folder_frames, model_frames, model_outfits, App, EditorFrame, EditorPose, Outfit, ServeOptions, UploadPrior};

/// Serves the editor of `app` on `listener` until the process ends, to the names of the address
/// it listens on ([`HostGuard`]).
///
/// # Errors
/// The listener's I/O error, if accepting connections fails for good.
pub async fn serve(listener: tokio::net::TcpListener, app: std::sync::Arc<App>) -> std::io::Result<()> {
    let guard = HostGuard::new(listener.local_addr()?);
    axum::serve(listener, router(app, guard)).await
}
