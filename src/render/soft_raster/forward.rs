//! Forward pass of the soft rasterizer (neural-puppet.md §3.2 eq. 1; silhouette of eq. 10–11):
//! rayon over batch × bands of `TILE` rows, tile by tile, faces from [`Bins`]. Per pixel
//! ([`Pixel::shade`]) the layers are visited **front to back**: a layer's faces until the first
//! that contains the pixel (its colour), then its outline edges within the cut distance for the
//! coverage (outside, the nearest one's face gives the colour); compositing stops when the transmittance reaches exactly 0 (an opaque
//! layer fully covering the pixel), since everything behind is then multiplied by 0. On request
//! the pass keeps, per pixel and visited layer, the colour face and outline edge it found
//! ([`Saved`]), so the backward pass evaluates one face and one edge per layer instead of
//! searching again.

use std::ops::Range;

use rayon::prelude::*;

use super::bins::{Bins, TILE};
use super::geometry::{edge_hit, inside_hit, Hit, Outline, Seg, Tri};
use super::texture::Lookup;
use super::{real, Params, Real, SoftRasterizer};
use crate::error::{Error, Result};

/// A batch of rendered images and silhouettes.
#[derive(Clone, Debug, PartialEq)]
pub struct RasterFrames<T> {
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

/// What [`SoftRasterizer::backward_saved`] needs from a forward pass: the call (poses, sizes,
/// parameters) and, per pixel, the layers the forward visited, front to back, each with the face
/// that gave its colour and the outline edge that gave its coverage. About 16 bytes per visited
/// layer and 4 per pixel.
#[derive(Clone, Debug)]
pub struct Saved<T> {
    pub(crate) vertices: Vec<T>,
    pub(crate) batch: usize,
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) params: Params,
    /// One entry per (pose, band of `TILE` rows), pose-major.
    pub(crate) bands: Vec<BandRecords>,
}

impl<T> Saved<T> {
    /// Number of poses B of the forward call.
    pub fn batch(&self) -> usize {
        self.batch
    }

    /// The poses `[B, V, 2]` of the forward call.
    pub fn vertices(&self) -> &[T] {
        &self.vertices
    }
}

/// The records of one band, in the order the band's pixels are visited: tile by tile (left to
/// right), row by row within a tile.
#[derive(Clone, Debug, Default)]
pub(crate) struct BandRecords {
    /// Number of records of each pixel.
    pub count: Vec<u32>,
    pub records: Vec<Record>,
}

/// `Record::edge` when no outline edge is within reach (coverage exactly 0 or 1).
pub(crate) const NO_EDGE: u32 = u32::MAX;

/// One visited layer at one pixel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Record {
    pub layer: u32,
    /// The face giving the colour: the first containing the pixel, else the nearest.
    pub face: u32,
    /// The nearest outline edge within reach, or [`NO_EDGE`].
    pub edge: u32,
    /// Some face of the layer contains the pixel centre.
    pub inside: bool,
}

/// Per-pose constants of one render.
pub(crate) struct Ctx<'a, T> {
    pub raster: &'a SoftRasterizer,
    pub bins: Bins<T>,
    /// Boundary edges binned the same way (an edge is binned as the degenerate triangle a, b, b).
    pub edge_bins: Bins<T>,
    /// Every face's per-pose constants.
    pub tris: Vec<Tri<T>>,
    /// Every outline edge's per-pose constants (none when crisp).
    pub segs: Vec<Seg<T>>,
    /// σ (0: crisp), the cut distance², the background (premultiplied).
    pub sigma: T,
    pub cut2: T,
    pub bg: [T; 4],
}

impl<'a, T: Real> Ctx<'a, T> {
    /// The constants of pose `verts`; with `binned` false the bins are left empty (the backward
    /// pass reads its faces and edges from the forward's records).
    pub fn new(raster: &'a SoftRasterizer, verts: &'a [T], params: &Params, width: usize, height: usize, binned: bool) -> Self {
        let cut2: T = real(params.cut_distance2());
        let corners = |f: usize| raster.faces[f].vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
        // Faces matter only where they contain the pixel; outline edges out to the cut distance.
        let face_count = if binned { raster.faces.len() } else { 0 };
        let bins = Bins::new(face_count, corners, T::zero(), width, height);
        let ends = |e: usize| {
            let [a, b] = raster.edges[e].vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
            [a, b, b]
        };
        // Crisp coverage needs no outline.
        let edge_count = if binned && params.sigma > 0.0 { raster.edges.len() } else { 0 };
        let edge_bins = Bins::new(edge_count, ends, cut2.sqrt(), width, height);
        let tris = (0..raster.faces.len()).map(|f| Tri::new(corners(f))).collect();
        let segs = if params.sigma > 0.0 {
            (0..raster.edges.len())
                .map(|e| {
                    let [a, b, _] = ends(e);
                    Seg::new(a, b)
                })
                .collect()
        } else {
            Vec::new()
        };
        let bg = params.background.premultiplied().map(|c| real(c as f64));
        Ctx {
            raster,
            bins,
            edge_bins,
            tris,
            segs,
            sigma: real(params.sigma as f64),
            cut2,
            bg,
        }
    }

    #[inline]
    pub fn corners(&self, f: usize) -> [[T; 2]; 3] {
        self.tris[f].v
    }

    /// The colour face and outside hit at the closest point `o` of an outline edge.
    #[inline]
    pub fn outline_hit(&self, o: &Outline<T>) -> (u32, Hit<T>) {
        let edge = &self.raster.edges[o.edge as usize];
        (edge.face, edge_hit(o, edge.corner as usize, self.tris[edge.face as usize].area2))
    }

    /// Layer coverage `A_l` from the nearest outline edge within reach (none: 1 inside, 0
    /// outside; crisp: the same).
    #[inline]
    pub fn coverage(&self, outline: Option<&Outline<T>>, inside: bool) -> T {
        let (zero, one) = (T::zero(), T::one());
        match outline {
            Some(o) if self.sigma > zero => {
                let z = if inside { o.dist2 / self.sigma } else { -o.dist2 / self.sigma };
                one / (one + (-z).exp())
            }
            _ if inside => one,
            _ => zero,
        }
    }

    /// The lookup of the layer's texture at the UV of `hit` on face `face`.
    #[inline]
    pub fn colour(&self, layer: u32, face: u32, hit: &Hit<T>) -> Lookup<T> {
        let uvs = self.raster.faces[face as usize].uvs;
        let uv = [0, 1].map(|c| (0..3).fold(T::zero(), |s, k| s + hit.w[k] * <T as From<f32>>::from(uvs[k][c])));
        Lookup::new(&self.raster.textures[layer as usize], uv)
    }
}

/// A tile's faces and outline edges of one layer (ranges into the tile's lists).
#[derive(Clone, Debug)]
pub(crate) struct Run {
    pub layer: u32,
    pub faces: Range<usize>,
    pub edges: Range<usize>,
}

/// Splits a tile's face and edge lists (both in global order, so grouped by layer, back to
/// front) into per-layer runs; a layer has a run if it has faces or outline edges in the tile.
pub(crate) fn layer_runs(raster: &SoftRasterizer, faces: &[u32], edges: &[u32], runs: &mut Vec<Run>) {
    runs.clear();
    let face_layer = |i: usize| faces.get(i).map_or(u32::MAX, |&f| raster.face_layer[f as usize]);
    let edge_layer = |i: usize| edges.get(i).map_or(u32::MAX, |&e| raster.edges[e as usize].layer);
    let (mut i, mut e) = (0, 0);
    while i < faces.len() || e < edges.len() {
        let layer = face_layer(i).min(edge_layer(e));
        let (i0, e0) = (i, e);
        while face_layer(i) == layer {
            i += 1;
        }
        while edge_layer(e) == layer {
            e += 1;
        }
        runs.push(Run {
            layer,
            faces: i0..i,
            edges: e0..e,
        });
    }
}

/// Reusable per-task buffers (no allocation per pixel): the current tile's layer runs and one
/// pixel's visited layers, front to back.
pub(crate) struct Pixel {
    pub runs: Vec<Run>,
    pub layers: Vec<Record>,
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

impl Pixel {
    pub fn new() -> Self {
        Pixel {
            runs: Vec::new(),
            layers: Vec::new(),
        }
    }

    /// Evaluates pixel centre `p` against the faces and outline edges of its tile (whose layer
    /// runs are in `self.runs`); returns (premultiplied RGBA, M).
    #[inline]
    pub fn shade<T: Real>(&mut self, ctx: &Ctx<T>, p: [T; 2], faces: &[u32], edges: &[u32]) -> ([T; 4], T) {
        let (zero, one) = (T::zero(), T::one());
        let crisp = ctx.sigma == zero;
        self.layers.clear();
        let (mut acc, mut trans, mut prod, mut zeros) = ([zero; 4], one, one, 0u32);
        for run in self.runs.iter().rev() {
            // Inside: the first face containing p gives the colour.
            let mut inside: Option<(u32, Hit<T>)> = None;
            for &f in &faces[run.faces.clone()] {
                let b = &ctx.bins.boxes[f as usize];
                if p[0] < b[0] || p[0] > b[2] || p[1] < b[1] || p[1] > b[3] {
                    continue;
                }
                if let Some(h) = inside_hit(p, &ctx.tris[f as usize]) {
                    inside = Some((f, h));
                    break;
                }
            }
            // Coverage: the nearest outline edge within the cut distance (the first of equals).
            let mut outline: Option<Outline<T>> = None;
            if !crisp {
                for &e in &edges[run.edges.clone()] {
                    let b = &ctx.edge_bins.boxes[e as usize];
                    if p[0] < b[0] || p[0] > b[2] || p[1] < b[1] || p[1] > b[3] {
                        continue;
                    }
                    let o = ctx.segs[e as usize].closest(p, e);
                    if o.dist2 <= ctx.cut2 && outline.is_none_or(|best| o.dist2 < best.dist2) {
                        outline = Some(o);
                    }
                }
            }
            // Outside, the colour comes from the closest point of the outline, on the face that
            // edge bounds; with no outline within reach either, A = 0 and the layer adds nothing.
            let (face, hit) = match (inside, &outline) {
                (Some(fh), _) => fh,
                (None, Some(o)) => ctx.outline_hit(o),
                (None, None) => continue,
            };
            let a = ctx.coverage(outline.as_ref(), hit.inside);
            let s = ctx.colour(run.layer, face, &hit).sample();
            let ta = trans * a;
            for c in 0..4 {
                acc[c] = acc[c] + ta * s[c];
            }
            trans = trans * (one - a * s[3]);
            let om = one - a;
            if om == zero {
                zeros += 1;
            } else {
                prod = prod * om;
            }
            self.layers.push(Record {
                layer: run.layer,
                face,
                edge: outline.as_ref().map_or(NO_EDGE, |o| o.edge),
                inside: hit.inside,
            });
            if trans == zero {
                // Everything behind is multiplied by 0, and M = 1 (this layer has A = 1).
                break;
            }
        }
        for c in 0..4 {
            acc[c] = acc[c] + trans * ctx.bg[c];
        }
        let mask = if zeros > 0 { one } else { one - prod };
        (acc, mask)
    }
}

/// Renders one band of `TILE` rows of one pose into `img`/`msk` (the band's slices), keeping the
/// per-pixel records in `saved` if given.
fn render_band<T: Real>(ctx: &Ctx<T>, band: usize, width: usize, img: &mut [T], msk: &mut [T], mut saved: Option<&mut BandRecords>) {
    let mut px = Pixel::new();
    let half = real::<T>(0.5);
    let rows = msk.len() / width;
    if let Some(s) = saved.as_deref_mut() {
        // Typically one or two layers per pixel: reserve once instead of growing.
        s.count.reserve(rows * width);
        s.records.reserve(2 * rows * width);
    }
    for tx in 0..width.div_ceil(TILE) {
        let faces = ctx.bins.tile(tx, band);
        let edges = ctx.edge_bins.tile(tx, band);
        layer_runs(ctx.raster, faces, edges, &mut px.runs);
        for ly in 0..rows {
            let y = band * TILE + ly;
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                let i = ly * width + x;
                if faces.is_empty() && edges.is_empty() {
                    img[4 * i..4 * i + 4].copy_from_slice(&ctx.bg);
                    if let Some(s) = saved.as_deref_mut() {
                        s.count.push(0);
                    }
                    continue;
                }
                let p = [real::<T>(x as f64) + half, real::<T>(y as f64) + half];
                let (rgba, m) = px.shade(ctx, p, faces, edges);
                img[4 * i..4 * i + 4].copy_from_slice(&rgba);
                msk[i] = m;
                if let Some(s) = saved.as_deref_mut() {
                    s.count.push(px.layers.len() as u32);
                    s.records.extend_from_slice(&px.layers);
                }
            }
        }
    }
}

impl SoftRasterizer {
    /// Renders B poses: `vertices` is `[B, V, 2]` row-major in output pixels (origin top-left,
    /// y down, pixel centres at (x + 0.5, y + 0.5)).
    ///
    /// # Errors
    /// [`crate::Error::Mismatch`] if the sizes disagree, [`crate::Error::Geometry`] if a coordinate
    /// is not finite or the image is empty, [`crate::Error::Setting`] if `params` is invalid.
    pub fn forward<T: Real>(&self, vertices: &[T], batch: usize, width: usize, height: usize, params: &Params) -> Result<RasterFrames<T>> {
        self.render(vertices, batch, width, height, params, false).map(|(f, _)| f)
    }

    /// [`SoftRasterizer::forward`], also returning what [`SoftRasterizer::backward_saved`] needs
    /// (a copy of the poses and the per-pixel records).
    ///
    /// # Errors
    /// As [`SoftRasterizer::forward`].
    pub fn forward_saving<T: Real>(
        &self,
        vertices: &[T],
        batch: usize,
        width: usize,
        height: usize,
        params: &Params,
    ) -> Result<(RasterFrames<T>, Saved<T>)> {
        let (frames, bands) = self.render(vertices, batch, width, height, params, true)?;
        let saved = Saved {
            vertices: vertices.to_vec(),
            batch,
            width,
            height,
            params: *params,
            bands,
        };
        Ok((frames, saved))
    }

    /// The forward pass; with `save`, the records of every band (else an empty list).
    fn render<T: Real>(
        &self,
        vertices: &[T],
        batch: usize,
        width: usize,
        height: usize,
        params: &Params,
        save: bool,
    ) -> Result<(RasterFrames<T>, Vec<BandRecords>)> {
        params.validate()?;
        self.validate_input(vertices, batch, width, height)?;
        let (mut image, mut mask) = (vec![T::zero(); batch * height * width * 4], vec![T::zero(); batch * height * width]);
        let pose = 2 * self.vertex_count;
        let ctxs: Vec<Ctx<T>> = (0..batch)
            .into_par_iter()
            .map(|b| Ctx::new(self, &vertices[b * pose..(b + 1) * pose], params, width, height, true))
            .collect();
        let bands = height.div_ceil(TILE);
        let mut records: Vec<BandRecords> = if save {
            vec![BandRecords::default(); batch * bands]
        } else {
            Vec::new()
        };
        let mut slots = records.iter_mut();
        let mut tasks = Vec::with_capacity(batch * bands);
        for (b, (img, msk)) in image
            .chunks_mut(height * width * 4)
            .zip(mask.chunks_mut(height * width))
            .enumerate()
        {
            for (band, (bi, bm)) in img.chunks_mut(TILE * width * 4).zip(msk.chunks_mut(TILE * width)).enumerate() {
                tasks.push((b, band, bi, bm, slots.next()));
            }
        }
        tasks
            .into_par_iter()
            .for_each(|(b, band, img, msk, saved)| render_band(&ctxs[b], band, width, img, msk, saved));
        let frames = RasterFrames {
            batch,
            width,
            height,
            image,
            mask,
        };
        Ok((frames, records))
    }
}

impl<T: Real> Saved<T> {
    /// Checks that these records come from a forward call of `raster`.
    pub(crate) fn check(&self, raster: &SoftRasterizer) -> Result<()> {
        let bands = self.height.div_ceil(TILE);
        if self.vertices.len() != self.batch * raster.vertex_count * 2 || self.bands.len() != self.batch * bands {
            return Err(Error::mismatch(
                "render backward: the saved forward",
                format!("{} poses × {} coordinates", self.batch, self.vertices.len() / self.batch.max(1)),
                format!("{} vertices per pose (this puppet)", raster.vertex_count),
            ));
        }
        Ok(())
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
            rig: None,
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
