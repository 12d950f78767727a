//! Forward pass of the soft rasterizer (neural-puppet.md §3.2 eq. 1; silhouette of eq. 10–11):
//! rayon over batch × bands of 8 rows, tile by tile, faces from [`Bins`]. The per-pixel
//! evaluation [`Pixel::shade`] is shared with the backward pass so both see the same function.

use rayon::prelude::*;

use super::bins::{Bins, TILE};
use super::geometry::{hit_within, Hit, Tri};
use super::texture::sample;
use super::{real, Params, Real, SoftRasterizer};
use crate::error::Result;

/// A batch of rendered images and silhouettes.
#[derive(Clone, Debug, PartialEq)]
pub struct Frames<T> {
    /// Number of images B.
    pub batch: usize,
    /// Width W in pixels.
    pub width: usize,
    /// Height H in pixels.
    pub height: usize,
    /// Premultiplied RGBA, `[B, H, W, 4]` row-major.
    pub image: Vec<T>,
    /// Silhouette `M = 1 − Π_l (1 − A_l)`, `[B, H, W]`.
    pub mask: Vec<T>,
}

/// Per-pose constants of one render.
pub(crate) struct Ctx<'a, T> {
    pub raster: &'a SoftRasterizer,
    /// This pose's vertices, `V × 2`.
    pub verts: &'a [T],
    pub bins: Bins<T>,
    /// Boundary edges binned the same way (an edge is binned as the degenerate triangle a, b, b).
    pub edge_bins: Bins<T>,
    /// Every face's per-pose constants.
    pub tris: Vec<Tri<T>>,
    /// σ (0: crisp), the cut distance² and its root, the background (premultiplied).
    pub sigma: T,
    pub cut2: T,
    pub reach: T,
    pub bg: [T; 4],
}

impl<'a, T: Real> Ctx<'a, T> {
    pub fn new(raster: &'a SoftRasterizer, verts: &'a [T], params: &Params, width: usize, height: usize) -> Self {
        let cut2: T = real(params.cut_distance2());
        let corners = |f: usize| raster.faces[f].vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
        let bins = Bins::new(raster.faces.len(), corners, cut2.sqrt(), width, height);
        let ends = |e: usize| {
            let [a, b] = raster.edges[e].vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
            [a, b, b]
        };
        let edge_bins = Bins::new(raster.edges.len(), ends, cut2.sqrt(), width, height);
        let tris = (0..raster.faces.len()).map(|f| Tri::new(corners(f))).collect();
        let bg = params.background.premultiplied().map(|c| real(c as f64));
        Ctx {
            raster,
            verts,
            bins,
            edge_bins,
            tris,
            sigma: real(params.sigma as f64),
            cut2,
            reach: cut2.sqrt(),
            bg,
        }
    }

    #[inline]
    pub fn corners(&self, f: usize) -> [[T; 2]; 3] {
        self.raster.faces[f]
            .vertices
            .map(|i| [self.verts[2 * i as usize], self.verts[2 * i as usize + 1]])
    }
}

/// The nearest boundary edge of a layer within reach of the pixel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Outline<T> {
    /// Index into [`SoftRasterizer::edges`].
    pub edge: u32,
    /// Closest point `q = a + t (b − a)`, t in [0, 1].
    pub t: T,
    /// `p − q`.
    pub pq: [T; 2],
    /// `|p − q|²`.
    pub dist2: T,
}

/// One layer that some face reaches at the pixel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LayerAt<T> {
    pub layer: u32,
    /// Some face of the layer contains the pixel centre.
    pub inside: bool,
    /// The nearest outline edge within reach (none: coverage is exactly 0 or 1).
    pub outline: Option<Outline<T>>,
    /// The face giving the colour (largest signed distance) and its hit.
    pub best: u32,
    pub best_key: T,
    pub best_hit: Option<Hit<T>>,
    /// Coverage A_l, texture lookup position and premultiplied sample S_l.
    pub a: T,
    pub uv: [T; 2],
    pub s: [T; 4],
    /// Composite of everything behind this layer (premultiplied).
    pub behind: [T; 4],
}

/// Reusable per-task buffers: one pixel's layers (no allocation per pixel).
pub(crate) struct Pixel<T> {
    pub touched: Vec<LayerAt<T>>,
    /// Π_l (1 − A_l) over the touched layers with a non-zero factor, and the count of zero factors.
    pub prod: T,
    pub zeros: u32,
}

/// `Π_{k ≠ j} f_k` from the product of the non-zero factors and the number of zero factors.
#[inline]
pub(crate) fn product_without<T: Real>(prod: T, zeros: u32, f_j: T) -> T {
    if f_j == T::zero() {
        if zeros == 1 {
            prod
        } else {
            T::zero()
        }
    } else if zeros == 0 {
        prod / f_j
    } else {
        T::zero()
    }
}

impl<T: Real> Pixel<T> {
    pub fn new() -> Self {
        Pixel {
            touched: Vec::new(),
            prod: T::one(),
            zeros: 0,
        }
    }

    /// Evaluates pixel centre `p` against the faces and outline edges of its tile; returns
    /// (premultiplied RGBA, M).
    #[inline]
    pub fn shade(&mut self, ctx: &Ctx<T>, p: [T; 2], faces: &[u32], edges: &[u32]) -> ([T; 4], T) {
        let (zero, one) = (T::zero(), T::one());
        let crisp = ctx.sigma == zero;
        self.touched.clear();
        self.prod = one;
        self.zeros = 0;
        for &f in faces {
            let b = &ctx.bins.boxes[f as usize];
            if p[0] < b[0] || p[0] > b[2] || p[1] < b[1] || p[1] > b[3] {
                continue;
            }
            let Some(h) = hit_within(p, &ctx.tris[f as usize], ctx.reach) else {
                continue;
            };
            if !h.inside && (crisp || h.dist2 > ctx.cut2) {
                continue;
            }
            let layer = ctx.raster.face_layer[f as usize];
            if self.touched.last().is_none_or(|t| t.layer != layer) {
                self.touched.push(LayerAt {
                    layer,
                    inside: false,
                    outline: None,
                    best: f,
                    best_key: T::neg_infinity(),
                    best_hit: None,
                    a: zero,
                    uv: [zero; 2],
                    s: [zero; 4],
                    behind: [zero; 4],
                });
            }
            let la = self.touched.last_mut().expect("pushed above");
            la.inside |= h.inside;
            let key = h.signed_dist2();
            if key > la.best_key {
                la.best_key = key;
                la.best = f;
                la.best_hit = Some(h);
            }
        }
        if !crisp && !self.touched.is_empty() {
            for &e in edges {
                let b = &ctx.edge_bins.boxes[e as usize];
                if p[0] < b[0] || p[0] > b[2] || p[1] < b[1] || p[1] > b[3] {
                    continue;
                }
                let edge = &ctx.raster.edges[e as usize];
                // Layers are few and in order: a short scan finds the slot (none: the layer has
                // no face within reach, so its outline is not within reach either).
                let Some(la) = self.touched.iter_mut().find(|la| la.layer == edge.layer) else {
                    continue;
                };
                let [a, b] = edge.vertices.map(|i| [ctx.verts[2 * i as usize], ctx.verts[2 * i as usize + 1]]);
                let o = closest_on_segment(p, a, b, e);
                if o.dist2 <= ctx.cut2 && la.outline.is_none_or(|best| o.dist2 < best.dist2) {
                    la.outline = Some(o);
                }
            }
        }
        let mut acc = ctx.bg;
        for la in &mut self.touched {
            la.a = match (la.outline, la.inside) {
                (Some(o), inside) if !crisp => {
                    let z = if inside { o.dist2 / ctx.sigma } else { -o.dist2 / ctx.sigma };
                    one / (one + (-z).exp())
                }
                (_, true) => one,
                (_, false) => zero,
            };
            let om = one - la.a;
            if om == zero {
                self.zeros += 1;
            } else {
                self.prod = self.prod * om;
            }
            let h = la.best_hit.expect("a touched layer has a face");
            let uvs = ctx.raster.faces[la.best as usize].uvs;
            la.uv = [0, 1].map(|c| (0..3).fold(zero, |s, k| s + h.w[k] * real::<T>(uvs[k][c] as f64)));
            la.s = sample(&ctx.raster.textures[la.layer as usize], la.uv);
            la.behind = acc;
            let alpha = la.a * la.s[3];
            for c in 0..4 {
                acc[c] = la.a * la.s[c] + (one - alpha) * acc[c];
            }
        }
        let mask = if self.zeros > 0 { one } else { one - self.prod };
        (acc, mask)
    }
}

/// The closest point to `p` on segment (a, b) (edge `edge`).
#[inline]
pub(crate) fn closest_on_segment<T: Real>(p: [T; 2], a: [T; 2], b: [T; 2], edge: u32) -> Outline<T> {
    let (zero, one) = (T::zero(), T::one());
    let e = [b[0] - a[0], b[1] - a[1]];
    let ap = [p[0] - a[0], p[1] - a[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = if len2 > zero {
        ((ap[0] * e[0] + ap[1] * e[1]) / len2).max(zero).min(one)
    } else {
        zero
    };
    let pq = [ap[0] - t * e[0], ap[1] - t * e[1]];
    Outline {
        edge,
        t,
        pq,
        dist2: pq[0] * pq[0] + pq[1] * pq[1],
    }
}

impl SoftRasterizer {
    /// Renders B poses: `vertices` is `[B, V, 2]` row-major in output pixels (origin top-left,
    /// y down, pixel centres at (x + 0.5, y + 0.5)).
    ///
    /// # Errors
    /// [`crate::Error::Invalid`] if the sizes disagree, a coordinate is not finite, the image is
    /// empty, or `params` is invalid.
    pub fn forward<T: Real>(&self, vertices: &[T], batch: usize, width: usize, height: usize, params: &Params) -> Result<Frames<T>> {
        params.validate()?;
        self.validate_input(vertices, batch, width, height)?;
        let (mut image, mut mask) = (vec![T::zero(); batch * height * width * 4], vec![T::zero(); batch * height * width]);
        let pose = 2 * self.vertex_count;
        let ctxs: Vec<Ctx<T>> = (0..batch)
            .into_par_iter()
            .map(|b| Ctx::new(self, &vertices[b * pose..(b + 1) * pose], params, width, height))
            .collect();
        image
            .par_chunks_mut(height * width * 4)
            .zip(mask.par_chunks_mut(height * width))
            .zip(ctxs.par_iter())
            .flat_map(|((img, msk), ctx)| {
                img.par_chunks_mut(TILE * width * 4)
                    .zip(msk.par_chunks_mut(TILE * width))
                    .enumerate()
                    .map(move |(band, bm)| (band, bm, ctx))
            })
            .for_each(|(band, (img, msk), ctx)| {
                let mut px = Pixel::new();
                let half = real::<T>(0.5);
                for tx in 0..width.div_ceil(TILE) {
                    let faces = ctx.bins.tile(tx, band);
                    let edges = ctx.edge_bins.tile(tx, band);
                    for ly in 0..TILE.min(height - band * TILE) {
                        let y = band * TILE + ly;
                        for x in tx * TILE..((tx + 1) * TILE).min(width) {
                            let i = ly * width + x;
                            if faces.is_empty() {
                                img[4 * i..4 * i + 4].copy_from_slice(&ctx.bg);
                                continue;
                            }
                            let p = [real::<T>(x as f64) + half, real::<T>(y as f64) + half];
                            let (rgba, m) = px.shade(ctx, p, faces, edges);
                            img[4 * i..4 * i + 4].copy_from_slice(&rgba);
                            msk[i] = m;
                        }
                    }
                }
            });
        Ok(Frames {
            batch,
            width,
            height,
            image,
            mask,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::reference;
    use super::super::Background;
    use super::*;
    use crate::puppet::{Layer, LayerKind, Mesh, Puppet};
    use crate::test_util::{jittered, layered_puppet, stripes, texture, Rng};

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    fn params(sigma: f32, background: Background) -> Params {
        Params {
            sigma,
            background,
            ..Params::default()
        }
    }

    #[test]
    fn forward_matches_reference_on_random_poses_of_the_layered_puppet() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let (w, h) = (50, 37); // not multiples of the tile size
        let mut rng = Rng::new(7);
        for seed in 0..4u64 {
            // Jitter below what folds a triangle: a fold makes two faces of a layer tie up to rounding.
            let mut v = jittered(&puppet.rest_vertices(), seed, 0.4);
            let (dx, dy) = (rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 4.0));
            v.chunks_mut(2).for_each(|p| (p[0], p[1]) = (p[0] + dx, p[1] + dy));
            for (sigma, bg) in [
                (0.3, Background::Transparent),
                (1.0, Background::Colour([0.2, 0.9, 1.0])),
                (0.0, Background::Transparent),
            ] {
                let p = params(sigma, bg);
                let fast = raster.forward(&v, 1, w, h, &p).unwrap();
                let (img, mask) = reference::render(&raster, &v, w, h, &p);
                let (di, dm) = (max_diff(&fast.image, &img), max_diff(&fast.mask, &mask));
                assert!(di < 1e-12 && dm < 1e-12, "seed {seed} σ {sigma}: image {di:e}, mask {dm:e}");
                // The f32 kernel agrees to single precision.
                let v32: Vec<f32> = v.iter().map(|&x| x as f32).collect();
                let f32img: Vec<f64> = raster.forward(&v32, 1, w, h, &p).unwrap().image.iter().map(|&x| x as f64).collect();
                assert!(
                    max_diff(&f32img, &img) < 2e-4,
                    "f32 seed {seed} σ {sigma}: {:e}",
                    max_diff(&f32img, &img)
                );
            }
        }
    }

    /// One layer of raw triangles (the renderer must survive what a bad pose produces).
    fn raw_puppet(tris: &[[[f32; 2]; 3]]) -> Puppet {
        let frame = (20, 16);
        let mesh = Mesh {
            vertices: tris.iter().flatten().copied().collect(),
            triangles: (0..tris.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
        };
        let uvs = mesh.vertices.iter().map(|v| [v[0] / 20.0, v[1] / 16.0]).collect();
        let tex = texture(frame.0, frame.1, |_, _| true, stripes([0.7, 0.4, 0.9], 4.0));
        let layer = Layer {
            name: "raw".into(),
            kind: LayerKind::Body,
            mesh,
            uvs,
            texture: tex,
        };
        Puppet {
            width: frame.0,
            height: frame.1,
            layers: vec![layer.clone(), layer],
            root: 0,
            joints: vec![],
        }
    }

    #[test]
    fn forward_matches_reference_on_degenerate_scenes() {
        let scenes: [&[[[f32; 2]; 3]]; 4] = [
            // zero-area face (collinear) beside a normal one
            &[[[2.0, 2.0], [8.0, 5.0], [14.0, 8.0]], [[3.0, 9.0], [12.0, 10.3], [6.0, 14.7]]],
            // off-screen and straddling the image border
            &[
                [[-30.0, -30.0], [-20.0, -30.0], [-25.0, -22.0]],
                [[15.2, 10.1], [27.0, 12.0], [18.0, 25.0]],
            ],
            // coincident faces, one wound clockwise
            &[[[3.1, 2.2], [15.3, 4.1], [7.7, 13.9]], [[3.1, 2.2], [7.7, 13.9], [15.3, 4.1]]],
            // a point-like face and a sliver
            &[[[9.3, 7.3], [9.3, 7.3], [9.3, 7.3]], [[1.0, 1.2], [19.0, 1.3], [10.0, 1.35]]],
        ];
        for (k, tris) in scenes.iter().enumerate() {
            let puppet = raw_puppet(tris);
            let raster = SoftRasterizer::new(&puppet).unwrap();
            let mut v: Vec<f64> = puppet.rest_vertices().iter().flatten().map(|&c| c as f64).collect();
            // The second layer is the first shifted (exactly, keeping collinear points collinear),
            // so layers overlap partly.
            let half = v.len() / 2;
            v[half..].iter_mut().step_by(2).for_each(|x| *x += 1.25);
            for sigma in [0.0, 0.5, 2.0] {
                let p = params(sigma, Background::Transparent);
                let fast = raster.forward(&v, 1, 20, 16, &p).unwrap();
                let (img, mask) = reference::render(&raster, &v, 20, 16, &p);
                let (di, dm) = (max_diff(&fast.image, &img), max_diff(&fast.mask, &mask));
                // A zero-area face's edges overlap, so its nearest edge is a tie broken differently
                // by the two codes; both give the same point, but the f32-rounded UVs make the
                // colour differ by ~1e-8. Coverage has no such tie.
                assert!(di < 1e-7 && dm < 1e-12, "scene {k} σ {sigma}: image {di:e}, mask {dm:e}");
                assert!(
                    fast.image.iter().chain(&fast.mask).all(|&x| (0.0..=1.0 + 1e-12).contains(&x)),
                    "scene {k}: out of [0, 1]"
                );
            }
        }
    }

    #[test]
    fn batch_items_are_independent_and_a_whole_pixel_shift_moves_the_image() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let v = jittered(&puppet.rest_vertices(), 3, 0.3);
        let shifted: Vec<f64> = v.chunks(2).flat_map(|p| [p[0] + 1.0, p[1]]).collect();
        let both: Vec<f64> = v.iter().chain(&shifted).copied().collect();
        let p = params(0.5, Background::Transparent);
        let f = raster.forward(&both, 2, 56, 40, &p).unwrap();
        let single = raster.forward(&v, 1, 56, 40, &p).unwrap();
        assert_eq!(&f.image[..56 * 40 * 4], &single.image[..]);
        for y in 0..40 {
            for x in 1..56 {
                for c in 0..4 {
                    let (a, b) = (f.image[(y * 56 + x - 1) * 4 + c], f.image[56 * 40 * 4 + (y * 56 + x) * 4 + c]);
                    assert!((a - b).abs() < 1e-12, "({x}, {y}).{c}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn crisp_mode_equals_the_hard_rasterizer_and_is_the_small_sigma_limit() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        for seed in 0..3 {
            let v = jittered(&puppet.rest_vertices(), 100 + seed, 1.5);
            for bg in [Background::Transparent, Background::Colour([1.0, 1.0, 1.0])] {
                let crisp = raster.forward(&v, 1, 48, 40, &Params::crisp(bg)).unwrap();
                let hard = reference::hard(&raster, &v, 48, 40, bg.premultiplied().map(|c| c as f64));
                assert!(
                    max_diff(&crisp.image, &hard) < 1e-12,
                    "seed {seed}: {:e}",
                    max_diff(&crisp.image, &hard)
                );
                // σ → 0: a pixel differs only within ~√(37σ) px of an edge — none at σ = 1e-12.
                let soft = raster.forward(&v, 1, 48, 40, &params(1e-12, bg)).unwrap();
                assert!(
                    max_diff(&soft.image, &crisp.image) < 1e-9,
                    "seed {seed}: σ=1e-12 vs crisp {:e}",
                    max_diff(&soft.image, &crisp.image)
                );
            }
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let puppet = layered_puppet();
        let raster = SoftRasterizer::new(&puppet).unwrap();
        let v: Vec<f32> = puppet.rest_vertices().iter().flatten().copied().collect();
        assert!(raster.forward(&v[1..], 1, 8, 8, &Params::default()).is_err());
        let mut nan = v.clone();
        nan[5] = f32::NAN;
        assert!(raster
            .forward(&nan, 1, 8, 8, &Params::default())
            .unwrap_err()
            .to_string()
            .contains("coordinate 5"));
        assert!(raster.forward(&v, 1, 0, 8, &Params::default()).is_err());
        assert!(raster.forward(&v, 1, 8, 8, &params(-1.0, Background::Transparent)).is_err());
        let mut broken = puppet.clone();
        broken.layers[2].uvs.pop();
        assert!(SoftRasterizer::new(&broken).unwrap_err().to_string().contains("\"head\""));
    }
}
