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
/// [`crate::Error::Mismatch`] if the vertex count differs from the puppet's,
/// [`crate::Error::Geometry`] if a coordinate is not finite, the size is empty or a layer is
/// malformed, [`crate::Error::Setting`] if `sigma` is negative.
pub fn render_pose(puppet: &Puppet, vertices: &[[f32; 2]], width: u32, height: u32, sigma: f32, background: Background) -> Result<Picture> {
    let raster = SoftRasterizer::new(puppet)?;
    let flat: Vec<f32> = vertices.iter().flatten().copied().collect();
    let params = Params {
        sigma,
        background,
        ..Params::default()
    };
    let frames = raster.forward(&flat, 1, width as usize, height as usize, &params)?;
    Ok(straight_picture(&frames.image, width, height))
}

/// One rendered image (premultiplied RGBA, `[H, W, 4]`, as the rasterizer writes it) as a
/// straight-alpha picture.
pub fn straight_picture(premultiplied: &[f32], width: u32, height: u32) -> Picture {
    let pixels = premultiplied
        .chunks_exact(4)
        .map(|p| match p[3] {
            a if a > 0.0 => [(p[0] / a).min(1.0), (p[1] / a).min(1.0), (p[2] / a).min(1.0), a.min(1.0)],
            _ => [0.0; 4],
        })
        .collect();
    Picture { width, height, pixels }
}

/// The crisp render (σ = 0, transparent background) every preview and export uses.
///
/// # Errors
/// As [`render_pose`].
pub fn render_crisp(puppet: &Puppet, vertices: &[[f32; 2]], width: u32, height: u32) -> Result<Picture> {
    render_pose(puppet, vertices, width, height, 0.0, Background::Transparent)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::layered_puppet;

    /// The artwork: every layer texture composited "over", back to front (straight alpha).
    fn artwork(puppet: &Puppet) -> Picture {
        let mut out = Picture::filled(puppet.width, puppet.height, [0.0; 4]);
        for layer in &puppet.layers {
            for (o, s) in out.pixels.iter_mut().zip(&layer.texture.pixels) {
                *o = crate::puppet::artwork::over(*s, *o);
            }
        }
        out
    }

    /// (masked RMSE over RGBA where either alpha > 0.5, IoU of alpha > 0.5) — DESIGN.md metrics.
    fn compare(a: &Picture, b: &Picture) -> (f64, f64) {
        let (mut se, mut n, mut inter, mut union) = (0.0, 0usize, 0usize, 0usize);
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            let (ia, ib) = (p[3] > 0.5, q[3] > 0.5);
            if ia || ib {
                se += (0..4).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>();
                n += 4;
                union += 1;
                inter += (ia && ib) as usize;
            }
        }
        ((se / n as f64).sqrt(), inter as f64 / union as f64)
    }

    #[test]
    fn rest_pose_crisp_render_reproduces_the_artwork() {
        let puppet = layered_puppet();
        let rest = puppet.rest_vertices();
        let render = render_crisp(&puppet, &rest, puppet.width, puppet.height).unwrap();
        let (rmse, iou) = compare(&render, &artwork(&puppet));
        println!("rest-pose crisp render vs artwork: masked RMSE {rmse:.4}, IoU {iou:.4}");
        // Only the head differs: a 12-gon mesh inside a drawn circle.
        assert!(rmse < 0.08 && iou > 0.99, "RMSE {rmse}, IoU {iou}");
        // Without the head the meshes match the drawn shapes exactly.
        let mut body = puppet.clone();
        body.layers.remove(2);
        let render = render_crisp(&body, &body.rest_vertices(), body.width, body.height).unwrap();
        let (rmse, iou) = compare(&render, &artwork(&body));
        println!("without the disc layer: masked RMSE {rmse:.2e}, IoU {iou:.4}");
        assert!(rmse < 1e-6 && iou == 1.0, "RMSE {rmse}, IoU {iou}");
    }

    #[test]
    fn soft_render_is_opaque_on_a_colour_background_and_errors_name_the_problem() {
        let puppet = layered_puppet();
        let pic = render_pose(&puppet, &puppet.rest_vertices(), 30, 20, 0.5, Background::Colour([1.0, 1.0, 1.0])).unwrap();
        assert!(pic.pixels.iter().all(|p| (p[3] - 1.0).abs() < 1e-6));
        let err = render_pose(&puppet, &puppet.rest_vertices()[1..], 30, 20, 0.5, Background::Transparent).unwrap_err();
        assert!(err.to_string().contains("vertices"), "{err}");
    }
}
