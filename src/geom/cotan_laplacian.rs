//! The cotangent Laplacian of a 2D triangle mesh: the weights w_ij = ½(cot α_ij + cot β_ij) that
//! the ARAP energy of neural-puppet.md §3.2 eq. 2 uses ("w_ij are cotangent weights"), as an edge
//! list and as a sparse matrix.
//!
//! α_ij and β_ij are the angles opposite edge (i, j) in its two triangles; a boundary edge has
//! only one, so its weight is ½ cot α_ij. Cotangents are taken from |cross|, so they do not depend
//! on a triangle's winding, and a triangle's cotangents do not change when the mesh is scaled.
//! Weights are negative where the opposite angles sum past 180° (obtuse triangles); the matrix
//! stays negative semi-definite because it is minus the Dirichlet energy of piecewise-linear
//! functions, Σ_t area_t |∇f|², summed triangle by triangle.

use faer::sparse::{SparseColMat, Triplet};
use num_traits::Float;

use crate::error::{Error, Result};

/// One undirected mesh edge `i < j` with its cotangent weight `w` = ½(cot α + cot β)
/// (one cotangent for a boundary edge). Dimensionless (scale invariant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CotanEdge {
    /// The smaller vertex index.
    pub i: u32,
    /// The larger vertex index.
    pub j: u32,
    /// ½(cot α_ij + cot β_ij); may be negative on obtuse triangles.
    pub w: f64,
}

/// Cotangent weights of every edge of a 2D triangle mesh, sorted by `(i, j)`.
///
/// `positions`: `#V` points `[x, y]` (any unit); `triangles`: `#F` index triples (either winding).
/// Vertices used by no triangle simply have no edge. The weights are computed in f64 whatever `T`.
///
/// # Errors
/// [`Error::Geometry`] naming the first bad input: a non-finite position, a triangle index past
/// `#V`, or a degenerate triangle (repeated index or zero area), for which cot is undefined.
pub fn cotan_weights<T: Float>(positions: &[[T; 2]], triangles: &[[u32; 3]]) -> Result<Vec<CotanEdge>> {
    let p = positions_f64(positions)?;
    let mut half_edges: Vec<(u64, f64)> = Vec::with_capacity(3 * triangles.len());
    for (t, &tri) in triangles.iter().enumerate() {
        let corners = triangle_corners(&p, t, tri)?;
        // Corner k is opposite the edge (k+1, k+2).
        let cross = (corners[1][0] - corners[0][0]) * (corners[2][1] - corners[0][1])
            - (corners[2][0] - corners[0][0]) * (corners[1][1] - corners[0][1]);
        let twice_area = cross.abs();
        let scale = (0..3).map(|k| dist2(corners[k], corners[(k + 1) % 3])).fold(0.0, f64::max);
        // Relative test: the cotangents depend on shape only, so the threshold must too.
        if twice_area <= 1e-14 * scale || scale == 0.0 {
            return Err(Error::geometry(
                format!("triangle {t} {tri:?}"),
                "is degenerate (zero area), cotangent weights are undefined",
            ));
        }
        for k in 0..3 {
            let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let u = sub(corners[(k + 1) % 3], corners[k]);
            let v = sub(corners[(k + 2) % 3], corners[k]);
            let cot = (u[0] * v[0] + u[1] * v[1]) / twice_area;
            half_edges.push((edge_key(a, b), 0.5 * cot));
        }
    }
    half_edges.sort_unstable_by_key(|&(key, _)| key);
    let mut edges: Vec<CotanEdge> = Vec::with_capacity(half_edges.len() / 2 + 1);
    for (key, w) in half_edges {
        let (i, j) = ((key >> 32) as u32, key as u32);
        match edges.last_mut() {
            Some(last) if last.i == i && last.j == j => last.w += w,
            _ => edges.push(CotanEdge { i, j, w }),
        }
    }
    Ok(edges)
}

/// The cotangent Laplacian L as a `#V × #V` sparse matrix (faer, column-major, both triangles
/// stored): L_ij = w_ij for each edge, L_ii = −Σ_j w_ij, zero elsewhere.
///
/// Sign: like libigl's `cotmatrix`, L is **negative semi-definite**, L·1 = 0, and −xᵀLx =
/// Σ_edges w_ij (x_i − x_j)² is the Dirichlet energy of the piecewise-linear function x.
/// Rows of vertices used by no triangle are zero.
///
/// # Errors
/// As [`cotan_weights`].
pub fn cotan_laplacian<T: Float>(positions: &[[T; 2]], triangles: &[[u32; 3]]) -> Result<SparseColMat<usize, f64>> {
    let edges = cotan_weights(positions, triangles)?;
    laplacian_from_edges(positions.len(), &edges)
}

/// Assembles L (sign as in [`cotan_laplacian`]) from an edge list over `n` vertices.
pub(crate) fn laplacian_from_edges(n: usize, edges: &[CotanEdge]) -> Result<SparseColMat<usize, f64>> {
    let mut diagonal = vec![0.0; n];
    let mut triplets = Vec::with_capacity(2 * edges.len() + n);
    for e in edges {
        let (i, j) = (e.i as usize, e.j as usize);
        triplets.push(Triplet::new(i, j, e.w));
        triplets.push(Triplet::new(j, i, e.w));
        diagonal[i] -= e.w;
        diagonal[j] -= e.w;
    }
    triplets.extend(diagonal.iter().enumerate().map(|(i, &d)| Triplet::new(i, i, d)));
    SparseColMat::try_new_from_triplets(n, n, &triplets)
        .map_err(|e| Error::geometry("cotangent laplacian", format!("cannot assemble the {n}×{n} sparse matrix: {e:?}")))
}

/// Converts positions to f64, rejecting non-finite ones.
pub(crate) fn positions_f64<T: Float>(positions: &[[T; 2]]) -> Result<Vec<[f64; 2]>> {
    positions
        .iter()
        .enumerate()
        .map(|(i, v)| match (v[0].to_f64(), v[1].to_f64()) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Ok([x, y]),
            _ => Err(Error::geometry(format!("vertex {i}"), "is not finite")),
        })
        .collect()
}

/// The three corners of triangle `t`, checking its indices.
fn triangle_corners(p: &[[f64; 2]], t: usize, tri: [u32; 3]) -> Result<[[f64; 2]; 3]> {
    if let Some(&bad) = tri.iter().find(|&&i| i as usize >= p.len()) {
        return Err(Error::geometry(
            format!("triangle {t} {tri:?}"),
            format!("index {bad} is past the {} vertices", p.len()),
        ));
    }
    Ok(tri.map(|i| p[i as usize]))
}

fn edge_key(a: u32, b: u32) -> u64 {
    let (i, j) = if a < b { (a, b) } else { (b, a) };
    (u64::from(i) << 32) | u64::from(j)
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    /// A jittered `nx × ny` grid of unit cells, two CCW triangles per cell (y down).
    fn grid(nx: usize, ny: usize, seed: u64) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut p = Vec::new();
        for y in 0..=ny {
            for x in 0..=nx {
                p.push([x as f64 + rng.random_range(-0.2..0.2), y as f64 + rng.random_range(-0.2..0.2)]);
            }
        }
        let id = |x: usize, y: usize| (y * (nx + 1) + x) as u32;
        let mut t = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                // Positive signed area (the crate's counter-clockwise with y down).
                t.push([id(x, y), id(x + 1, y), id(x, y + 1)]);
                t.push([id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        (p, t)
    }

    fn dense(l: &SparseColMat<usize, f64>) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; l.ncols()]; l.nrows()];
        for t in l.triplet_iter() {
            d[t.row][t.col] += *t.val;
        }
        d
    }

    #[test]
    fn laplacian_annihilates_constants_and_is_symmetric() {
        let (p, t) = grid(6, 5, 1);
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        for (i, row) in l.iter().enumerate() {
            let sum: f64 = row.iter().sum();
            let scale: f64 = row.iter().map(|v| v.abs()).sum();
            assert!(sum.abs() <= 1e-13 * scale, "row {i}: L·1 = {sum}");
            for (j, &v) in row.iter().enumerate() {
                assert_eq!(v, l[j][i], "L[{i}][{j}] != L[{j}][{i}]");
            }
        }
    }

    #[test]
    fn laplacian_is_negative_semi_definite() {
        let (p, t) = grid(5, 4, 2);
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..20 {
            let x: Vec<f64> = (0..p.len()).map(|_| rng.random_range(-1.0..1.0)).collect();
            let q: f64 = (0..p.len()).map(|i| x[i] * (0..p.len()).map(|j| l[i][j] * x[j]).sum::<f64>()).sum();
            assert!(q <= 1e-12, "xᵀLx = {q} > 0");
        }
    }

    #[test]
    fn weights_are_scale_invariant() {
        let (p, t) = grid(4, 4, 4);
        let reference = cotan_weights(&p, &t).unwrap();
        for s in [1e-4, 1e4] {
            let scaled: Vec<[f64; 2]> = p.iter().map(|v| [v[0] * s, v[1] * s]).collect();
            let w = cotan_weights(&scaled, &t).unwrap();
            assert_eq!(w.len(), reference.len());
            for (a, b) in w.iter().zip(&reference) {
                assert_eq!((a.i, a.j), (b.i, b.j));
                assert!(
                    (a.w - b.w).abs() <= 1e-12 * (1.0 + b.w.abs()),
                    "scale {s}: edge ({}, {}): {} vs {}",
                    a.i,
                    a.j,
                    a.w,
                    b.w
                );
            }
        }
    }

    #[test]
    fn right_triangle_by_hand() {
        // Legs 3 (along x) and 4 (along y), right angle at vertex 0; (0, 1, 2) has positive
        // signed area. Angles: 90° at 0, atan(4/3) at 1, atan(3/4) at 2.
        // Edge (1,2) is opposite the right angle: ½ cot 90° = 0. Edge (0,2) is opposite
        // vertex 1: ½ cot(atan(4/3)) = ½·3/4. Edge (0,1) is opposite vertex 2: ½·4/3.
        let p = [[0.0, 0.0], [3.0, 0.0], [0.0, 4.0]];
        let w = cotan_weights(&p, &[[0, 1, 2]]).unwrap();
        let expected = [(0, 1, 2.0 / 3.0), (0, 2, 3.0 / 8.0), (1, 2, 0.0)];
        assert_eq!(w.len(), 3);
        for (e, (i, j, v)) in w.iter().zip(expected) {
            assert_eq!((e.i, e.j), (i, j));
            assert!((e.w - v).abs() < 1e-15, "edge ({i}, {j}): {} vs {v}", e.w);
        }
        let l = dense(&cotan_laplacian(&p, &[[0, 1, 2]]).unwrap());
        assert!((l[0][0] + 2.0 / 3.0 + 3.0 / 8.0).abs() < 1e-15);
        assert!((l[1][1] + 2.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn interior_edge_sums_both_cotangents() {
        // Unit square split along its diagonal (0,2): both opposite angles are 90°, so w = 0;
        // each side is opposite a 45° angle: w = ½.
        let p = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let t = [[0, 1, 2], [0, 2, 3]];
        let w = cotan_weights(&p, &t).unwrap();
        let get = |i, j| w.iter().find(|e| (e.i, e.j) == (i, j)).unwrap().w;
        assert!(get(0, 2).abs() < 1e-15);
        for (i, j) in [(0, 1), (1, 2), (2, 3), (0, 3)] {
            assert!((get(i, j) - 0.5).abs() < 1e-15);
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let p = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, f64::NAN]];
        let msg = |r: Result<Vec<CotanEdge>>| r.unwrap_err().to_string();
        assert!(msg(cotan_weights(&p[..3], &[[0, 1, 2]])).contains("degenerate"));
        assert!(msg(cotan_weights(&p[..3], &[[0, 1, 1]])).contains("degenerate"));
        assert!(msg(cotan_weights(&p[..3], &[[0, 1, 7]])).contains("index 7"));
        assert!(msg(cotan_weights(&p, &[[0, 1, 3]])).contains("vertex 3: is not finite"));
    }
}
