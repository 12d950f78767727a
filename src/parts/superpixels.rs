//! SLIC superpixels of a pose's foreground (Achanta et al. 2012; apes-part-extraction.md §3.2
//! "Voting pairs"): k-means in CIELAB colour and position, each centre searching a 2S × 2S
//! window, then every superpixel made one connected piece.

use super::pose::SheetPose;
use crate::geom::component_labels;

/// Marks a background pixel in [`Superpixels::labels`].
pub const NONE: u32 = u32::MAX;

/// SLIC's iterations (the paper of SLIC reports convergence within ten).
const ITERATIONS: usize = 10;

/// A pose cut into superpixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Superpixels {
    /// Row-major superpixel of each pixel, [`NONE`] on the background.
    pub labels: Vec<u32>,
    /// Number of superpixels; labels are `0..count`.
    pub count: usize,
    /// Pixel count of each superpixel.
    pub sizes: Vec<usize>,
    /// Centroid of each superpixel, pixels.
    pub centroids: Vec<[f32; 2]>,
}

/// CIELAB of an sRGB colour (D65), each channel in [0, 1].
fn lab(rgb: [f32; 3]) -> [f32; 3] {
    let linear = |c: f32| if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    let [r, g, b] = rgb.map(linear);
    let x = (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) / 0.950_47;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b;
    let z = (0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b) / 1.088_83;
    let f = |t: f32| if t > 0.008_856 { t.cbrt() } else { 7.787 * t + 16.0 / 116.0 };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Cuts the foreground of `pose` into about `target` superpixels with SLIC's `compactness`
/// (the weight of position against CIELAB colour; SLIC's usual 10). Every superpixel is one
/// 4-connected piece of at least a quarter of the nominal size `S²` unless the piece it lies in
/// is smaller. Deterministic.
pub fn slic(pose: &SheetPose, target: usize, compactness: f32) -> Superpixels {
    let (w, h) = (pose.width(), pose.height());
    let area = pose.area();
    if area == 0 {
        return finish(vec![NONE; w * h], w);
    }
    let step = ((area as f32 / target.max(1) as f32).sqrt()).max(1.0);
    let colours: Vec<[f32; 3]> = pose.image.pixels.iter().map(|p| lab([p[0], p[1], p[2]])).collect();
    // Seeds on a grid of step S over the foreground, each moved to the lowest colour gradient
    // of its 3 × 3 neighbourhood (SLIC: not on an edge).
    let gradient = |x: usize, y: usize| -> f32 {
        if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            return f32::INFINITY;
        }
        let d = |a: usize, b: usize| -> f32 { (0..3).map(|c| (colours[a][c] - colours[b][c]).powi(2)).sum() };
        d(y * w + x + 1, y * w + x - 1) + d((y + 1) * w + x, (y - 1) * w + x)
    };
    let mut centres: Vec<([f32; 3], [f32; 2])> = Vec::new();
    let half = step / 2.0;
    let mut gy = half;
    while gy < h as f32 {
        let mut gx = half;
        while gx < w as f32 {
            let (x0, y0) = (gx as usize, gy as usize);
            let mut best = None;
            for y in y0.saturating_sub(1)..=(y0 + 1).min(h - 1) {
                for x in x0.saturating_sub(1)..=(x0 + 1).min(w - 1) {
                    if pose.mask[y * w + x] {
                        let g = gradient(x, y);
                        if best.is_none_or(|(bg, _, _)| g < bg) {
                            best = Some((g, x, y));
                        }
                    }
                }
            }
            if let Some((_, x, y)) = best {
                centres.push((colours[y * w + x], [x as f32, y as f32]));
            }
            gx += step;
        }
        gy += step;
    }
    let mut labels = vec![NONE; w * h];
    let spatial = (compactness / step).powi(2);
    for _ in 0..ITERATIONS {
        let mut best = vec![f32::INFINITY; w * h];
        for (k, (c, p)) in centres.iter().enumerate() {
            let x0 = (p[0] - step).max(0.0) as usize;
            let y0 = (p[1] - step).max(0.0) as usize;
            let x1 = ((p[0] + step) as usize).min(w - 1);
            let y1 = ((p[1] + step) as usize).min(h - 1);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let i = y * w + x;
                    if !pose.mask[i] {
                        continue;
                    }
                    let dc: f32 = (0..3).map(|j| (colours[i][j] - c[j]).powi(2)).sum();
                    let ds = (x as f32 - p[0]).powi(2) + (y as f32 - p[1]).powi(2);
                    let d = dc + ds * spatial;
                    if d < best[i] {
                        best[i] = d;
                        labels[i] = k as u32;
                    }
                }
            }
        }
        let mut sums = vec![([0.0f32; 3], [0.0f32; 2], 0usize); centres.len()];
        for (i, &l) in labels.iter().enumerate() {
            if l != NONE {
                let s = &mut sums[l as usize];
                for (sum, c) in s.0.iter_mut().zip(colours[i]) {
                    *sum += c;
                }
                s.1[0] += (i % w) as f32;
                s.1[1] += (i / w) as f32;
                s.2 += 1;
            }
        }
        for (centre, (c, p, n)) in centres.iter_mut().zip(sums) {
            if n > 0 {
                let n = n as f32;
                *centre = (c.map(|v| v / n), [p[0] / n, p[1] / n]);
            }
        }
    }
    // Foreground no window reached (thin pieces far from every seed) joins its neighbours below.
    let min_size = ((step * step) / 4.0).max(1.0) as usize;
    enforce_connectivity(&mut labels, &pose.mask, w, min_size);
    finish(labels, w)
}

/// Splits every label into its 4-connected pieces, then merges each piece smaller than
/// `min_size` (and each unlabelled foreground piece) into the neighbouring piece it shares the
/// longest border with, smallest pieces first; an isolated piece stays on its own.
fn enforce_connectivity(labels: &mut [u32], mask: &[bool], w: usize, min_size: usize) {
    let n = labels.len();
    let mut edges = Vec::new();
    for i in 0..n {
        if !mask[i] {
            continue;
        }
        for j in [(i % w + 1 < w).then(|| i + 1), (i + w < n).then(|| i + w)].into_iter().flatten() {
            if mask[j] && labels[i] == labels[j] {
                edges.push((i, j));
            }
        }
    }
    let (piece, count) = component_labels(n, edges);
    let mut size = vec![0usize; count];
    for i in (0..n).filter(|&i| mask[i]) {
        size[piece[i]] += 1;
    }
    // Border lengths between pieces.
    let mut border: std::collections::BTreeMap<(usize, usize), usize> = std::collections::BTreeMap::new();
    for i in (0..n).filter(|&i| mask[i]) {
        for j in [(i % w + 1 < w).then(|| i + 1), (i + w < n).then(|| i + w)].into_iter().flatten() {
            if mask[j] && piece[i] != piece[j] {
                let key = (piece[i].min(piece[j]), piece[i].max(piece[j]));
                *border.entry(key).or_default() += 1;
            }
        }
    }
    let mut unlabelled = vec![false; count];
    for i in (0..n).filter(|&i| mask[i] && labels[i] == NONE) {
        unlabelled[piece[i]] = true;
    }
    let mut target: Vec<usize> = (0..count).collect();
    let find = |target: &mut Vec<usize>, mut p: usize| {
        while target[p] != p {
            target[p] = target[target[p]];
            p = target[p];
        }
        p
    };
    let mut order: Vec<usize> = (0..count).filter(|&p| size[p] > 0).collect();
    order.sort_by_key(|&p| (size[p], p));
    let mut merged_size = size.clone();
    for p in order {
        let root = find(&mut target, p);
        if root != p || (merged_size[p] >= min_size && !unlabelled[p]) {
            continue;
        }
        let mut best: Option<(usize, usize)> = None;
        let mut lengths: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
        for (&(a, b), &len) in &border {
            let (ra, rb) = (find(&mut target, a), find(&mut target, b));
            let other = if ra == p && rb != p {
                rb
            } else if rb == p && ra != p {
                ra
            } else {
                continue;
            };
            *lengths.entry(other).or_default() += len;
        }
        for (&other, &len) in &lengths {
            if best.is_none_or(|(_, l)| len > l) {
                best = Some((other, len));
            }
        }
        if let Some((other, _)) = best {
            target[p] = other;
            merged_size[other] += merged_size[p];
            unlabelled[p] = false;
        }
    }
    for i in (0..n).filter(|&i| mask[i]) {
        labels[i] = find(&mut target, piece[i]) as u32;
    }
}

/// Renumbers labels `0..count` in order of first appearance and measures them.
fn finish(mut labels: Vec<u32>, w: usize) -> Superpixels {
    let mut renumber = std::collections::HashMap::new();
    for l in labels.iter_mut().filter(|l| **l != NONE) {
        let next = renumber.len() as u32;
        *l = *renumber.entry(*l).or_insert(next);
    }
    let count = renumber.len();
    let mut sizes = vec![0usize; count];
    let mut sums = vec![[0.0f64; 2]; count];
    for (i, &l) in labels.iter().enumerate().filter(|(_, l)| **l != NONE) {
        sizes[l as usize] += 1;
        sums[l as usize][0] += (i % w) as f64;
        sums[l as usize][1] += (i / w) as f64;
    }
    let centroids = sums
        .iter()
        .zip(&sizes)
        .map(|(s, &n)| [(s[0] / n as f64) as f32, (s[1] / n as f64) as f32])
        .collect();
    Superpixels {
        labels,
        count,
        sizes,
        centroids,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::picture::Picture;

    fn two_colour_pose() -> SheetPose {
        // A 60 × 40 rectangle, red on the left half and blue on the right, on transparency.
        let mut image = Picture::filled(80, 60, [0.0; 4]);
        for y in 10..50 {
            for x in 10..70 {
                image.pixels[y * 80 + x] = if x < 40 { [0.9, 0.1, 0.1, 1.0] } else { [0.1, 0.1, 0.9, 1.0] };
            }
        }
        SheetPose::new("test", image)
    }

    #[test]
    fn superpixels_cover_the_foreground_in_connected_pieces_that_respect_colour_edges() {
        let pose = two_colour_pose();
        let sp = slic(&pose, 24, 10.0);
        assert!((12..=36).contains(&sp.count), "{} superpixels for a target of 24", sp.count);
        for (i, &l) in sp.labels.iter().enumerate() {
            assert_eq!(l != NONE, pose.mask[i], "pixel {i}");
        }
        assert_eq!(sp.sizes.iter().sum::<usize>(), pose.area());
        // No superpixel straddles the colour edge.
        for k in 0..sp.count as u32 {
            let xs: Vec<usize> = (0..sp.labels.len()).filter(|&i| sp.labels[i] == k).map(|i| i % 80).collect();
            assert!(
                xs.iter().all(|&x| x < 40) || xs.iter().all(|&x| x >= 40),
                "superpixel {k} straddles the edge"
            );
        }
        // Each is one 4-connected piece.
        for k in 0..sp.count as u32 {
            let inside: Vec<usize> = (0..sp.labels.len()).filter(|&i| sp.labels[i] == k).collect();
            let index: std::collections::HashMap<usize, usize> = inside.iter().enumerate().map(|(a, &i)| (i, a)).collect();
            let edges = inside.iter().flat_map(|&i| {
                [i + 1, i + 80]
                    .into_iter()
                    .filter_map(|j| index.get(&j).map(|&b| (index[&i], b)))
                    .collect::<Vec<_>>()
            });
            let (_, pieces) = component_labels(inside.len(), edges);
            assert_eq!(pieces, 1, "superpixel {k} is in {pieces} pieces");
        }
    }

    #[test]
    fn an_empty_pose_has_no_superpixels() {
        let pose = SheetPose::new("empty", Picture::filled(16, 16, [0.0; 4]));
        assert_eq!(slic(&pose, 10, 10.0).count, 0);
    }
}
