//! The system every handle shares: Q = L M̄⁻¹ L on the free unknowns in one AMD order, its
//! factorisations, and the unconstrained weights of every handle.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::Mat;

use super::admm::{Admm, ADMM_RHO};
use super::factor::Factor;
use super::BbwError;
use crate::geom::cotan_laplacian::CotanEdge;

/// Q = L M̄⁻¹ L (M̄ = M / mean M) restricted to the free unknowns, in AMD order, with the columns
/// that couple it to the handles.
pub(super) struct Biharmonic {
    /// Free unknown → mesh vertex (free unknowns numbered in AMD order).
    pub(super) vertex: Vec<u32>,
    /// Q_ff: both triangles, columns with ascending rows.
    pub(super) q: SymbolicSparseColMat<usize>,
    pub(super) q_val: Vec<f64>,
    /// Position of the diagonal entry in each column of `q`.
    pub(super) diagonal: Vec<usize>,
    /// Per handle k: the free part of Q's column h_k, (free unknown, value). b_k = −this.
    pub(super) coupling: Vec<Vec<(usize, f64)>>,
    /// The handles' vertices.
    pub(super) handles: Vec<u32>,
}

impl Biharmonic {
    pub(super) fn new(n: usize, edges: &[CotanEdge], mass: &[f64], handles: &[u32]) -> Result<Self, BbwError> {
        // L as rows with the diagonal first: L_ii = −Σ_j w_ij, L_ij = w_ij.
        let mut start = vec![0usize; n + 1];
        for e in edges {
            start[e.i as usize + 1] += 1;
            start[e.j as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v] + 1;
        }
        let mut next: Vec<usize> = start[..n].iter().map(|s| s + 1).collect();
        let mut col = vec![0u32; start[n]];
        let mut val = vec![0.0; start[n]];
        for v in 0..n {
            col[start[v]] = v as u32;
        }
        for e in edges {
            for (a, b) in [(e.i, e.j), (e.j, e.i)] {
                let slot = next[a as usize];
                col[slot] = b;
                val[slot] = e.w;
                val[start[a as usize]] -= e.w;
                next[a as usize] += 1;
            }
        }
        let used: Vec<f64> = mass.iter().copied().filter(|&m| m > 0.0).collect();
        let mean = used.iter().sum::<f64>() / used.len().max(1) as f64;
        // 1/m̄ for used vertices; unused ones (handles only) have an empty row of L, so 0 is safe.
        let inv_mass: Vec<f64> = mass.iter().map(|&m| if m > 0.0 { mean / m } else { 0.0 }).collect();

        // Free numbering in vertex order first.
        const FIXED: usize = usize::MAX;
        let mut natural = vec![0usize; n];
        for &v in handles {
            natural[v as usize] = FIXED;
        }
        let mut vertex_natural = Vec::with_capacity(n - handles.len());
        for (v, slot) in natural.iter_mut().enumerate() {
            if *slot != FIXED {
                *slot = vertex_natural.len();
                vertex_natural.push(v as u32);
            }
        }
        let m = vertex_natural.len();

        // Column j of Q = Σ_k L_{:,k} L_kj / m̄_k, over the 1-ring k of j and the 1-ring of k.
        let mut acc = vec![0.0; n];
        let mut seen = vec![usize::MAX; n];
        let mut touched: Vec<usize> = Vec::new();
        let mut q_column = |j: usize, out: &mut Vec<(usize, f64)>| {
            touched.clear();
            for e in start[j]..start[j + 1] {
                let k = col[e] as usize;
                let c = val[e] * inv_mass[k];
                for f in start[k]..start[k + 1] {
                    let i = col[f] as usize;
                    if seen[i] != j {
                        seen[i] = j;
                        acc[i] = 0.0;
                        touched.push(i);
                    }
                    acc[i] += val[f] * c;
                }
            }
            out.clear();
            out.extend(touched.iter().filter(|&&i| natural[i] != FIXED).map(|&i| (natural[i], acc[i])));
        };
        let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); m];
        for (c, &v) in vertex_natural.iter().enumerate() {
            q_column(v as usize, &mut columns[c]);
            columns[c].sort_unstable_by_key(|&(i, _)| i);
        }
        let mut coupling: Vec<Vec<(usize, f64)>> = vec![Vec::new(); handles.len()];
        for (k, &v) in handles.iter().enumerate() {
            q_column(v as usize, &mut coupling[k]);
        }

        // One fill-reducing order for everything: AMD of Q_ff's pattern.
        let (pattern_ptr, pattern_idx) = csc_pattern(&columns, |i| i);
        let pattern = SymbolicSparseColMatRef::new_checked(m, m, &pattern_ptr, None, &pattern_idx);
        let mut perm = vec![0usize; m];
        let mut perm_inv = vec![0usize; m];
        let mut buffer = MemBuffer::new(amd::order_scratch::<usize>(m, pattern_idx.len()));
        amd::order(
            &mut perm,
            &mut perm_inv,
            pattern,
            amd::Control::default(),
            MemStack::new(&mut buffer),
        )
        .map_err(|e| BbwError::Factorisation {
            stage: "ordering".into(),
            size: m,
            problem: format!("{e:?}"),
        })?;

        // Renumber: new unknown perm_inv[old].
        let mut renumbered: Vec<Vec<(usize, f64)>> = vec![Vec::new(); m];
        for (old, column) in columns.into_iter().enumerate() {
            renumbered[perm_inv[old]] = column.into_iter().map(|(i, v)| (perm_inv[i], v)).collect();
        }
        for column in &mut renumbered {
            column.sort_unstable_by_key(|&(i, _)| i);
        }
        for column in &mut coupling {
            column.iter_mut().for_each(|e| e.0 = perm_inv[e.0]);
        }
        let vertex: Vec<u32> = perm.iter().map(|&old| vertex_natural[old]).collect();
        let (col_ptr, row_idx) = csc_pattern(&renumbered, |i| i);
        let q_val: Vec<f64> = renumbered.iter().flatten().map(|&(_, v)| v).collect();
        let diagonal: Vec<usize> = (0..m)
            .map(|j| col_ptr[j] + row_idx[col_ptr[j]..col_ptr[j + 1]].partition_point(|&i| i < j))
            .collect();
        let q = SymbolicSparseColMat::new_checked(m, m, col_ptr, None, row_idx);
        Ok(Self {
            vertex,
            q,
            q_val,
            diagonal,
            coupling,
            handles: handles.to_vec(),
        })
    }

    pub(super) fn len(&self) -> usize {
        self.vertex.len()
    }

    /// The LLᵀ factorisation of Q_ff + σI (its upper triangle in the shared AMD order).
    fn factor(&self, sigma: f64, stage: &str) -> Result<Factor, BbwError> {
        let m = self.len();
        let (ptr, idx) = (self.q.col_ptr(), self.q.row_idx());
        // Upper triangle (rows ≤ column): columns are sorted, so it is each column's prefix up to
        // the diagonal, which comes last.
        let (mut upper_ptr, mut upper_idx, mut upper_val) = (vec![0usize], Vec::new(), Vec::new());
        for j in 0..m {
            let end = self.diagonal[j] + 1;
            upper_idx.extend_from_slice(&idx[ptr[j]..end]);
            upper_val.extend_from_slice(&self.q_val[ptr[j]..end]);
            *upper_val.last_mut().expect("a column holds its diagonal") += sigma;
            upper_ptr.push(upper_idx.len());
        }
        let upper = SymbolicSparseColMatRef::new_checked(m, m, &upper_ptr, None, &upper_idx);
        Factor::new(upper, &upper_val).map_err(|problem| BbwError::Factorisation {
            stage: stage.into(),
            size: m,
            problem,
        })
    }

    /// Every handle's unconstrained minimiser x_k = Q_ff⁻¹ b_k (one factorisation and one
    /// multi-column solve for all handles).
    pub(super) fn unconstrained(&self) -> Result<Vec<Vec<f64>>, BbwError> {
        let mut rhs = Mat::zeros(self.len(), self.coupling.len());
        for (k, column) in self.coupling.iter().enumerate() {
            for &(i, v) in column {
                rhs[(i, k)] = -v;
            }
        }
        self.factor(0.0, "unconstrained weights")?.solve(rhs.as_mut());
        Ok((0..rhs.ncols()).map(|k| rhs.col(k).iter().copied().collect()).collect())
    }

    /// The ADMM warm start's shared factorisation, ρ = [`ADMM_RHO`] × the mean of diag Q_ff.
    pub(super) fn admm(&self) -> Result<Admm, BbwError> {
        let rho = ADMM_RHO * self.diagonal.iter().map(|&d| self.q_val[d]).sum::<f64>() / self.len() as f64;
        Ok(Admm {
            factor: self.factor(rho, "admm warm start")?,
            rho,
        })
    }
}

/// Compressed columns (pointers, row indices) of column lists, rows mapped by `row`.
fn csc_pattern(columns: &[Vec<(usize, f64)>], row: impl Fn(usize) -> usize) -> (Vec<usize>, Vec<usize>) {
    let mut ptr = Vec::with_capacity(columns.len() + 1);
    ptr.push(0);
    let mut idx = Vec::with_capacity(columns.iter().map(Vec::len).sum());
    for column in columns {
        idx.extend(column.iter().map(|&(i, _)| row(i)));
        ptr.push(idx.len());
    }
    (ptr, idx)
}
