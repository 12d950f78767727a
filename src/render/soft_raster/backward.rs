//! Backward pass: the exact vector-Jacobian product of [`SoftRasterizer::forward`] w.r.t. the
//! vertex positions (neural-puppet.md §3.2: gradients of eq. 1, 10, 11 reach `V_pred` through
//! the renderer). Two routes per pixel: through each layer's coverage `A_l` (the derivative of
//! `d_l²`, the squared distance to the nearest outline edge) and through the barycentric texture
//! lookup of each layer's colour face (interiors).
//! The forward pass's [`Saved`] records name, per pixel and visited layer, the colour face and
//! the outline edge; here each is evaluated once more with the forward's own geometry code, so
//! both passes see the same function without a second search through the tile's faces.

use rayon::prelude::*;

use super::bins::TILE;
use super::forward::{product_without, BandRecords, Ctx, Saved, NO_EDGE};
use super::geometry::{bary_vjp, inside_hit, Hit, Outline};
use super::texture::Lookup;
use super::{real, Params, Real, SoftRasterizer};
use crate::error::{Error, Result};

impl SoftRasterizer {
    /// `dL/dvertices` (`[B, V, 2]`) given `dL/dimage` (`[B, H, W, 4]`, premultiplied RGBA as
    /// [`SoftRasterizer::forward`] returns it) and/or `dL/dmask` (`[B, H, W]`), for the same
    /// `vertices`, sizes and `params` as the forward call. With σ = 0 only the texture route
    /// remains (crisp coverage is piecewise constant). Runs the forward pass again; after
    /// [`SoftRasterizer::forward_saving`], [`SoftRasterizer::backward_saved`] does not.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if sizes disagree, [`Error::Geometry`] if inputs are not finite (as for `forward`).
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
        let (_, saved) = self.forward_saving(vertices, batch, width, height, params)?;
        self.backward_saved(&saved, d_image, d_mask)
    }

    /// [`SoftRasterizer::backward`] from the records of a [`SoftRasterizer::forward_saving`] call
    /// of this rasterizer (poses, sizes and parameters are those of that call).
    ///
    /// # Errors
    /// [`Error::Mismatch`] if the gradient sizes disagree with the forward call, or `saved` comes
    /// from a rasterizer of another puppet.
    pub fn backward_saved<T: Real>(&self, saved: &Saved<T>, d_image: Option<&[T]>, d_mask: Option<&[T]>) -> Result<Vec<T>> {
        self.vjp(saved, d_image, d_mask, Routes::ALL)
    }

    /// [`SoftRasterizer::backward_saved`] with a choice of routes (tests switch one off to show
    /// that the gradient checks detect a missing term).
    pub(crate) fn vjp<T: Real>(&self, saved: &Saved<T>, d_image: Option<&[T]>, d_mask: Option<&[T]>, routes: Routes) -> Result<Vec<T>> {
        saved.check(self)?;
        let (batch, width, height) = (saved.batch, saved.width, saved.height);
        let npx = batch * width * height;
        if d_image.is_some_and(|g| g.len() != npx * 4) || d_mask.is_some_and(|g| g.len() != npx) {
            return Err(Error::mismatch(
                "render backward: the gradient sizes (image, mask)",
                format!("{:?}, {:?}", d_image.map(<[T]>::len), d_mask.map(<[T]>::len)),
                format!("{}, {npx}", npx * 4),
            ));
        }
        let pose = 2 * self.vertex_count;
        let mut grads = vec![T::zero(); batch * pose];
        if d_image.is_none() && d_mask.is_none() {
            return Ok(grads);
        }
        let ctxs: Vec<Ctx<T>> = (0..batch)
            .into_par_iter()
            .map(|b| Ctx::new(self, &saved.vertices[b * pose..(b + 1) * pose], &saved.params, width, height, false))
            .collect();
        let bands = height.div_ceil(TILE);
        // Rayon over poses × groups of bands (fixed, so the sums below run in a fixed order and
        // the result does not depend on scheduling); one buffer per group.
        const GROUP: usize = 8;
        let groups = bands.div_ceil(GROUP);
        let partial: Vec<Vec<T>> = (0..batch * groups)
            .into_par_iter()
            .map(|task| {
                let (b, group) = (task / groups, task % groups);
                let gi = d_image.map(|g| &g[b * width * height * 4..(b + 1) * width * height * 4]);
                let gm = d_mask.map(|g| &g[b * width * height..(b + 1) * width * height]);
                let mut g = vec![T::zero(); pose];
                for band in group * GROUP..((group + 1) * GROUP).min(bands) {
                    band_vjp(
                        &ctxs[b],
                        &saved.bands[b * bands + band],
                        band,
                        width,
                        height,
                        (gi, gm),
                        routes,
                        &mut g,
                    );
                }
                g
            })
            .collect();
        for (task, g) in partial.into_iter().enumerate() {
            let b = task / groups;
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
    /// Through the layer coverages A_l (outline edges).
    pub coverage: bool,
    /// Through the barycentric texture lookup (interiors).
    pub texture: bool,
}

impl Routes {
    /// Both routes: the full gradient.
    pub const ALL: Routes = Routes {
        coverage: true,
        texture: true,
    };
}

/// One visited layer re-evaluated from its record.
struct Layer<T> {
    face: u32,
    inside: bool,
    hit: Hit<T>,
    outline: Option<Outline<T>>,
    a: T,
    lookup: Lookup<T>,
    s: [T; 4],
    /// Composite of everything behind this layer (premultiplied).
    behind: [T; 4],
}

/// Accumulates the vertex gradient of one band of `TILE` rows into `g` (`V × 2`), visiting
/// pixels in the order the forward pass recorded them.
#[allow(clippy::too_many_arguments)]
fn band_vjp<T: Real>(
    ctx: &Ctx<T>,
    recs: &BandRecords,
    band: usize,
    width: usize,
    height: usize,
    (gi, gm): (Option<&[T]>, Option<&[T]>),
    routes: Routes,
    g: &mut [T],
) {
    let (zero, one) = (T::zero(), T::one());
    let half = real::<T>(0.5);
    let soft = ctx.sigma > zero && routes.coverage;
    let mut layers: Vec<Layer<T>> = Vec::new();
    let (mut pixel, mut next) = (0usize, 0usize);
    for tx in 0..width.div_ceil(TILE) {
        for y in band * TILE..((band + 1) * TILE).min(height) {
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                let n = recs.count[pixel] as usize;
                let here = &recs.records[next..next + n];
                (pixel, next) = (pixel + 1, next + n);
                if n == 0 {
                    continue;
                }
                let i = y * width + x;
                let gout = gi.map_or([zero; 4], |g| [g[4 * i], g[4 * i + 1], g[4 * i + 2], g[4 * i + 3]]);
                let gmask = gm.map_or(zero, |g| g[i]);
                if gout.iter().all(|&v| v == zero) && gmask == zero {
                    continue;
                }
                let p = [real::<T>(x as f64) + half, real::<T>(y as f64) + half];
                // The forward's quantities, front to back, and the silhouette product.
                layers.clear();
                let (mut prod, mut zeros, mut trans) = (one, 0u32, one);
                for r in here {
                    let outline = (r.edge != NO_EDGE).then(|| ctx.segs[r.edge as usize].closest(p, r.edge));
                    let hit = match (r.inside, &outline) {
                        (true, _) => inside_hit(p, &ctx.tris[r.face as usize]),
                        (false, Some(o)) => Some(ctx.outline_hit(o).1),
                        (false, None) => None,
                    }
                    .expect("the forward recorded an inside face or an outline edge");
                    let a = ctx.coverage(outline.as_ref(), r.inside);
                    let lookup = ctx.colour(r.layer, r.face, &hit);
                    let s = lookup.sample();
                    let om = one - a;
                    if om == zero {
                        zeros += 1;
                    } else {
                        prod = prod * om;
                    }
                    trans = trans * (one - a * s[3]);
                    layers.push(Layer {
                        face: r.face,
                        inside: r.inside,
                        hit,
                        outline,
                        a,
                        lookup,
                        s,
                        behind: [zero; 4],
                    });
                }
                // Compositing: out = Σ_l T_l X_l + T_bg bg, X_l = A_l S_l, α_l = A_l s_a,l, and
                // ∂out/∂α_l = −T_l · behind_l (the composite of what lies behind l). When the
                // forward stopped at an opaque layer (T = 0 after it) what lies behind it was not
                // evaluated; it enters only through ∂α/∂(A, s_a) of that layer, which is 0 there
                // (A = 1 beyond the cut; s_a = 1 is a maximum of the bilinear alpha).
                let mut behind = if trans == zero { [zero; 4] } else { ctx.bg };
                for la in layers.iter_mut().rev() {
                    la.behind = behind;
                    let alpha = la.a * la.s[3];
                    for c in 0..4 {
                        behind[c] = la.a * la.s[c] + (one - alpha) * behind[c];
                    }
                }
                let mut t = one;
                for la in &layers {
                    let gx = gout.map(|c| t * c);
                    let g_alpha = -t * (0..4).fold(zero, |s, c| s + gout[c] * la.behind[c]);
                    // dL/dA_l through the image, then through the silhouette:
                    // ∂M/∂A_l = Π_{k≠l}(1 − A_k).
                    let om = one - la.a;
                    let g_a = (0..4).fold(zero, |s, c| s + gx[c] * la.s[c]) + g_alpha * la.s[3] + gmask * product_without(prod, zeros, om);
                    let mut gs = gx.map(|c| la.a * c);
                    gs[3] = gs[3] + la.a * g_alpha;
                    // Texture lookup → UV → barycentric weights → the colour face's corners.
                    if routes.texture {
                        let guv = la.lookup.vjp(gs);
                        if guv[0] != zero || guv[1] != zero {
                            let face = &ctx.raster.faces[la.face as usize];
                            let gw = face
                                .uvs
                                .map(|uv| guv[0] * <T as From<f32>>::from(uv[0]) + guv[1] * <T as From<f32>>::from(uv[1]));
                            let mut gc = [[zero; 2]; 3];
                            bary_vjp(gw, p, ctx.corners(la.face as usize), &la.hit, &mut gc);
                            scatter(g, face.vertices, gc);
                        }
                    }
                    t = t * (one - la.a * la.s[3]);
                    // Coverage: A_l = sigmoid(z), z = ±d²/σ, d² = |p − q|², q = a + t(b − a) the
                    // closest point of the outline edge. At the minimising t (or a clamped end)
                    // ∂d²/∂a = −2(1 − t)(p − q) and ∂d²/∂b = −2t(p − q).
                    let Some(o) = la.outline.filter(|_| soft) else { continue };
                    let gz = g_a * la.a * om;
                    if gz == zero {
                        continue;
                    }
                    let gd2 = if la.inside { gz / ctx.sigma } else { -gz / ctx.sigma };
                    let [va, vb] = ctx.raster.edges[o.edge as usize].vertices;
                    let two = gd2 + gd2;
                    let ga_end = [-two * (one - o.t) * o.pq[0], -two * (one - o.t) * o.pq[1]];
                    let gb_end = [-two * o.t * o.pq[0], -two * o.t * o.pq[1]];
                    for (v, gv) in [(va, ga_end), (vb, gb_end)] {
                        g[2 * v as usize] = g[2 * v as usize] + gv[0];
                        g[2 * v as usize + 1] = g[2 * v as usize + 1] + gv[1];
                    }
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
        let gi = (0..mask.len() * 4)
            .map(|i| if keep(mask[i / 4]) { rng.uniform(-1.0, 1.0) } else { 0.0 })
            .collect();
        let gm = mask.iter().map(|&m| if keep(m) { rng.uniform(-1.0, 1.0) } else { 0.0 }).collect();
        (gi, gm)
    }

    const ALL: Routes = Routes::ALL;
    const NO_COVERAGE: Routes = Routes {
        coverage: false,
        texture: true,
    };
    const NO_TEXTURE: Routes = Routes {
        coverage: true,
        texture: false,
    };

    fn vjp(raster: &SoftRasterizer, v: &[f64], p: &Params, gi: &[f64], gm: &[f64], routes: Routes) -> Vec<f64> {
        let (_, saved) = raster.forward_saving(v, 1, W, H, p).unwrap();
        raster.vjp(&saved, Some(gi), Some(gm), routes).unwrap()
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
            let p = Params {
                sigma,
                cutoff: 1e-12,
                background: Background::Colour([0.9, 0.8, 0.7]),
            };
            let mask = raster.forward(&v, 1, W, H, &p).unwrap().mask;
            // Edge pixels: partial silhouette coverage. Interior pixels: covered to within 1e-3.
            let edge = weights(&mask, 1, |m| m > 0.02 && m < 0.98);
            let interior = weights(&mask, 2, |m| m > 0.999);
            for (name, (gi, gm), dropped, what) in [
                ("edge", &edge, NO_COVERAGE, "coverage"),
                ("interior", &interior, NO_TEXTURE, "texture"),
            ] {
                let full = vjp(&raster, &v, &p, gi, gm, ALL);
                let (bad, scale) = fd_violation(&raster, &v, &p, gi, gm, &full);
                println!("σ {sigma} {name} pixels: max |vjp − fd| / allowance = {bad:.1e} (max |fd| {scale:.3})");
                assert!(
                    bad <= 1.0,
                    "σ {sigma} {name}: gradient off the central differences ({bad} × allowance)"
                );
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
        let p = Params {
            sigma: 0.5,
            ..Params::default()
        };
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
        assert!(
            full[2 * off[2]..2 * off[3]].iter().all(|&g| g == 0.0),
            "off-image head got a gradient"
        );
        assert!(full.iter().any(|&g| g != 0.0), "crisp texture route is empty");
        // Central differences see the interiors (no pixel changes coverage for a 1e-6 step).
        let (bad, _) = fd_violation(&raster, &v, &p, &gi, &gm, &full);
        assert!(bad <= 1.0, "{bad} × allowance");
    }

    #[test]
    fn batched_backward_equals_per_pose_backward_and_f32_follows_f64() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let (a, b) = (
            jittered(&puppet.rest_vertices(), 30, 0.4),
            jittered(&puppet.rest_vertices(), 31, 0.4),
        );
        let p = Params::default();
        let mut rng = Rng::new(9);
        let gi: Vec<f64> = (0..2 * W * H * 4).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let both: Vec<f64> = a.iter().chain(&b).copied().collect();
        let g = raster.backward(&both, 2, W, H, &p, Some(&gi), None).unwrap();
        let ga = raster.backward(&a, 1, W, H, &p, Some(&gi[..W * H * 4]), None).unwrap();
        let gb = raster.backward(&b, 1, W, H, &p, Some(&gi[W * H * 4..]), None).unwrap();
        let n = a.len();
        assert!(g[..n]
            .iter()
            .zip(&ga)
            .chain(g[n..].iter().zip(&gb))
            .all(|(x, y)| (x - y).abs() < 1e-9));
        let a32: Vec<f32> = a.iter().map(|&x| x as f32).collect();
        let gi32: Vec<f32> = gi[..W * H * 4].iter().map(|&x| x as f32).collect();
        let g32 = raster.backward(&a32, 1, W, H, &p, Some(&gi32), None).unwrap();
        let scale = ga.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let err = g32.iter().zip(&ga).fold(0.0f64, |m, (x, y)| m.max((*x as f64 - y).abs()));
        assert!(err < 1e-3 * scale, "f32 gradient off by {err} (scale {scale})");
    }

    #[test]
    fn saved_records_of_another_puppet_or_wrong_gradient_sizes_are_errors() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let v = jittered(&puppet.rest_vertices(), 40, 0.4);
        let (_, saved) = raster.forward_saving(&v, 1, W, H, &Params::default()).unwrap();
        let gi = vec![1.0; W * H * 4];
        assert!(raster.backward_saved(&saved, Some(&gi[1..]), None).is_err());
        assert!(raster.backward_saved(&saved, None, Some(&gi)).is_err());
        let mut smaller = puppet.clone();
        smaller.layers.pop();
        let other = SoftRasterizer::new(&smaller).unwrap();
        let err = other.backward_saved(&saved, Some(&gi), None).unwrap_err().to_string();
        assert!(err.contains("saved forward") && err.contains("this puppet"), "{err}");
        assert!(raster.backward_saved(&saved, Some(&gi), None).is_ok());
    }
}
