//! The slow and obvious soft rasterizer (tests only): every face against every pixel in f64,
//! written from the definitions in `mod.rs` without the fast path's tiles, bounding boxes or
//! shared geometry code; plus a plain hard rasterizer (scan each triangle, paint, composite) for
//! the σ → 0 equivalence.

use super::{Params, SoftRasterizer, Texture};

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Barycentrics of `p` in (a, b, c), or None for a zero-area triangle.
fn barycentric(p: [f64; 2], v: [[f64; 2]; 3]) -> Option<[f64; 3]> {
    let area = cross(sub(v[1], v[0]), sub(v[2], v[0]));
    if area == 0.0 {
        return None;
    }
    let w1 = cross(sub(v[2], v[1]), sub(p, v[1])) / area;
    let w2 = cross(sub(v[0], v[2]), sub(p, v[2])) / area;
    Some([w1, w2, 1.0 - w1 - w2])
}

/// Is `p` inside or on the triangle?
fn inside(p: [f64; 2], v: [[f64; 2]; 3]) -> bool {
    barycentric(p, v).is_some_and(|w| w.iter().all(|&x| x >= -1e-12))
}

/// Closest point to `p` on the triangle's boundary: (distance², barycentrics of that point).
fn closest_boundary(p: [f64; 2], v: [[f64; 2]; 3]) -> (f64, [f64; 3]) {
    let mut best = (f64::INFINITY, [0.0; 3]);
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let e = sub(b, a);
        let len2 = e[0] * e[0] + e[1] * e[1];
        let t = if len2 > 0.0 {
            ((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / len2
        } else {
            0.0
        };
        let t = t.clamp(0.0, 1.0);
        let q = [a[0] + t * e[0], a[1] + t * e[1]];
        let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
        if d2 < best.0 {
            let mut w = [0.0; 3];
            w[k] = 1.0 - t;
            w[(k + 1) % 3] = t;
            best = (d2, w);
        }
    }
    best
}

/// Bilinear lookup, texel centres at ((i + 0.5)/W, (j + 0.5)/H), clamp to edge.
fn bilinear(tex: &Texture, uv: [f64; 2]) -> [f64; 4] {
    let x = uv[0] * tex.width as f64 - 0.5;
    let y = uv[1] * tex.height as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |i: f64, j: f64| {
        let i = i.clamp(0.0, tex.width as f64 - 1.0) as usize;
        let j = j.clamp(0.0, tex.height as f64 - 1.0) as usize;
        tex.texels[j * tex.width + i].map(|c| c as f64)
    };
    let (a, b, c, d) = (at(x0, y0), at(x0 + 1.0, y0), at(x0, y0 + 1.0), at(x0 + 1.0, y0 + 1.0));
    [0, 1, 2, 3].map(|k| (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy)
}

/// One pose rendered by brute force: (premultiplied RGBA `[H, W, 4]`, mask `[H, W]`).
pub(crate) fn render(raster: &SoftRasterizer, verts: &[f64], width: usize, height: usize, params: &Params) -> (Vec<f64>, Vec<f64>) {
    let sigma = params.sigma as f64;
    let layers = raster.textures.len();
    let bg = params.background.premultiplied().map(|c| c as f64);
    let (mut image, mut mask) = (vec![0.0; width * height * 4], vec![0.0; width * height]);
    for y in 0..height {
        for x in 0..width {
            let p = [x as f64 + 0.5, y as f64 + 0.5];
            // Per layer: the first face (in index order) containing p, with its weights.
            let mut inner: Vec<Option<(usize, [f64; 3])>> = vec![None; layers];
            for (f, face) in raster.faces.iter().enumerate() {
                let v = face.vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
                let l = raster.face_layer[f] as usize;
                if inner[l].is_none() && inside(p, v) {
                    inner[l] = Some((f, barycentric(p, v).expect("inside implies non-zero area")));
                }
            }
            // Per layer: distance² to the outline (the edges used by one triangle only), and the
            // closest point as weights on the corners of the face that edge bounds (the first
            // of equally close edges).
            let mut outline: Vec<(f64, usize, [f64; 3])> = vec![(f64::INFINITY, 0, [0.0; 3]); layers];
            for edge in &raster.edges {
                let [a, b] = edge.vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
                let (d2, w) = closest_boundary(p, [a, b, b]);
                let l = edge.layer as usize;
                if d2 < outline[l].0 {
                    let k = edge.corner as usize;
                    let mut wf = [0.0; 3];
                    (wf[k], wf[(k + 1) % 3]) = (w[0], w[1] + w[2]);
                    outline[l] = (d2, edge.face as usize, wf);
                }
            }
            let mut acc = bg;
            let mut all = 1.0;
            for l in 0..layers {
                let within = sigma > 0.0 && outline[l].0 <= params.cut_distance2();
                // Inside, the containing face gives the colour; outside, the closest outline
                // point's face; outside and beyond the cut, A = 0 and the layer adds nothing.
                let (f, w) = match (inner[l], within) {
                    (Some(fw), _) => fw,
                    (None, true) => (outline[l].1, outline[l].2),
                    (None, false) => continue,
                };
                // Beyond the cut radius the sigmoid is within ε of 0 or 1 and is taken as that.
                let a = if !within {
                    1.0
                } else {
                    let d2 = outline[l].0;
                    let z = if inner[l].is_some() { d2 } else { -d2 };
                    1.0 / (1.0 + (-z / sigma).exp())
                };
                all *= 1.0 - a;
                let uvs = raster.faces[f].uvs;
                let uv = [0, 1].map(|c| (0..3).map(|k| w[k] * uvs[k][c] as f64).sum::<f64>());
                let s = bilinear(&raster.textures[l], uv);
                let alpha = a * s[3];
                acc = [0, 1, 2, 3].map(|c| a * s[c] + (1.0 - alpha) * acc[c]);
            }
            image[4 * (y * width + x)..4 * (y * width + x) + 4].copy_from_slice(&acc);
            mask[y * width + x] = 1.0 - all;
        }
    }
    (image, mask)
}

/// A plain hard rasterizer: each layer's triangles painted where the pixel centre is inside
/// (edges included; where a layer's triangles overlap, the first paints), textured at the
/// interpolated UV, layers composited "over" back to front.
pub(crate) fn hard(raster: &SoftRasterizer, verts: &[f64], width: usize, height: usize, bg: [f64; 4]) -> Vec<f64> {
    let mut image: Vec<f64> = (0..width * height).flat_map(|_| bg).collect();
    for l in 0..raster.textures.len() {
        let mut paint: Vec<Option<[f64; 4]>> = vec![None; width * height];
        for (f, face) in raster.faces.iter().enumerate().filter(|(f, _)| raster.face_layer[*f] as usize == l) {
            let v = face.vertices.map(|i| [verts[2 * i as usize], verts[2 * i as usize + 1]]);
            let x0 = v.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
            let y0 = v.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
            let x1 = (v.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max).ceil() as usize).min(width);
            let y1 = (v.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max).ceil() as usize).min(height);
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = [x as f64 + 0.5, y as f64 + 0.5];
                    if paint[y * width + x].is_some() {
                        continue;
                    }
                    if let (true, Some(w)) = (inside(p, v), barycentric(p, v)) {
                        let uvs = raster.faces[f].uvs;
                        let uv = [0, 1].map(|c| (0..3).map(|k| w[k] * uvs[k][c] as f64).sum::<f64>());
                        paint[y * width + x] = Some(bilinear(&raster.textures[l], uv));
                    }
                }
            }
        }
        for (i, s) in paint.iter().enumerate() {
            if let Some(s) = s {
                for c in 0..4 {
                    image[4 * i + c] = s[c] + (1.0 - s[3]) * image[4 * i + c];
                }
            }
        }
    }
    image
}
