//! Drawing: previews now; the differentiable soft rasterizer arrives with its issue.

pub mod preview;
