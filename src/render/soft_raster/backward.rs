//! Backward pass: the exact vector-Jacobian product of [`SoftRasterizer::forward`] w.r.t. the
//! vertex positions (neural-puppet.md §3.2: gradients of eq. 1, 10, 11 reach `V_pred` through
//! the renderer). Two routes per pixel: through the coverages `D_j` (edges; the derivative of
//! `d_j²`) and through the barycentric texture lookup of each layer's colour face (interiors).
//! Per-pixel quantities are recomputed with the forward's own [`Pixel::shade`] instead of being
//! stored: that keeps memory at O(B·V) and forward/backward identical by construction.

use rayon::prelude::*;

use super::bins::TILE;
use super::forward::{product_without, Ctx, Pixel};
use super::geometry::{bary_vjp, dist2_vjp};
use super::texture::sample_vjp;
use super::{real, Params, Real, SoftRasterizer};
use crate::error::{Error, Result};

impl SoftRasterizer {
    /// `dL/dvertices` (`[B, V, 2]`) given `dL/dimage` (`[B, H, W, 4]`, premultiplied RGBA as
    /// [`SoftRasterizer::forward`] returns it) and/or `dL/dmask` (`[B, H, W]`), for the same
    /// `vertices`, sizes and `params` as the forward call. With σ = 0 only the texture route
    /// remains (crisp coverage is piecewise constant).
    ///
    /// # Errors
    /// [`Error::Invalid`] if sizes disagree or inputs are not finite (as for `forward`).
    #[allow(clippy::too_many_arguments)] // the forward's arguments plus the two output gradients
    pub fn backward<T: Real>(
        &self,
        vertices: &[T],
        batch: usize,
        width: usize,
        height: usize,
        params: &Params,
        d_image: Option<&[T]>,
        d_mask: Option<&[T]>,
    ) -> Result<Vec<T>> {
        self.vjp(vertices, batch, width, height, params, d_image, d_mask, Routes { coverage: true, texture: true })
    }

    /// [`SoftRasterizer::backward`] with a choice of routes (tests switch one off to show that the
    /// gradient checks detect a missing term).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn vjp<T: Real>(
        &self,
        vertices: &[T],
        batch: usize,
        width: usize,
        height: usize,
        params: &Params,
        d_image: Option<&[T]>,
        d_mask: Option<&[T]>,
        routes: Routes,
    ) -> Result<Vec<T>> {
        params.validate()?;
        self.validate_input(vertices, batch, width, height)?;
        let npx = batch * width * height;
        if d_image.is_some_and(|g| g.len() != npx * 4) || d_mask.is_some_and(|g| g.len() != npx) {
            return Err(Error::Invalid(format!(
                "render backward: gradient sizes {:?} (image) and {:?} (mask), expected {} and {npx}",
                d_image.map(<[T]>::len),
                d_mask.map(<[T]>::len),
                npx * 4
            )));
        }
        let pose = 2 * self.vertex_count;
        let mut grads = vec![T::zero(); batch * pose];
        if d_image.is_none() && d_mask.is_none() {
            return Ok(grads);
        }
        let ctxs: Vec<Ctx<T>> = (0..batch)
            .into_par_iter()
            .map(|b| Ctx::new(self, &vertices[b * pose..(b + 1) * pose], params, width, height))
            .collect();
        let bands = height.div_ceil(TILE);
        let partial: Vec<(usize, Vec<T>)> = (0..batch * bands)
            .into_par_iter()
            .map(|task| {
                let (b, band) = (task / bands, task % bands);
                let ctx = &ctxs[b];
                let gi = d_image.map(|g| &g[b * width * height * 4..(b + 1) * width * height * 4]);
                let gm = d_mask.map(|g| &g[b * width * height..(b + 1) * width * height]);
                let mut g = vec![T::zero(); pose];
                band_vjp(ctx, band, width, height, gi, gm, routes, &mut g);
                (b, g)
            })
            .collect();
        for (b, g) in partial {
            for (acc, v) in grads[b * pose..(b + 1) * pose].iter_mut().zip(g) {
                *acc = *acc + v;
            }
        }
        Ok(grads)
    }
}

/// Which terms of the gradient to include.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Routes {
    /// Through the face coverages D_j (edges).
    pub coverage: bool,
    /// Through the barycentric texture lookup (interiors).
    pub texture: bool,
}

/// Accumulates the vertex gradient of one band of `TILE` rows into `g` (`V × 2`).
#[allow(clippy::too_many_arguments)]
fn band_vjp<T: Real>(
    ctx: &Ctx<T>,
    band: usize,
    width: usize,
    height: usize,
    gi: Option<&[T]>,
    gm: Option<&[T]>,
    routes: Routes,
    g: &mut [T],
) {
    let (zero, one) = (T::zero(), T::one());
    let half = real::<T>(0.5);
    let soft = ctx.sigma > zero && routes.coverage;
    let mut px = Pixel::new();
    let mut ga: Vec<T> = Vec::new();
    for tx in 0..width.div_ceil(TILE) {
        let faces = ctx.bins.tile(tx, band);
        if faces.is_empty() {
            continue;
        }
        for y in band * TILE..((band + 1) * TILE).min(height) {
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                let i = y * width + x;
                let gout = gi.map_or([zero; 4], |g| [g[4 * i], g[4 * i + 1], g[4 * i + 2], g[4 * i + 3]]);
                let gmask = gm.map_or(zero, |g| g[i]);
                if gout.iter().all(|&v| v == zero) && gmask == zero {
                    continue;
                }
                let p = [real::<T>(x as f64) + half, real::<T>(y as f64) + half];
                px.shade(ctx, p, faces);
                if px.near.is_empty() {
                    continue;
                }
                // Compositing, front to back: out = Σ_l T_l X_l + …, X_l = A_l S_l, and α_l = A_l s_a
                // also scales everything behind l: ∂out/∂α_l = −T_l · behind_l.
                ga.clear();
                ga.resize(px.touched.len(), zero);
                let mut trans = one;
                for (slot, la) in px.touched.iter().enumerate().rev() {
                    let gx = gout.map(|c| trans * c);
                    let g_alpha = -trans * (0..4).fold(zero, |s, c| s + gout[c] * la.behind[c]);
                    ga[slot] = (0..4).fold(zero, |s, c| s + gx[c] * la.s[c]) + g_alpha * la.s[3];
                    let mut gs = gx.map(|c| la.a * c);
                    gs[3] = gs[3] + la.a * g_alpha;
                    // Texture lookup → UV → barycentric weights → the colour face's corners.
                    let tex = &ctx.raster.textures[la.layer as usize];
                    let guv = sample_vjp(tex, la.uv, gs);
                    if routes.texture && (guv[0] != zero || guv[1] != zero) {
                        let face = &ctx.raster.faces[la.best as usize];
                        let gw = face.uvs.map(|uv| guv[0] * real::<T>(uv[0] as f64) + guv[1] * real::<T>(uv[1] as f64));
                        let h = la.best_hit.expect("a touched layer has a face");
                        let mut gc = [[zero; 2]; 3];
                        bary_vjp(gw, p, ctx.corners(la.best as usize), &h, &mut gc);
                        scatter(g, face.vertices, gc);
                    }
                    trans = trans * (one - la.a * la.s[3]);
                }
                if !soft {
                    continue;
                }
                // Coverage: ∂A_l/∂D_j = Π_{k∈l, k≠j}(1 − D_k), ∂M/∂D_j = Π_{k≠j}(1 − D_k);
                // D = sigmoid(z), z = ±d²/σ.
                for n in &px.near {
                    let la = &px.touched[n.slot as usize];
                    let om = one - n.d;
                    let gd = ga[n.slot as usize] * product_without(la.prod, la.zeros, om)
                        + gmask * product_without(px.prod, px.zeros, om);
                    let gz = gd * n.d * om;
                    if gz == zero {
                        continue;
                    }
                    let gd2 = if n.hit.inside { gz / ctx.sigma } else { -gz / ctx.sigma };
                    let mut gc = [[zero; 2]; 3];
                    dist2_vjp(gd2, &n.hit, &mut gc);
                    scatter(g, ctx.raster.faces[n.face as usize].vertices, gc);
                }
            }
        }
    }
}

#[inline]
fn scatter<T: Real>(g: &mut [T], vertices: [u32; 3], gc: [[T; 2]; 3]) {
    for k in 0..3 {
        let v = vertices[k] as usize;
        g[2 * v] = g[2 * v] + gc[k][0];
        g[2 * v + 1] = g[2 * v + 1] + gc[k][1];
    }
}
