//! Boundary tracing for layer meshing (neural-puppet.md §3.1, first step of "standard
//! triangulation"): marching squares on the alpha grid at the threshold, sub-pixel.
//!
//! Samples sit at pixel centres `(x + 0.5, y + 0.5)`; the grid is padded by one transparent
//! sample on every side, so parts touching the image border close. A crossing on a cell edge is
//! placed by linear interpolation of alpha between the two centres. Saddle cells (two diagonal
//! corners inside) are resolved by the mean of the four corners: above the threshold the inside
//! corners connect. Each crossing belongs to exactly one ring, so rings never touch.

/// An alpha image and its threshold: the region to trace.
#[derive(Clone, Copy, Debug)]
pub struct AlphaGrid<'a> {
    /// Row-major alpha, `width * height` values.
    pub alpha: &'a [f32],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// A pixel is inside when its alpha is strictly above this.
    pub threshold: f32,
}

impl AlphaGrid<'_> {
    /// Alpha of pixel `(x, y)`, 0 outside the image (the padding).
    pub fn value(&self, x: i64, y: i64) -> f32 {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            0.0
        } else {
            self.alpha[(y as usize) * self.width as usize + x as usize]
        }
    }

    /// Whether pixel `(x, y)` is inside the part (false outside the image).
    pub fn inside(&self, x: i64, y: i64) -> bool {
        self.value(x, y) > self.threshold
    }
}

/// Crossings closer than this fraction of a pixel to a sample are moved away from it, so that no
/// two crossings coincide.
const CROSSING_CLAMP: f32 = 1e-3;

/// Traces every boundary of `{alpha > threshold}`: outer boundaries (positive shoelace area) and
/// holes (negative), in pixel coordinates, each ring without its closing point.
///
/// The part lies where `cross(b - a, p - a) > 0` for each ring edge `a → b`; every inside pixel
/// centre is strictly inside the rings (even-odd), every outside one strictly outside. The order
/// of rings and of their points is deterministic (row-major order of the first crossing).
pub fn contour(grid: &AlphaGrid) -> Vec<Vec<[f64; 2]>> {
    // Padded sample grid: sample (i, j) is pixel (i - 1, j - 1), at (i - 0.5, j - 0.5).
    let gw = grid.width as usize + 2;
    let gh = grid.height as usize + 2;
    let sample = |i: usize, j: usize| grid.value(i as i64 - 1, j as i64 - 1);
    // The inside test once per sample, padded, so the cell loop only reads a byte per corner.
    let mut mask = vec![false; gw * gh];
    for y in 0..grid.height as usize {
        let row = &grid.alpha[y * grid.width as usize..(y + 1) * grid.width as usize];
        for (x, &a) in row.iter().enumerate() {
            mask[(y + 1) * gw + x + 1] = a > grid.threshold;
        }
    }
    let inside = |i: usize, j: usize| mask[j * gw + i];
    // Edge ids: horizontal edge from sample (i, j) to (i + 1, j) is 2 (j gw + i), vertical edge
    // from (i, j) to (i, j + 1) is 2 (j gw + i) + 1.
    let h = |i: usize, j: usize| 2 * (j * gw + i);
    let v = |i: usize, j: usize| 2 * (j * gw + i) + 1;
    // Links (from edge, to edge), one per crossing segment; cells are visited in row-major
    // order, so sorting by `from` only reorders within the few links of neighbouring cells.
    let mut links: Vec<(usize, usize)> = Vec::new();
    for j in 0..gh - 1 {
        for i in 0..gw - 1 {
            // Corners in cyclic order TL, TR, BR, BL; edge k runs from corner k to corner k + 1.
            let corners = [inside(i, j), inside(i + 1, j), inside(i + 1, j + 1), inside(i, j + 1)];
            if corners == [corners[0]; 4] {
                continue;
            }
            let case = corners.iter().enumerate().fold(0, |c, (k, &b)| c | (usize::from(b) << k));
            if case == 0 || case == 15 {
                continue;
            }
            let edges = [h(i, j), v(i + 1, j), h(i, j + 1), v(i, j)];
            let mut link = |from: usize, to: usize| links.push((edges[from], edges[to]));
            let saddle = case == 5 || case == 10;
            let connected = saddle && {
                let mean = (sample(i, j) + sample(i + 1, j) + sample(i + 1, j + 1) + sample(i, j + 1)) / 4.0;
                mean > grid.threshold
            };
            // For a run of inside corners k..=l (cyclic), the crossing goes from the edge after
            // the run (edge l) to the edge before it (edge k - 1); with the inside corners
            // connected through the centre, the runs of *outside* corners are cut off instead,
            // from the edge before the run to the edge after it.
            let runs_of = !connected;
            for k in 0..4 {
                let prev = (k + 3) % 4;
                if corners[k] == runs_of && corners[prev] != runs_of {
                    let mut l = k;
                    while corners[(l + 1) % 4] == runs_of {
                        l = (l + 1) % 4;
                    }
                    if runs_of {
                        link(l, prev);
                    } else {
                        link(prev, l);
                    }
                }
            }
        }
    }
    let point = |e: usize| -> [f64; 2] {
        let cell = e / 2;
        let (i, j) = (cell % gw, cell / gw);
        let (i1, j1) = if e.is_multiple_of(2) { (i + 1, j) } else { (i, j + 1) };
        let (a0, a1) = (sample(i, j), sample(i1, j1));
        let t = ((grid.threshold - a0) / (a1 - a0)).clamp(CROSSING_CLAMP, 1.0 - CROSSING_CLAMP);
        let t = f64::from(t);
        [
            i as f64 - 0.5 + t * (i1 as f64 - i as f64),
            j as f64 - 0.5 + t * (j1 as f64 - j as f64),
        ]
    };
    links.sort_unstable();
    let mut used = vec![false; links.len()];
    let mut rings = Vec::new();
    for first in 0..links.len() {
        if used[first] {
            continue;
        }
        let mut ring = Vec::new();
        let mut k = first;
        // Every crossing has exactly one outgoing and one incoming link, so this closes.
        while !used[k] {
            used[k] = true;
            ring.push(point(links[k].0));
            let to = links[k].1;
            match links.binary_search_by_key(&to, |l| l.0) {
                Ok(n) => k = n,
                Err(_) => break,
            }
        }
        rings.push(ring);
    }
    rings
}

/// Shoelace area of a closed ring: positive for outer boundaries, negative for holes.
pub fn signed_area(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    0.5 * (0..n)
        .map(|k| {
            let (a, b) = (ring[k], ring[(k + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
}

/// Even-odd point-in-polygon test over several rings.
pub fn inside_rings(rings: &[Vec<[f64; 2]>], p: [f64; 2]) -> bool {
    let mut inside = false;
    for ring in rings {
        let n = ring.len();
        for k in 0..n {
            let (a, b) = (ring[k], ring[(k + 1) % n]);
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if p[0] < x {
                    inside = !inside;
                }
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_of(rows: &[&str]) -> (Vec<f32>, u32, u32) {
        let (w, h) = (rows[0].len() as u32, rows.len() as u32);
        let alpha = rows
            .iter()
            .flat_map(|r| r.bytes().map(|b| if b == b'#' { 1.0 } else { 0.0 }))
            .collect();
        (alpha, w, h)
    }

    fn check_separates(rows: &[&str]) -> Vec<Vec<[f64; 2]>> {
        let (alpha, width, height) = grid_of(rows);
        let grid = AlphaGrid {
            alpha: &alpha,
            width,
            height,
            threshold: 0.5,
        };
        let rings = contour(&grid);
        for y in -1..=height as i64 {
            for x in -1..=width as i64 {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                assert_eq!(inside_rings(&rings, p), grid.inside(x, y), "pixel ({x}, {y}) in {rows:?}");
            }
        }
        rings
    }

    #[test]
    fn single_pixel_is_a_diamond_with_positive_area() {
        let rings = check_separates(&["#"]);
        assert_eq!(rings.len(), 1);
        assert_eq!(rings[0].len(), 4);
        assert!((signed_area(&rings[0]) - 0.5).abs() < 1e-9);
    }

    #[test]
    fn hole_is_negative_and_border_parts_close() {
        let rings = check_separates(&["###", "#.#", "###"]);
        assert_eq!(rings.len(), 2);
        let areas: Vec<f64> = rings.iter().map(|r| signed_area(r)).collect();
        assert!(areas.iter().any(|&a| a > 0.0) && areas.iter().any(|&a| a < 0.0), "{areas:?}");
    }

    #[test]
    fn orientation_puts_the_part_on_the_positive_side() {
        let rings = check_separates(&["....", ".##.", ".##.", "...."]);
        let r = &rings[0];
        // Nudge each edge midpoint to its positive side: must be inside.
        for k in 0..r.len() {
            let (a, b) = (r[k], r[(k + 1) % r.len()]);
            let m = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
            let normal = [-(b[1] - a[1]), b[0] - a[0]];
            let p = [m[0] + 0.01 * normal[0], m[1] + 0.01 * normal[1]];
            assert!(inside_rings(&rings, p), "edge {k}");
        }
    }

    #[test]
    fn saddles_are_deterministic_and_separate_correctly() {
        // Binary saddles have mean 0.5, not above 0.5: diagonal pixels stay apart.
        let rings = check_separates(&["#.", ".#"]);
        assert_eq!(rings.len(), 2);
        let rings2 = check_separates(&[".#", "#."]);
        assert_eq!(rings2.len(), 2);
        // A brighter saddle connects.
        let alpha = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let grid = AlphaGrid {
            alpha: &alpha,
            width: 3,
            height: 3,
            threshold: 0.2,
        };
        assert_eq!(contour(&grid).len(), 1);
        assert_eq!(contour(&grid), contour(&grid));
    }

    #[test]
    fn random_masks_separate_inside_from_outside() {
        let mut state = 12345u64;
        for _ in 0..20 {
            let rows: Vec<String> = (0..9)
                .map(|_| {
                    (0..11)
                        .map(|_| {
                            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                            if (state >> 33).is_multiple_of(2) {
                                '#'
                            } else {
                                '.'
                            }
                        })
                        .collect()
                })
                .collect();
            let refs: Vec<&str> = rows.iter().map(|s| s.as_str()).collect();
            check_separates(&refs);
        }
    }

    #[test]
    fn crossings_interpolate_alpha() {
        // One row: alpha 1 then 0.25; threshold 0.5 crosses 2/3 of the way between centres.
        let alpha = [1.0, 0.25];
        let grid = AlphaGrid {
            alpha: &alpha,
            width: 2,
            height: 1,
            threshold: 0.5,
        };
        let rings = contour(&grid);
        let max_x = rings[0].iter().map(|p| p[0]).fold(f64::MIN, f64::max);
        assert!((max_x - (0.5 + 2.0 / 3.0)).abs() < 1e-6, "{max_x}");
    }
}
