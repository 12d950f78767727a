//! A part's non-rigid deformation field (issue 4 item 3, APES appendix B): a regular triangle
//! grid over the part's local bounding box, whose deformed vertex positions define a
//! piecewise-linear map. [`Grid::map`] sends a rest point forward (ground truth);
//! [`InverseMap`] sends a deformed point back (drawing: shapes are evaluated through the
//! inverse of the deformation), so both use the very same map.

use serde::{Deserialize, Serialize};

/// A `cols × rows`-vertex grid with square cells of side `spacing`, in a part's local units.
/// Vertex `(i, j)` is number `j * cols + i` at `origin + spacing · (i, j)`; each cell is split
/// along its `(i, j)–(i+1, j+1)` diagonal into two counter-clockwise triangles (y down).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Position of vertex (0, 0).
    pub origin: [f32; 2],
    /// Cell side.
    pub spacing: f32,
    /// Vertices per row (at least 2).
    pub cols: u32,
    /// Vertices per column (at least 2).
    pub rows: u32,
}

impl Grid {
    /// The grid covering `bounds` grown by `margin` on every side, with cells of at most
    /// `max_spacing` and at least 3 cells along the shorter side.
    pub fn covering(bounds: [[f32; 2]; 2], margin: f32, max_spacing: f32) -> Grid {
        let lo = [bounds[0][0] - margin, bounds[0][1] - margin];
        let size = [
            bounds[1][0] - bounds[0][0] + 2.0 * margin,
            bounds[1][1] - bounds[0][1] + 2.0 * margin,
        ];
        let spacing = max_spacing.min(size[0].min(size[1]) / 3.0).max(1e-3);
        let cols = (size[0] / spacing).ceil() as u32 + 1;
        let rows = (size[1] / spacing).ceil() as u32 + 1;
        // Centre the (slightly larger) grid on the box.
        let extra = [(cols - 1) as f32 * spacing - size[0], (rows - 1) as f32 * spacing - size[1]];
        Grid {
            origin: [lo[0] - 0.5 * extra[0], lo[1] - 0.5 * extra[1]],
            spacing,
            cols: cols.max(2),
            rows: rows.max(2),
        }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    /// Rest positions of all vertices.
    pub fn vertices(&self) -> Vec<[f32; 2]> {
        (0..self.rows)
            .flat_map(|j| (0..self.cols).map(move |i| [i, j]))
            .map(|[i, j]| [self.origin[0] + i as f32 * self.spacing, self.origin[1] + j as f32 * self.spacing])
            .collect()
    }

    /// The triangles, counter-clockwise (positive signed area with y down).
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut t = Vec::with_capacity(2 * ((self.cols - 1) * (self.rows - 1)) as usize);
        for j in 0..self.rows - 1 {
            for i in 0..self.cols - 1 {
                let v00 = j * self.cols + i;
                let (v10, v01, v11) = (v00 + 1, v00 + self.cols, v00 + self.cols + 1);
                t.push([v00, v10, v11]);
                t.push([v00, v11, v01]);
            }
        }
        t
    }

    /// The triangle holding `p` and `p`'s barycentric weights in it. Points outside the grid
    /// use the nearest border cell, with weights extrapolated (some negative).
    pub fn locate(&self, p: [f32; 2]) -> ([u32; 3], [f32; 3]) {
        let u = (p[0] - self.origin[0]) / self.spacing;
        let v = (p[1] - self.origin[1]) / self.spacing;
        let i = (u.floor().max(0.0) as u32).min(self.cols - 2);
        let j = (v.floor().max(0.0) as u32).min(self.rows - 2);
        let (fu, fv) = (u - i as f32, v - j as f32);
        let v00 = j * self.cols + i;
        let (v10, v01, v11) = (v00 + 1, v00 + self.cols, v00 + self.cols + 1);
        if fu >= fv {
            ([v00, v10, v11], [1.0 - fu, fu - fv, fv])
        } else {
            ([v00, v11, v01], [1.0 - fv, fu, fv - fu])
        }
    }

    /// Where rest point `p` goes when the grid's vertices move to `deformed`.
    ///
    /// # Panics
    /// If `deformed.len()` is not [`Grid::vertex_count`] (a caller bug).
    pub fn map(&self, deformed: &[[f32; 2]], p: [f32; 2]) -> [f32; 2] {
        assert_eq!(deformed.len(), self.vertex_count(), "deformed grid has the wrong vertex count");
        let (t, w) = self.locate(p);
        let [a, b, c] = t.map(|k| deformed[k as usize]);
        [w[0] * a[0] + w[1] * b[0] + w[2] * c[0], w[0] * a[1] + w[1] * b[1] + w[2] * c[1]]
    }
}

/// Point location in a deformed grid, for pulling deformed points back to rest.
pub struct InverseMap<'a> {
    rest: Vec<[f32; 2]>,
    deformed: &'a [[f32; 2]],
    triangles: Vec<[u32; 3]>,
    lo: [f32; 2],
    cell: f32,
    dims: [usize; 2],
    buckets: Vec<Vec<u32>>,
}

impl<'a> InverseMap<'a> {
    /// Indexes the triangles of `grid` at positions `deformed`.
    ///
    /// # Panics
    /// If `deformed.len()` is not [`Grid::vertex_count`] (a caller bug).
    pub fn new(grid: &Grid, deformed: &'a [[f32; 2]]) -> Self {
        assert_eq!(deformed.len(), grid.vertex_count(), "deformed grid has the wrong vertex count");
        let triangles = grid.triangles();
        let mut lo = [f32::INFINITY; 2];
        let mut hi = [f32::NEG_INFINITY; 2];
        for p in deformed {
            lo = [lo[0].min(p[0]), lo[1].min(p[1])];
            hi = [hi[0].max(p[0]), hi[1].max(p[1])];
        }
        let cell = grid.spacing;
        let dims = [((hi[0] - lo[0]) / cell) as usize + 1, ((hi[1] - lo[1]) / cell) as usize + 1];
        let mut buckets = vec![Vec::new(); dims[0] * dims[1]];
        for (k, t) in triangles.iter().enumerate() {
            let p = t.map(|v| deformed[v as usize]);
            let bx = |x: f32| (((x - lo[0]) / cell) as usize).min(dims[0] - 1);
            let by = |y: f32| (((y - lo[1]) / cell) as usize).min(dims[1] - 1);
            let (x0, x1) = (bx(p[0][0].min(p[1][0]).min(p[2][0])), bx(p[0][0].max(p[1][0]).max(p[2][0])));
            let (y0, y1) = (by(p[0][1].min(p[1][1]).min(p[2][1])), by(p[0][1].max(p[1][1]).max(p[2][1])));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    buckets[y * dims[0] + x].push(k as u32);
                }
            }
        }
        InverseMap {
            rest: grid.vertices(),
            deformed,
            triangles,
            lo,
            cell,
            dims,
            buckets,
        }
    }

    /// The rest point that maps to `q`, or `None` if `q` is outside the deformed grid.
    pub fn rest_of(&self, q: [f32; 2]) -> Option<[f32; 2]> {
        let x = (q[0] - self.lo[0]) / self.cell;
        let y = (q[1] - self.lo[1]) / self.cell;
        if x < 0.0 || y < 0.0 || x >= self.dims[0] as f32 || y >= self.dims[1] as f32 {
            return None;
        }
        for &k in &self.buckets[y as usize * self.dims[0] + x as usize] {
            let t = self.triangles[k as usize];
            let [a, b, c] = t.map(|v| self.deformed[v as usize]);
            let det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            if det.abs() < 1e-12 {
                continue;
            }
            let w1 = ((q[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (q[1] - a[1])) / det;
            let w2 = ((b[0] - a[0]) * (q[1] - a[1]) - (q[0] - a[0]) * (b[1] - a[1])) / det;
            let w0 = 1.0 - w1 - w2;
            let eps = -1e-5;
            if w0 >= eps && w1 >= eps && w2 >= eps {
                let [ra, rb, rc] = t.map(|v| self.rest[v as usize]);
                return Some([w0 * ra[0] + w1 * rb[0] + w2 * rc[0], w0 * ra[1] + w1 * rb[1] + w2 * rc[1]]);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        Grid::covering([[-3.0, -1.0], [5.0, 9.0]], 1.0, 2.0)
    }

    #[test]
    fn grid_covers_the_box_with_ccw_triangles() {
        let g = grid();
        let v = g.vertices();
        assert!(g.spacing <= 2.0);
        assert!(v.iter().any(|p| p[0] <= -4.0) && v.iter().any(|p| p[0] >= 6.0));
        assert!(v.iter().any(|p| p[1] <= -2.0) && v.iter().any(|p| p[1] >= 10.0));
        let mesh = crate::puppet::Mesh {
            vertices: v,
            triangles: g.triangles(),
        };
        mesh.check_invariants().unwrap();
    }

    #[test]
    fn undeformed_map_is_the_identity_inside_and_outside() {
        let g = grid();
        let rest = g.vertices();
        for p in [[0.3, 0.7], [4.9, 8.2], [-3.9, -1.9], [20.0, -7.0]] {
            let q = g.map(&rest, p);
            assert!((q[0] - p[0]).abs() < 1e-4 && (q[1] - p[1]).abs() < 1e-4, "{p:?} -> {q:?}");
        }
    }

    #[test]
    fn inverse_map_undoes_a_smooth_deformation() {
        let g = grid();
        let deformed: Vec<[f32; 2]> = g
            .vertices()
            .iter()
            .map(|p| [p[0] + 0.4 * (0.3 * p[1]).sin(), p[1] + 0.3 * (0.2 * p[0]).cos() + 0.5])
            .collect();
        let inv = InverseMap::new(&g, &deformed);
        for k in 0..200 {
            let p = [-3.5 + (k % 20) as f32 * 0.45, -1.5 + (k / 20) as f32 * 1.1];
            let q = g.map(&deformed, p);
            let back = inv.rest_of(q).expect("inside the grid");
            assert!(
                (back[0] - p[0]).abs() < 1e-3 && (back[1] - p[1]).abs() < 1e-3,
                "{p:?} -> {q:?} -> {back:?}"
            );
        }
        assert_eq!(inv.rest_of([100.0, 100.0]), None);
    }
}
