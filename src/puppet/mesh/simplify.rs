//! Boundary simplification for layer meshing (neural-puppet.md §3.1): Douglas–Peucker on closed
//! rings, restricted so that no inside pixel centre is uncovered and no ring crosses itself or
//! another ring.
//!
//! A chord `a → b` may replace a stretch of ring when every dropped point lies within the
//! tolerance of it *and* no inside pixel centre lies within that distance of the chord on its
//! outer side (or closer than [`COVER_MARGIN`] on its inner side). Whatever a chord removes from
//! the part lies on its outer side within the tolerance, so inside centres stay inside. Chords
//! that cross are split again (at their farthest dropped point) until no two ring edges meet.

use super::contour::{signed_area, AlphaGrid};
use super::MIN_RING_AREA;

/// Inside pixel centres are kept at least this far (px) inside every simplified edge.
pub const COVER_MARGIN: f64 = 0.05;

/// Simplifies traced rings (see [`super::contour::contour`]) with tolerance `tolerance` px,
/// dropping traced rings whose area is below [`MIN_RING_AREA`] px² and holes that collapse.
///
/// Every inside pixel centre of `grid` that was inside a kept ring stays inside, at least
/// [`COVER_MARGIN`] from every new chord (traced edges that are kept stay where they were); rings keep their orientation, at least 3 points each, and
/// no two edges of the result touch except consecutive ones at their shared point. A kept point
/// whose interior angle (on the part's side) is below `min_vertex_angle` degrees gets its
/// neighbouring traced points back until the angle is at least that or both its edges are
/// traced edges: refinement cannot widen an input angle, so simplification must not sharpen one.
pub fn simplify(rings: &[Vec<[f64; 2]>], grid: &AlphaGrid, tolerance: f64, min_vertex_angle: f64) -> Vec<Vec<[f64; 2]>> {
    let rings: Vec<&Vec<[f64; 2]>> = rings.iter().filter(|r| signed_area(r).abs() >= MIN_RING_AREA).collect();
    let mut keep: Vec<Vec<bool>> = rings
        .iter()
        .map(|ring| {
            let mut keep = vec![false; ring.len()];
            let n = ring.len();
            // Anchors: point 0 and the point farthest from it.
            let far = (0..n)
                .max_by(|&a, &b| dist2(ring[0], ring[a]).total_cmp(&dist2(ring[0], ring[b])))
                .unwrap_or(0);
            keep[0] = true;
            keep[far] = true;
            douglas_peucker(ring, 0, far, grid, tolerance, &mut keep);
            douglas_peucker(ring, far, n, grid, tolerance, &mut keep);
            keep
        })
        .collect();
    // Split crossing chords, then chords meeting at a sharper angle than the traced contour
    // had, until neither is left; terminates because the traced rings are simple and every
    // split keeps one more traced point.
    loop {
        let mut offenders = crossing_chords(&rings, &keep);
        if offenders.is_empty() {
            offenders = sharp_chords(&rings, &keep, min_vertex_angle);
        }
        if offenders.is_empty() {
            break;
        }
        for (r, i, j) in offenders {
            let m = farthest(rings[r], i, j).0;
            keep[r][m % rings[r].len()] = true;
            douglas_peucker(rings[r], i, m, grid, tolerance, &mut keep[r]);
            douglas_peucker(rings[r], m, j, grid, tolerance, &mut keep[r]);
        }
    }
    rings
        .iter()
        .zip(&keep)
        .map(|(ring, keep)| ring.iter().zip(keep).filter(|(_, &k)| k).map(|(p, _)| *p).collect::<Vec<_>>())
        // Only collapsed rings go (holes filled by chords); a kept ring may end below
        // MIN_RING_AREA (a one-pixel-wide line thins to its centres) and must stay.
        .filter(|r| r.len() >= 3 && signed_area(r) != 0.0)
        .collect()
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Distance from `p` to segment `a b`.
pub(super) fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist2(p, [a[0] + t * d[0], a[1] + t * d[1]]).sqrt()
}

/// The dropped point of stretch `i..j` (indices mod ring length) farthest from chord `i → j`.
fn farthest(ring: &[[f64; 2]], i: usize, j: usize) -> (usize, f64) {
    let n = ring.len();
    let (a, b) = (ring[i % n], ring[j % n]);
    (i + 1..j)
        .map(|k| (k, segment_distance(ring[k % n], a, b)))
        .fold((i + 1, -1.0), |best, c| if c.1 > best.1 { c } else { best })
}

/// Douglas–Peucker on the stretch `i..=j` of a closed ring (`j` may equal `ring.len()`, meaning
/// point 0), marking kept points in `keep`; chords must also pass [`chord_covers`].
fn douglas_peucker(ring: &[[f64; 2]], i: usize, j: usize, grid: &AlphaGrid, tolerance: f64, keep: &mut [bool]) {
    let n = ring.len();
    let mut stack = vec![(i, j)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (m, d) = farthest(ring, i, j);
        if d <= tolerance && chord_covers(ring[i % n], ring[j % n], grid, tolerance) {
            continue;
        }
        keep[m % n] = true;
        stack.push((i, m));
        stack.push((m, j));
    }
}

/// Whether chord `a → b` keeps every inside pixel centre near it on its inner side, at least
/// [`COVER_MARGIN`] away: checks the centres within `tolerance + COVER_MARGIN` of the chord.
fn chord_covers(a: [f64; 2], b: [f64; 2], grid: &AlphaGrid, tolerance: f64) -> bool {
    let reach = tolerance + COVER_MARGIN;
    let d = [b[0] - a[0], b[1] - a[1]];
    let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if len == 0.0 {
        return false;
    }
    let x0 = (a[0].min(b[0]) - reach - 0.5).floor() as i64;
    let x1 = (a[0].max(b[0]) + reach - 0.5).ceil() as i64;
    let y0 = (a[1].min(b[1]) - reach - 0.5).floor() as i64;
    let y1 = (a[1].max(b[1]) + reach - 0.5).ceil() as i64;
    for y in y0..=y1 {
        for x in x0..=x1 {
            if !grid.inside(x, y) {
                continue;
            }
            let p = [x as f64 + 0.5, y as f64 + 0.5];
            let side = (d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) / len;
            if side < COVER_MARGIN && segment_distance(p, a, b) <= reach {
                return false;
            }
        }
    }
    true
}

/// Chords `(ring, i, j)` (kept points `i` and next kept `j`, `j` possibly past the end) that
/// touch another chord, found with a uniform grid over the chords' bounding boxes.
fn crossing_chords(rings: &[&Vec<[f64; 2]>], keep: &[Vec<bool>]) -> Vec<(usize, usize, usize)> {
    // Chords as (ring, i, j, a, b, position in the ring's kept list, kept count).
    let mut chords = Vec::new();
    for (r, (ring, keep)) in rings.iter().zip(keep).enumerate() {
        let kept: Vec<usize> = (0..ring.len()).filter(|&k| keep[k]).collect();
        for (c, &i) in kept.iter().enumerate() {
            let j = kept.get(c + 1).copied().unwrap_or(kept[0] + ring.len());
            chords.push((r, i, j, ring[i], ring[j % ring.len()], c, kept.len()));
        }
    }
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for c in &chords {
        for p in [c.3, c.4] {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let cell = 8.0;
    let cols = (((hi[0] - lo[0]) / cell) as usize + 1).min(4096);
    let rows = (((hi[1] - lo[1]) / cell) as usize + 1).min(4096);
    let cell_of = |p: f64, k: usize, count: usize| (((p - lo[k]) / cell) as usize).min(count - 1);
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); cols * rows];
    for (c, chord) in chords.iter().enumerate() {
        let (a, b) = (chord.3, chord.4);
        for y in cell_of(a[1].min(b[1]), 1, rows)..=cell_of(a[1].max(b[1]), 1, rows) {
            for x in cell_of(a[0].min(b[0]), 0, cols)..=cell_of(a[0].max(b[0]), 0, cols) {
                buckets[y * cols + x].push(c);
            }
        }
    }
    let mut bad = vec![false; chords.len()];
    for bucket in &buckets {
        for (s, &c1) in bucket.iter().enumerate() {
            for &c2 in &bucket[s + 1..] {
                let (p, q) = (&chords[c1], &chords[c2]);
                let consecutive = if p.0 != q.0 {
                    None
                } else if (p.5 + 1) % p.6 == q.5 {
                    Some((p, q))
                } else if (q.5 + 1) % q.6 == p.5 {
                    Some((q, p))
                } else {
                    None
                };
                let hit = match consecutive {
                    // Consecutive chords share a point: they only conflict by folding back (a
                    // ring of two chords always does).
                    Some((f, s)) => {
                        let (u, v) = ([f.4[0] - f.3[0], f.4[1] - f.3[1]], [s.4[0] - s.3[0], s.4[1] - s.3[1]]);
                        p.6 < 3 || (u[0] * v[1] - u[1] * v[0] == 0.0 && u[0] * v[0] + u[1] * v[1] < 0.0)
                    }
                    None => segments_touch(p.3, p.4, q.3, q.4),
                };
                if hit {
                    bad[c1] = true;
                    bad[c2] = true;
                }
            }
        }
    }
    chords
        .iter()
        .zip(&bad)
        .filter(|(c, &b)| b && c.2 > c.1 + 1)
        .map(|(c, _)| (c.0, c.1, c.2))
        .collect()
}

/// Chords `(ring, i, j)` on either side of a kept point whose interior angle is below
/// `min_angle` degrees (rings have the part on their positive side), when they can be split.
fn sharp_chords(rings: &[&Vec<[f64; 2]>], keep: &[Vec<bool>], min_angle: f64) -> Vec<(usize, usize, usize)> {
    let mut out = Vec::new();
    for (r, (ring, keep)) in rings.iter().zip(keep).enumerate() {
        let n = ring.len();
        let kept: Vec<usize> = (0..n).filter(|&k| keep[k]).collect();
        let m = kept.len();
        if m < 3 {
            continue;
        }
        // Chord c runs from kept[c] to kept[c + 1] (past the end: kept[0] + n).
        let chord = |c: usize| (kept[c], if c + 1 < m { kept[c + 1] } else { kept[0] + n });
        for c in 0..m {
            let (i, v) = chord((c + m - 1) % m);
            let (_, w) = chord(c);
            let (pu, pv, pw) = (ring[i % n], ring[v % n], ring[w % n]);
            let (d1, d2) = ([pv[0] - pu[0], pv[1] - pu[1]], [pw[0] - pv[0], pw[1] - pv[1]]);
            let turn = (d1[0] * d2[1] - d1[1] * d2[0]).atan2(d1[0] * d2[0] + d1[1] * d2[1]);
            let interior = 180.0 - turn.to_degrees();
            if interior < min_angle {
                for (a, b) in [chord((c + m - 1) % m), chord(c)] {
                    if b > a + 1 && !out.contains(&(r, a, b)) {
                        out.push((r, a, b));
                    }
                }
            }
        }
    }
    out
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether closed segments `p1 p2` and `q1 q2` share any point.
fn segments_touch(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let (d1, d2) = (orient(q1, q2, p1), orient(q1, q2, p2));
    let (d3, d4) = (orient(p1, p2, q1), orient(p1, p2, q2));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |a: [f64; 2], b: [f64; 2], p: [f64; 2], o: f64| {
        o == 0.0 && p[0] >= a[0].min(b[0]) && p[0] <= a[0].max(b[0]) && p[1] >= a[1].min(b[1]) && p[1] <= a[1].max(b[1])
    };
    on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4)
}

#[cfg(test)]
mod tests {
    use super::super::contour::{contour, inside_rings};
    use super::*;

    /// Seeded blobby alpha images (sums of Gaussian bumps), 48×48.
    fn blobs(seed: u64) -> Vec<f32> {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        let bumps: Vec<[f32; 3]> = (0..5)
            .map(|_| [6.0 + 36.0 * next(), 6.0 + 36.0 * next(), 2.0 + 5.0 * next()])
            .collect();
        (0..48 * 48)
            .map(|i| {
                let (x, y) = ((i % 48) as f32 + 0.5, (i / 48) as f32 + 0.5);
                let s: f32 = bumps
                    .iter()
                    .map(|b| (-((x - b[0]).powi(2) + (y - b[1]).powi(2)) / (2.0 * b[2] * b[2])).exp())
                    .sum();
                (0.5 + 3.0 * (s - 0.5)).clamp(0.0, 1.0)
            })
            .collect()
    }

    #[test]
    fn simplified_rings_cover_inside_centres_and_never_touch() {
        for seed in 0..12u64 {
            let alpha = blobs(seed);
            let grid = AlphaGrid {
                alpha: &alpha,
                width: 48,
                height: 48,
                threshold: 0.5,
            };
            let traced = contour(&grid);
            for tolerance in [0.5, 1.0, 2.0] {
                let rings = simplify(&traced, &grid, tolerance, 45.0);
                let (before, after) = (
                    traced.iter().map(Vec::len).sum::<usize>(),
                    rings.iter().map(Vec::len).sum::<usize>(),
                );
                assert!(after < before, "seed {seed}: nothing simplified ({before} points)");
                let big: Vec<Vec<[f64; 2]>> = traced.iter().filter(|r| signed_area(r).abs() >= MIN_RING_AREA).cloned().collect();
                for y in 0..48 {
                    for x in 0..48 {
                        let p = [x as f64 + 0.5, y as f64 + 0.5];
                        if grid.inside(x, y) && inside_rings(&big, p) {
                            assert!(inside_rings(&rings, p), "seed {seed} tol {tolerance}: ({x}, {y}) uncovered");
                            let gap = |rings: &[Vec<[f64; 2]>]| {
                                rings
                                    .iter()
                                    .flat_map(|r| (0..r.len()).map(move |k| segment_distance(p, r[k], r[(k + 1) % r.len()])))
                                    .fold(f64::MAX, f64::min)
                            };
                            // Kept traced edges may be closer than the margin (alpha just above
                            // the threshold); chords never are.
                            let (now, was) = (gap(&rings), gap(&big));
                            assert!(
                                now >= COVER_MARGIN.min(was) - 1e-9,
                                "seed {seed}: ({x}, {y}) only {now} px inside (was {was})"
                            );
                        }
                    }
                }
                let edges: Vec<(usize, usize, [f64; 2], [f64; 2])> = rings
                    .iter()
                    .enumerate()
                    .flat_map(|(r, ring)| (0..ring.len()).map(move |k| (r, k, ring[k], ring[(k + 1) % ring.len()])))
                    .collect();
                for (s, e) in edges.iter().enumerate() {
                    for f in &edges[s + 1..] {
                        let n = rings[e.0].len();
                        let adjacent = e.0 == f.0 && ((e.1 + 1) % n == f.1 || (f.1 + 1) % n == e.1);
                        assert!(
                            adjacent || !segments_touch(e.2, e.3, f.2, f.3),
                            "seed {seed}: edges {e:?} and {f:?} touch"
                        );
                    }
                }
                for r in &rings {
                    assert!(r.len() >= 3 && signed_area(r) != 0.0);
                }
            }
        }
    }

    #[test]
    fn specks_are_dropped_and_zero_tolerance_only_removes_collinear_points() {
        let mut alpha = vec![0.0; 20 * 20];
        for y in 4..14 {
            for x in 4..14 {
                alpha[y * 20 + x] = 1.0;
            }
        }
        alpha[18 * 20 + 18] = 1.0; // a one-pixel speck: 0.5 px² diamond
        let grid = AlphaGrid {
            alpha: &alpha,
            width: 20,
            height: 20,
            threshold: 0.5,
        };
        let traced = contour(&grid);
        assert_eq!(traced.len(), 2);
        let rings = simplify(&traced, &grid, 0.0, 45.0);
        assert_eq!(rings.len(), 1);
        // The block's contour is an octagon: four sides and four 45° corner cuts.
        assert_eq!(rings[0].len(), 8, "{:?}", rings[0]);
        assert!((signed_area(&rings[0]) - signed_area(&traced[0])).abs() < 1e-9);
    }
}
