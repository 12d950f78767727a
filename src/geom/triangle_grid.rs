//! A soup of triangles bucketed on a uniform grid, for exact point queries against their union:
//! is a point covered, and if not, how far is it from the nearest triangle.

use super::triangle::{closest_on_segment, contains};

/// Triangles (corner positions) and, per grid cell, the triangles whose bounding boxes meet it.
pub struct TriangleGrid {
    triangles: Vec<[[f32; 2]; 3]>,
    origin: [f32; 2],
    cell: f32,
    columns: usize,
    rows: usize,
    cells: Vec<Vec<u32>>,
}

impl TriangleGrid {
    /// Buckets `triangles` on cells of `cell` units (at least 1e-3).
    pub fn new(triangles: Vec<[[f32; 2]; 3]>, cell: f32) -> Self {
        let cell = cell.max(1e-3);
        let finite: Vec<[f32; 2]> = triangles
            .iter()
            .flatten()
            .copied()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
            .collect();
        let lo = finite.iter().fold([f32::INFINITY; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
        let hi = finite.iter().fold([f32::NEG_INFINITY; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
        if finite.is_empty() {
            return TriangleGrid {
                triangles: Vec::new(),
                origin: [0.0; 2],
                cell,
                columns: 0,
                rows: 0,
                cells: Vec::new(),
            };
        }
        // Far-flung corners of a broken pose must not make the grid huge: 4096 cells a side at most.
        let cell = cell.max((hi[0] - lo[0]).max(hi[1] - lo[1]) / 4096.0);
        let columns = ((hi[0] - lo[0]) / cell) as usize + 1;
        let rows = ((hi[1] - lo[1]) / cell) as usize + 1;
        let mut grid = TriangleGrid {
            triangles: Vec::with_capacity(triangles.len()),
            origin: lo,
            cell,
            columns,
            rows,
            cells: vec![Vec::new(); columns * rows],
        };
        for t in triangles {
            if t.iter().flatten().any(|x| !x.is_finite()) {
                continue;
            }
            let k = grid.triangles.len() as u32;
            let [c0, r0] = grid.cell_of([t[0][0].min(t[1][0]).min(t[2][0]), t[0][1].min(t[1][1]).min(t[2][1])]);
            let [c1, r1] = grid.cell_of([t[0][0].max(t[1][0]).max(t[2][0]), t[0][1].max(t[1][1]).max(t[2][1])]);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    grid.cells[r * columns + c].push(k);
                }
            }
            grid.triangles.push(t);
        }
        grid
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell_of(&self, p: [f32; 2]) -> [usize; 2] {
        let at = |x: f32, o: f32, n: usize| (((x - o) / self.cell).floor().max(0.0) as usize).min(n - 1);
        [at(p[0], self.origin[0], self.columns), at(p[1], self.origin[1], self.rows)]
    }

    /// Whether `p` lies in one of the triangles (edges included).
    pub fn covers(&self, p: [f32; 2]) -> bool {
        self.holding(p).is_some()
    }

    /// A triangle holding `p` (edges included), as its index among the finite triangles given
    /// to [`TriangleGrid::new`] (their order; all of them for a mesh's triangles at rest).
    pub fn holding(&self, p: [f32; 2]) -> Option<usize> {
        if self.triangles.is_empty() || !p[0].is_finite() || !p[1].is_finite() {
            return None;
        }
        let inside = |x: f32, o: f32, n: usize| x >= o && x <= o + n as f32 * self.cell;
        if !inside(p[0], self.origin[0], self.columns) || !inside(p[1], self.origin[1], self.rows) {
            return None;
        }
        let [c, r] = self.cell_of(p);
        self.cells[r * self.columns + c]
            .iter()
            .find(|&&k| contains(self.triangles[k as usize], p, 1e-6))
            .map(|&k| k as usize)
    }

    /// Whether the disc of radius `r` about `p` lies in the union, judged at its centre and at
    /// 16 points of its rim (exact for discs smaller than the triangles' features).
    pub fn covers_disc(&self, p: [f32; 2], r: f32) -> bool {
        self.covers(p)
            && (0..16).all(|k| {
                let (s, c) = (k as f32 * std::f32::consts::TAU / 16.0).sin_cos();
                self.covers([p[0] + r * c, p[1] + r * s])
            })
    }

    /// The distance from `p` to the union of the triangles: 0 inside, infinite without
    /// triangles or for a point that is not finite.
    pub fn distance(&self, p: [f32; 2]) -> f32 {
        if self.covers(p) {
            return 0.0;
        }
        if !p[0].is_finite() || !p[1].is_finite() {
            return f32::INFINITY;
        }
        // Uncovered points are few (they are what an evaluation reports), so a plain scan.
        self.triangles
            .iter()
            .flat_map(|t| (0..3).map(move |e| closest_on_segment(t[e], t[(e + 1) % 3], p)))
            .map(|q| (q[0] - p[0]).hypot(q[1] - p[1]))
            .fold(f32::INFINITY, f32::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random point in [lo, hi)², reproducible.
    fn point(k: u32, lo: f32, hi: f32) -> [f32; 2] {
        let h = |x: u32| (x.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
        [lo + (hi - lo) * h(2 * k + 1), lo + (hi - lo) * h(2 * k + 7919)]
    }

    #[test]
    fn queries_agree_with_a_scan_of_every_triangle() {
        let triangles: Vec<[[f32; 2]; 3]> = (0..40)
            .map(|k| {
                let a = point(k, 0.0, 50.0);
                [a, [a[0] + 6.0, a[1] + 1.0], [a[0] + 2.0, a[1] + 5.0]]
            })
            .collect();
        let grid = TriangleGrid::new(triangles.clone(), 4.0);
        for k in 0..2000 {
            let p = point(1000 + k, -10.0, 70.0);
            let scan_covers = triangles.iter().any(|&t| contains(t, p, 1e-6));
            assert_eq!(grid.covers(p), scan_covers, "{p:?}");
            let scan = triangles
                .iter()
                .flat_map(|t| (0..3).map(move |e| closest_on_segment(t[e], t[(e + 1) % 3], p)))
                .map(|q| (q[0] - p[0]).hypot(q[1] - p[1]))
                .fold(f32::INFINITY, f32::min);
            let want = if scan_covers { 0.0 } else { scan };
            assert!((grid.distance(p) - want).abs() < 1e-5, "{p:?}: {} vs {want}", grid.distance(p));
        }
    }

    #[test]
    fn a_disc_is_covered_only_when_it_lies_inside() {
        // A 10 × 10 square as two triangles: the diagonal inside must not count as an edge.
        let grid = TriangleGrid::new(
            vec![[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]], [[0.0, 0.0], [10.0, 10.0], [0.0, 10.0]]],
            3.0,
        );
        assert!(grid.covers_disc([5.0, 5.0], 4.9));
        assert!(grid.covers_disc([0.6, 5.0], 0.5));
        assert!(!grid.covers_disc([0.4, 5.0], 0.5));
        assert!(!grid.covers_disc([5.0, 5.0], 5.1));
    }

    #[test]
    fn empty_and_broken_input_answer_without_panicking() {
        let empty = TriangleGrid::new(Vec::new(), 1.0);
        assert!(!empty.covers([0.0, 0.0]));
        assert_eq!(empty.distance([0.0, 0.0]), f32::INFINITY);
        let broken = TriangleGrid::new(
            vec![[[0.0, 0.0], [f32::NAN, 1.0], [1.0, 0.0]], [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]],
            1.0,
        );
        assert!(broken.covers([1.0, 1.0]));
        assert!(!broken.covers([f32::NAN, 1.0]));
        assert!((broken.distance([5.0, 0.0]) - 1.0).abs() < 1e-6);
        let far = TriangleGrid::new(
            vec![[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[1e9, 0.0], [1e9 + 1.0, 0.0], [1e9, 1.0]]],
            1.0,
        );
        assert!(far.covers([0.2, 0.2]));
    }
}
