//! Layer masks at rest (the opaque pixels of each layer's texture) and what the rig reads off
//! them: overlaps, connected pieces, outlines sampled at a spacing, and exact Euclidean distances
//! (Felzenszwalb & Huttenlocher 2012, "Distance Transforms of Sampled Functions").
//!
//! Pixel `(x, y)` is the square `[x, x+1) × [y, y+1)`, its centre `(x + 0.5, y + 0.5)` (DESIGN.md).

use crate::puppet::mesh::contour::{contour, AlphaGrid};
use crate::puppet::Layer;

/// A binary image of the canvas: which pixels a layer covers.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major coverage.
    pub inside: Vec<bool>,
}

impl Mask {
    /// The pixels of `layer`'s texture with alpha above `threshold`.
    pub fn of_layer(layer: &Layer, threshold: f32) -> Self {
        Mask {
            width: layer.texture.width,
            height: layer.texture.height,
            inside: layer.texture.pixels.iter().map(|p| p[3] > threshold).collect(),
        }
    }

    /// The pixels of a `width` × `height` canvas whose centres lie in a triangle of `triangles`
    /// over `vertices` (either winding): a layer's coverage in any pose.
    pub fn of_triangles(vertices: &[[f32; 2]], triangles: &[[u32; 3]], width: u32, height: u32) -> Self {
        let mut inside = vec![false; width as usize * height as usize];
        for t in triangles {
            let c = t.map(|i| vertices[i as usize]);
            let xs = c.map(|p| p[0]);
            let ys = c.map(|p| p[1]);
            let lo = |v: [f32; 3]| (v.into_iter().fold(f32::INFINITY, f32::min) - 0.5).floor().max(0.0) as u32;
            let hi = |v: [f32; 3], n: u32| ((v.into_iter().fold(f32::NEG_INFINITY, f32::max) - 0.5).ceil().max(0.0) as u32 + 1).min(n);
            for y in lo(ys)..hi(ys, height) {
                for x in lo(xs)..hi(xs, width) {
                    if crate::geom::triangle::contains(c, [x as f32 + 0.5, y as f32 + 0.5], 1e-6) {
                        inside[(y * width + x) as usize] = true;
                    }
                }
            }
        }
        Mask { width, height, inside }
    }

    /// Pixels covered by either.
    pub fn or(&self, other: &Mask) -> Mask {
        Mask {
            width: self.width,
            height: self.height,
            inside: self.inside.iter().zip(&other.inside).map(|(a, b)| *a || *b).collect(),
        }
    }

    /// Pixels covered by both.
    pub fn and(&self, other: &Mask) -> Mask {
        Mask {
            width: self.width,
            height: self.height,
            inside: self.inside.iter().zip(&other.inside).map(|(a, b)| *a && *b).collect(),
        }
    }

    /// Covered pixels.
    pub fn count(&self) -> usize {
        self.inside.iter().filter(|&&i| i).count()
    }

    /// Whether pixel `(x, y)` is covered (false outside the canvas).
    pub fn at(&self, x: i64, y: i64) -> bool {
        x >= 0
            && y >= 0
            && x < i64::from(self.width)
            && y < i64::from(self.height)
            && self.inside[(y as usize) * self.width as usize + x as usize]
    }

    /// Whether the pixel holding point `p` is covered.
    pub fn covers(&self, p: [f32; 2]) -> bool {
        self.at(p[0].floor() as i64, p[1].floor() as i64)
    }

    /// The centre of pixel index `i`.
    pub fn centre(&self, i: usize) -> [f32; 2] {
        let w = self.width as usize;
        [(i % w) as f32 + 0.5, (i / w) as f32 + 0.5]
    }

    /// The mean of the covered pixel centres.
    pub fn centroid(&self) -> Option<[f32; 2]> {
        let n = self.count();
        (n > 0).then(|| {
            let s = (0..self.inside.len())
                .filter(|&i| self.inside[i])
                .map(|i| self.centre(i))
                .fold([0.0f64; 2], |s, p| [s[0] + f64::from(p[0]), s[1] + f64::from(p[1])]);
            [(s[0] / n as f64) as f32, (s[1] / n as f64) as f32]
        })
    }

    /// The 8-connected pieces, each as its pixel indices in row-major order, pieces ordered by
    /// their first pixel.
    pub fn pieces(&self) -> Vec<Vec<usize>> {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut label = vec![usize::MAX; self.inside.len()];
        let mut pieces = Vec::new();
        for start in 0..self.inside.len() {
            if !self.inside[start] || label[start] != usize::MAX {
                continue;
            }
            let id = pieces.len();
            let mut piece = vec![start];
            label[start] = id;
            let mut k = 0;
            while k < piece.len() {
                let i = piece[k];
                let (x, y) = ((i as i64) % w, (i as i64) / w);
                for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w && ny < h {
                        let j = (ny * w + nx) as usize;
                        if self.inside[j] && label[j] == usize::MAX {
                            label[j] = id;
                            piece.push(j);
                        }
                    }
                }
                k += 1;
            }
            piece.sort_unstable();
            pieces.push(piece);
        }
        pieces
    }

    /// Points along every outline of the mask (outer boundaries and holes, traced sub-pixel as
    /// the mesher traces them), one every `spacing` pixels of arc length, each ring starting at
    /// its first traced point.
    pub fn outline(&self, spacing: f32) -> Vec<[f32; 2]> {
        self.outline_rings(spacing).concat()
    }

    /// [`Mask::outline`] ring by ring, each ring's points in tracing order.
    pub fn outline_rings(&self, spacing: f32) -> Vec<Vec<[f32; 2]>> {
        let alpha: Vec<f32> = self.inside.iter().map(|&i| if i { 1.0 } else { 0.0 }).collect();
        let grid = AlphaGrid {
            alpha: &alpha,
            width: self.width,
            height: self.height,
            threshold: 0.5,
        };
        let spacing = f64::from(spacing.max(0.5));
        let mut rings = Vec::new();
        for ring in contour(&grid) {
            let n = ring.len();
            let mut out = Vec::new();
            let mut carry = 0.0;
            for k in 0..n {
                let (a, b) = (ring[k], ring[(k + 1) % n]);
                let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                let mut s = carry;
                while s < len {
                    let t = s / len;
                    out.push([(a[0] + t * (b[0] - a[0])) as f32, (a[1] + t * (b[1] - a[1])) as f32]);
                    s += spacing;
                }
                carry = s - len;
            }
            rings.push(out);
        }
        rings
    }

    /// The exact Euclidean distance from every pixel centre to the nearest covered pixel centre
    /// (0 on covered pixels; `f32::INFINITY` everywhere if nothing is covered).
    pub fn distance(&self) -> Vec<f32> {
        let (w, h) = (self.width as usize, self.height as usize);
        let big = 1e20f64;
        let mut d: Vec<f64> = self.inside.iter().map(|&i| if i { 0.0 } else { big }).collect();
        let mut column = vec![0.0; h];
        let mut out = vec![0.0; h.max(w)];
        for x in 0..w {
            for y in 0..h {
                column[y] = d[y * w + x];
            }
            squared_1d(&column, &mut out[..h]);
            for y in 0..h {
                d[y * w + x] = out[y];
            }
        }
        for y in 0..h {
            squared_1d(&d[y * w..(y + 1) * w], &mut out[..w]);
            d[y * w..(y + 1) * w].copy_from_slice(&out[..w]);
        }
        d.into_iter()
            .map(|v| if v >= big / 2.0 { f32::INFINITY } else { v.sqrt() as f32 })
            .collect()
    }

    /// The covered pixel centre nearest `p`, if one lies within `radius` pixels.
    pub fn nearest_inside(&self, p: [f32; 2], radius: f32) -> Option<[f32; 2]> {
        let r = radius.ceil() as i64;
        let (cx, cy) = (p[0].floor() as i64, p[1].floor() as i64);
        let mut best: Option<(f32, [f32; 2])> = None;
        for y in cy - r..=cy + r {
            for x in cx - r..=cx + r {
                if self.at(x, y) {
                    let c = [x as f32 + 0.5, y as f32 + 0.5];
                    let d = (c[0] - p[0]).hypot(c[1] - p[1]);
                    if d <= radius && best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, c));
                    }
                }
            }
        }
        best.map(|(_, c)| c)
    }
}

/// The 1D squared distance transform of `f` (the lower envelope of the parabolas
/// `(q − p)² + f[p]`), into `out`.
fn squared_1d(f: &[f64], out: &mut [f64]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let intersect = |q: usize, p: usize| ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f64; n + 1];
    let mut k = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let mut s = intersect(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = intersect(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    let mut k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        *o = (q as f64 - p as f64).powi(2) + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(w: u32, h: u32, c: [f32; 2], r: f32) -> Mask {
        let inside = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                (x - c[0]).hypot(y - c[1]) < r
            })
            .collect();
        Mask {
            width: w,
            height: h,
            inside,
        }
    }

    #[test]
    fn distance_is_exact_against_brute_force() {
        let mut m = disc(23, 17, [7.0, 6.0], 3.0);
        m.inside[16 * 23 + 20] = true;
        let d = m.distance();
        for (i, &di) in d.iter().enumerate() {
            let p = m.centre(i);
            let brute = (0..m.inside.len())
                .filter(|&j| m.inside[j])
                .map(|j| {
                    let q = m.centre(j);
                    (p[0] - q[0]).hypot(p[1] - q[1])
                })
                .fold(f32::INFINITY, f32::min);
            assert!((di - brute).abs() < 1e-4, "pixel {i}: {di} vs {brute}");
        }
        let empty = Mask {
            width: 3,
            height: 2,
            inside: vec![false; 6],
        };
        assert!(empty.distance().iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn pieces_outline_and_centroid() {
        let mut m = disc(40, 20, [10.0, 10.0], 5.0);
        let other = disc(40, 20, [30.0, 10.0], 4.0);
        m.inside.iter_mut().zip(&other.inside).for_each(|(a, b)| *a |= *b);
        let pieces = m.pieces();
        assert_eq!(pieces.len(), 2);
        let outline = m.outline(2.0);
        // Two circles of radius ~5 and ~4: circumference / spacing points each, roughly.
        assert!((20..=35).contains(&outline.len()), "{}", outline.len());
        assert!(outline
            .iter()
            .all(|p| ((p[0] - 10.0).hypot(p[1] - 10.0) - 5.0).abs() < 1.0 || ((p[0] - 30.0).hypot(p[1] - 10.0) - 4.0).abs() < 1.0));
        let c = disc(40, 20, [10.0, 10.0], 5.0).centroid().unwrap();
        assert!((c[0] - 10.0).abs() < 0.05 && (c[1] - 10.0).abs() < 0.05, "{c:?}");
        assert_eq!(m.nearest_inside([20.0, 10.0], 3.0), None);
        assert_eq!(m.nearest_inside([15.6, 10.1], 3.0), Some([14.5, 10.5]));
    }
}
