//! Minimise a sparse quadratic with some unknowns fixed: the linear engine under ARAP's global
//! step (Sorkine & Alexa 2007 eq. 9; neural-puppet.md §3.2 eq. 2), and under any other
//! Laplacian-type problem with positional constraints (harmonic weights, pose pins).
//!
//! Problem, per column d of D independent right-hand sides:
//! minimise ½ xᵀ Q x − bᵀ x subject to x_k = y_k for every fixed k. With the unknowns split into
//! free f and fixed c, the minimiser solves Q_ff x_f = b_f − Q_fc y. Q_ff is factorised once (sparse
//! LLᵀ with a fill-reducing AMD ordering, faer), so each solve is two sparse triangular solves.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::Llt;
use faer::sparse::{SparseColMat, SparseColMatRef, Triplet};
use faer::{Mat, Side};

use crate::error::{Error, Result};

/// Marks a fixed unknown in `free_index`.
const FIXED: u32 = u32::MAX;

/// A factorised "minimise ½xᵀQx − bᵀx with x_fixed = y" problem, reusable for any b and y.
///
/// Q is `n × n`, symmetric, and positive definite once restricted to the free unknowns (e.g.
/// −L for a cotangent Laplacian L with at least one fixed vertex per connected component).
#[derive(Debug)]
pub struct MinQuadWithFixed {
    n: usize,
    /// Fixed unknowns, in the caller's order (the order of `y`).
    fixed: Vec<u32>,
    /// For each unknown, its row in the free system, or [`FIXED`].
    free_index: Vec<u32>,
    /// Free unknowns in free-system order.
    free: Vec<u32>,
    /// Entries of Q_fc as (free row, position in `fixed`, value).
    coupling: Vec<(u32, u32, f64)>,
    /// LLᵀ of Q_ff; `None` when every unknown is fixed.
    llt: Option<Llt<usize, f64>>,
    /// Right-hand side / solution buffer, `#free × D`.
    rhs: Mat<f64>,
}

impl MinQuadWithFixed {
    /// Factorises Q restricted to the unknowns not in `fixed`.
    ///
    /// `q`: the full symmetric `n × n` matrix (both triangles stored; only the lower triangle of
    /// Q_ff is read, Q_fc is read in full). `fixed`: distinct indices below `n`, in the order the
    /// values `y` will be given to [`solve`](Self::solve).
    ///
    /// # Errors
    /// [`Error::Geometry`] if `q` is not square `n × n`, a fixed index is out of range or repeated,
    /// or Q_ff is not numerically positive definite (e.g. a connected component of Q's graph has no
    /// fixed unknown, so Q_ff is singular).
    pub fn new(q: SparseColMatRef<'_, usize, f64>, fixed: &[u32]) -> Result<Self> {
        let n = q.nrows();
        if q.ncols() != n {
            return Err(Error::mismatch("min_quad_with_fixed: Q", format!("{n}×{}", q.ncols()), "square"));
        }
        let mut free_index = vec![0u32; n];
        for (k, &c) in fixed.iter().enumerate() {
            match free_index.get_mut(c as usize) {
                None => {
                    return Err(Error::geometry(
                        format!("fixed unknown {c} (entry {k})"),
                        format!("is past the {n} unknowns"),
                    ))
                }
                Some(slot) if *slot == FIXED => return Err(Error::geometry(format!("fixed unknown {c}"), "is listed twice")),
                Some(slot) => *slot = FIXED,
            }
        }
        let mut free = Vec::with_capacity(n - fixed.len());
        for (i, slot) in free_index.iter_mut().enumerate() {
            if *slot != FIXED {
                *slot = free.len() as u32;
                free.push(i as u32);
            }
        }
        let mut position_in_fixed = vec![0u32; n];
        for (k, &c) in fixed.iter().enumerate() {
            position_in_fixed[c as usize] = k as u32;
        }
        let mut ff = Vec::with_capacity(q.compute_nnz());
        let mut coupling = Vec::new();
        for t in q.triplet_iter() {
            let (fi, fj) = (free_index[t.row], free_index[t.col]);
            match (fi != FIXED, fj != FIXED) {
                (true, true) if fi >= fj => ff.push(Triplet::new(fi as usize, fj as usize, *t.val)),
                (true, false) => coupling.push((fi, position_in_fixed[t.col], *t.val)),
                _ => {}
            }
        }
        let llt = if free.is_empty() {
            None
        } else {
            let m = free.len();
            let q_ff = SparseColMat::<usize, f64>::try_new_from_triplets(m, m, &ff)
                .map_err(|e| Error::geometry("min_quad_with_fixed", format!("cannot assemble Q_ff: {e:?}")))?;
            Some(q_ff.sp_cholesky(Side::Lower).map_err(|e| {
                Error::geometry(
                    "min_quad_with_fixed",
                    format!(
                        "Q restricted to the {m} free unknowns is not positive definite ({e:?}); \
                         does every connected part have a fixed unknown?"
                    ),
                )
            })?)
        };
        Ok(Self {
            n,
            fixed: fixed.to_vec(),
            free_index,
            free,
            coupling,
            llt,
            rhs: Mat::new(),
        })
    }

    /// Number of unknowns `n`.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The fixed unknowns, in the order `y` is given.
    pub fn fixed(&self) -> &[u32] {
        &self.fixed
    }

    /// Whether unknown `i` is fixed.
    pub fn is_fixed(&self, i: usize) -> bool {
        self.free_index[i] == FIXED
    }

    /// Solves for all D columns at once: writes the minimiser into `x` (`n` rows), with
    /// `x[fixed[k]] = y[k]` exactly.
    ///
    /// `b`: the linear term, `n` rows (rows of fixed unknowns are ignored); `y`: one row per
    /// fixed unknown.
    ///
    /// # Panics
    /// If `b.len() != n`, `x.len() != n` or `y.len() != fixed.len()` (caller bugs).
    pub fn solve<const D: usize>(&mut self, b: &[[f64; D]], y: &[[f64; D]], x: &mut [[f64; D]]) {
        assert_eq!(b.len(), self.n, "min_quad_with_fixed: b has {} rows, expected {}", b.len(), self.n);
        assert_eq!(x.len(), self.n, "min_quad_with_fixed: x has {} rows, expected {}", x.len(), self.n);
        assert_eq!(
            y.len(),
            self.fixed.len(),
            "min_quad_with_fixed: y has {} rows, expected {}",
            y.len(),
            self.fixed.len()
        );
        for (&c, yk) in self.fixed.iter().zip(y) {
            x[c as usize] = *yk;
        }
        let Some(llt) = &self.llt else { return };
        let m = self.free.len();
        if self.rhs.nrows() != m || self.rhs.ncols() != D {
            self.rhs = Mat::zeros(m, D);
        }
        for (r, &i) in self.free.iter().enumerate() {
            for (d, &v) in b[i as usize].iter().enumerate() {
                self.rhs[(r, d)] = v;
            }
        }
        for &(r, k, q) in &self.coupling {
            for (d, &v) in y[k as usize].iter().enumerate() {
                self.rhs[(r as usize, d)] -= q * v;
            }
        }
        llt.solve_in_place(self.rhs.as_mut());
        for (r, &i) in self.free.iter().enumerate() {
            for (d, v) in x[i as usize].iter_mut().enumerate() {
                *v = self.rhs[(r, d)];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sparse(n: usize, entries: &[(usize, usize, f64)]) -> SparseColMat<usize, f64> {
        let t: Vec<_> = entries.iter().map(|&(i, j, v)| Triplet::new(i, j, v)).collect();
        SparseColMat::try_new_from_triplets(n, n, &t).unwrap()
    }

    #[test]
    fn path_graph_by_hand() {
        // Q = −L of the path 0–1–2 with unit weights; fix x0 = 0, x2 = 3, b = 0: the minimiser of
        // (x1 − x0)² + (x2 − x1)² is the midpoint x1 = 1.5. With b1 = 1: 2x1 − 3 = 1 → x1 = 2.
        let q = sparse(
            3,
            &[
                (0, 0, 1.0),
                (1, 1, 2.0),
                (2, 2, 1.0),
                (0, 1, -1.0),
                (1, 0, -1.0),
                (1, 2, -1.0),
                (2, 1, -1.0),
            ],
        );
        let mut solver = MinQuadWithFixed::new(q.as_ref(), &[2, 0]).unwrap();
        let mut x = [[0.0; 2]; 3];
        solver.solve(&[[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], &[[3.0, 3.0], [0.0, 0.0]], &mut x);
        assert_eq!(x[0], [0.0, 0.0]);
        assert_eq!(x[2], [3.0, 3.0]);
        assert!((x[1][0] - 1.5).abs() < 1e-14 && (x[1][1] - 2.0).abs() < 1e-14, "{x:?}");
    }

    #[test]
    fn unconstrained_component_is_an_error() {
        // Two disconnected edges; only the first has a fixed unknown.
        let q = sparse(
            4,
            &[
                (0, 0, 1.0),
                (1, 1, 1.0),
                (0, 1, -1.0),
                (1, 0, -1.0),
                (2, 2, 1.0),
                (3, 3, 1.0),
                (2, 3, -1.0),
                (3, 2, -1.0),
            ],
        );
        let err = MinQuadWithFixed::new(q.as_ref(), &[0]).unwrap_err().to_string();
        assert!(err.contains("not positive definite"), "{err}");
        assert!(MinQuadWithFixed::new(q.as_ref(), &[0, 3]).is_ok());
    }

    #[test]
    fn bad_fixed_lists_are_errors() {
        let q = sparse(2, &[(0, 0, 1.0), (1, 1, 1.0)]);
        assert!(MinQuadWithFixed::new(q.as_ref(), &[5]).unwrap_err().to_string().contains("past"));
        assert!(MinQuadWithFixed::new(q.as_ref(), &[1, 1])
            .unwrap_err()
            .to_string()
            .contains("twice"));
        let mut all_fixed = MinQuadWithFixed::new(q.as_ref(), &[1, 0]).unwrap();
        let mut x = [[9.0]; 2];
        all_fixed.solve(&[[0.0]; 2], &[[4.0], [5.0]], &mut x);
        assert_eq!(x, [[5.0], [4.0]]);
    }
}
