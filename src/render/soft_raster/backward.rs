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

#[cfg(test)]
mod tests {
    use super::super::Background;
    use super::*;
    use crate::test_util::{jittered, layered_puppet, Rng};

    const W: usize = 48;
    const H: usize = 40;

    /// `<g_image, image> + <g_mask, mask>` for one pose.
    fn loss(raster: &SoftRasterizer, v: &[f64], p: &Params, gi: &[f64], gm: &[f64]) -> f64 {
        let f = raster.forward(v, 1, W, H, p).unwrap();
        f.image.iter().zip(gi).map(|(a, b)| a * b).sum::<f64>() + f.mask.iter().zip(gm).map(|(a, b)| a * b).sum::<f64>()
    }

    /// Largest violation of |vjp − fd| ≤ tol·(1 + |fd|) over all coordinates, as a multiple of
    /// the allowance (≤ 1 passes). h = 1e-6: truncation ~h²·|L'''| (L''' ≲ 1e3 at σ = 0.3)
    /// and rounding ~1e-16·|L|/h ≈ 1e-9 are both far below tol = 1e-5.
    fn fd_violation(raster: &SoftRasterizer, v: &[f64], p: &Params, gi: &[f64], gm: &[f64], vjp: &[f64]) -> (f64, f64) {
        let (h, tol) = (1e-6, 1e-5);
        let mut worst: (f64, f64) = (0.0, 0.0);
        for i in 0..v.len() {
            let (mut vp, mut vm) = (v.to_vec(), v.to_vec());
            vp[i] += h;
            vm[i] -= h;
            let fd = (loss(raster, &vp, p, gi, gm) - loss(raster, &vm, p, gi, gm)) / (2.0 * h);
            worst.0 = worst.0.max((vjp[i] - fd).abs() / (tol * (1.0 + fd.abs())));
            worst.1 = worst.1.max(fd.abs());
        }
        worst
    }

    /// Pixel weights: random, but only where `keep(mask)` holds.
    fn weights(mask: &[f64], seed: u64, keep: impl Fn(f64) -> bool) -> (Vec<f64>, Vec<f64>) {
        let mut rng = Rng::new(seed);
        let gi = (0..mask.len() * 4).map(|i| if keep(mask[i / 4]) { rng.uniform(-1.0, 1.0) } else { 0.0 }).collect();
        let gm = mask.iter().map(|&m| if keep(m) { rng.uniform(-1.0, 1.0) } else { 0.0 }).collect();
        (gi, gm)
    }

    const ALL: Routes = Routes { coverage: true, texture: true };
    const NO_COVERAGE: Routes = Routes { coverage: false, texture: true };
    const NO_TEXTURE: Routes = Routes { coverage: true, texture: false };

    fn vjp(raster: &SoftRasterizer, v: &[f64], p: &Params, gi: &[f64], gm: &[f64], routes: Routes) -> Vec<f64> {
        raster.vjp(v, 1, W, H, p, Some(gi), Some(gm), routes).unwrap()
    }

    /// The fixture's four layers overlap (arms behind and in front of the torso, head over it);
    /// its textures are striped, so interior pixels carry a texture gradient.
    /// The cutoff is 1e-12 here so that a coordinate step of h never crosses the cutoff's jump
    /// (1e-4 at the default, which a central difference would turn into an error of 1e-4/2h);
    /// the default cutoff is checked separately on seeds that avoid it.
    #[test]
    fn vertex_gradient_matches_central_differences_at_edges_and_interiors_for_several_sigma() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        for (k, sigma) in [0.3f32, 1.0, 3.0].into_iter().enumerate() {
            let v = jittered(&puppet.rest_vertices(), 10 + k as u64, 0.4);
            let p = Params { sigma, cutoff: 1e-12, background: Background::Colour([0.9, 0.8, 0.7]) };
            let mask = raster.forward(&v, 1, W, H, &p).unwrap().mask;
            // Edge pixels: partial silhouette coverage. Interior pixels: covered to within 1e-3.
            let edge = weights(&mask, 1, |m| m > 0.02 && m < 0.98);
            let interior = weights(&mask, 2, |m| m > 0.999);
            for (name, (gi, gm), dropped, what) in
                [("edge", &edge, NO_COVERAGE, "coverage"), ("interior", &interior, NO_TEXTURE, "texture")]
            {
                let full = vjp(&raster, &v, &p, gi, gm, ALL);
                let (bad, scale) = fd_violation(&raster, &v, &p, gi, gm, &full);
                println!("σ {sigma} {name} pixels: max |vjp − fd| / allowance = {bad:.1e} (max |fd| {scale:.3})");
                assert!(bad <= 1.0, "σ {sigma} {name}: gradient off the central differences ({bad} × allowance)");
                // Without the term that dominates these pixels the same check fails by far.
                let partial = vjp(&raster, &v, &p, gi, gm, dropped);
                let (bad, _) = fd_violation(&raster, &v, &p, gi, gm, &partial);
                println!("σ {sigma} {name} pixels without the {what} term: {bad:.0} × allowance");
                assert!(bad > 100.0, "σ {sigma} {name}: dropping the {what} term went unnoticed ({bad})");
            }
        }
    }

    #[test]
    fn default_cutoff_gradient_is_exact_for_the_truncated_coverage() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let v = jittered(&puppet.rest_vertices(), 21, 0.4);
        let p = Params { sigma: 0.5, ..Params::default() };
        let mask = raster.forward(&v, 1, W, H, &p).unwrap().mask;
        let (gi, gm) = weights(&mask, 3, |_| true);
        let full = vjp(&raster, &v, &p, &gi, &gm, ALL);
        let (bad, _) = fd_violation(&raster, &v, &p, &gi, &gm, &full);
        assert!(bad <= 1.0, "{bad} × allowance");
    }

    #[test]
    fn crisp_gradient_has_only_the_texture_route_and_off_image_faces_get_none() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let mut v = jittered(&puppet.rest_vertices(), 5, 0.4);
        // Move the head (layer 2) far off the image.
        let off = puppet.vertex_offsets();
        v[2 * off[2]..2 * off[3]].iter_mut().for_each(|x| *x -= 500.0);
        let p = Params::crisp(Background::Transparent);
        let mask = raster.forward(&v, 1, W, H, &p).unwrap().mask;
        let (gi, gm) = weights(&mask, 4, |m| m > 0.5);
        let full = vjp(&raster, &v, &p, &gi, &gm, ALL);
        assert!(full[2 * off[2]..2 * off[3]].iter().all(|&g| g == 0.0), "off-image head got a gradient");
        assert!(full.iter().any(|&g| g != 0.0), "crisp texture route is empty");
        // Central differences see the interiors (no pixel changes coverage for a 1e-6 step).
        let (bad, _) = fd_violation(&raster, &v, &p, &gi, &gm, &full);
        assert!(bad <= 1.0, "{bad} × allowance");
    }

    #[test]
    fn batched_backward_equals_per_pose_backward_and_f32_follows_f64() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let (a, b) = (jittered(&puppet.rest_vertices(), 30, 0.4), jittered(&puppet.rest_vertices(), 31, 0.4));
        let p = Params::default();
        let mut rng = Rng::new(9);
        let gi: Vec<f64> = (0..2 * W * H * 4).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let both: Vec<f64> = a.iter().chain(&b).copied().collect();
        let g = raster.backward(&both, 2, W, H, &p, Some(&gi), None).unwrap();
        let ga = raster.backward(&a, 1, W, H, &p, Some(&gi[..W * H * 4]), None).unwrap();
        let gb = raster.backward(&b, 1, W, H, &p, Some(&gi[W * H * 4..]), None).unwrap();
        let n = a.len();
        assert!(g[..n].iter().zip(&ga).chain(g[n..].iter().zip(&gb)).all(|(x, y)| (x - y).abs() < 1e-9));
        let a32: Vec<f32> = a.iter().map(|&x| x as f32).collect();
        let gi32: Vec<f32> = gi[..W * H * 4].iter().map(|&x| x as f32).collect();
        let g32 = raster.backward(&a32, 1, W, H, &p, Some(&gi32), None).unwrap();
        let scale = ga.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let err = g32.iter().zip(&ga).fold(0.0f64, |m, (x, y)| m.max((*x as f64 - y).abs()));
        assert!(err < 1e-3 * scale, "f32 gradient off by {err} (scale {scale})");
    }
}
