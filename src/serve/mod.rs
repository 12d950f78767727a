//! The web editor (issue 18): a local HTTP server with one page that draws the puppet from its
//! mesh and textures and poses it by drag pins — the latent optimisation of neural-puppet.md
//! §4.2 (eq. 7–9), one [`crate::edit::pose::PoseEditor`] per page.
//!
//! Routes (JSON unless a picture; every refusal is a 4xx with `{"error": "…"}`):
//!
//! ```text
//! GET  /                      the page (part of the binary)
//! GET  /api/puppet            width, height, vertex_count, layers back to front:
//!                             {name, kind, offset, triangles, uvs, rest, texture}
//! GET  /api/texture/<i>.png   layer i's texture (straight-alpha RGBA)
//! GET  /api/frames            {frames: [{index, name, held_out, picture}]}
//! GET  /api/frame/<i>.png     frame i
//! POST /api/session           {frame: i} → {session, vertices}: frame i fitted
//! POST /api/drag              {session, pins: [{from: [x, y], to: [x, y]}], alpha_reg?, alpha_joints?}
//!                             → {vertices, pin_error}
//! ```
//!
//! Points and vertices are frame pixels (origin top-left, y down); `vertices` use the global
//! numbering (layer `offset` + the layer's vertex). A drag whose pins have the same `from`
//! points as the session's last continues from the latent that drag reached, so a page sends
//! the whole pin list on every mouse move.

pub mod api;
pub mod state;

pub use api::{router, ApiError};
pub use state::{folder_frames, model_frames, App, EditorFrame, ServeOptions};

/// Serves the editor of `app` on `listener` until the process ends.
///
/// # Errors
/// The listener's I/O error, if accepting connections fails for good.
pub async fn serve(listener: tokio::net::TcpListener, app: std::sync::Arc<App>) -> std::io::Result<()> {
    axum::serve(listener, router(app)).await
}
