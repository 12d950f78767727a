//! One pose to one [`Picture`]: the entry point for previews, exports and `puppet render`
//! (neural-puppet.md §3.2's R(V, F, I^uv) at a chosen σ; σ = 0 is crisp).

use super::soft_raster::{Background, Params, SoftRasterizer};
use crate::error::Result;
use crate::picture::Picture;
use crate::puppet::Puppet;

/// Renders `puppet` with its vertices at `vertices` (global numbering, output pixels) into a
/// `width × height` straight-alpha picture, with SoftRas sharpness `sigma` (px²; 0 = crisp).
///
/// # Errors
/// [`crate::Error::Invalid`] if the vertex count differs from the puppet's, a coordinate is not
/// finite, the size is empty, `sigma` is negative, or a layer is malformed.
pub fn render_pose(
    puppet: &Puppet,
    vertices: &[[f32; 2]],
    width: u32,
    height: u32,
    sigma: f32,
    background: Background,
) -> Result<Picture> {
    let raster = SoftRasterizer::new(puppet)?;
    let flat: Vec<f32> = vertices.iter().flatten().copied().collect();
    let params = Params { sigma, background, ..Params::default() };
    let frames = raster.forward(&flat, 1, width as usize, height as usize, &params)?;
    let pixels = frames
        .image
        .chunks_exact(4)
        .map(|p| match p[3] {
            a if a > 0.0 => [(p[0] / a).min(1.0), (p[1] / a).min(1.0), (p[2] / a).min(1.0), a.min(1.0)],
            _ => [0.0; 4],
        })
        .collect();
    Ok(Picture { width, height, pixels })
}

/// The crisp render (σ = 0, transparent background) every preview and export uses.
///
/// # Errors
/// As [`render_pose`].
pub fn render_crisp(puppet: &Puppet, vertices: &[[f32; 2]], width: u32, height: u32) -> Result<Picture> {
    render_pose(puppet, vertices, width, height, 0.0, Background::Transparent)
}
