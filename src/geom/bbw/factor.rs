//! A sparse LLᵀ factorisation (faer) for the solver's symmetric positive definite systems.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// A sparse LLᵀ factorisation (faer) of a symmetric positive definite matrix given by its upper
/// triangle, already in a fill-reducing order. Sequential: callers run in parallel.
pub(super) struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl Factor {
    pub(super) fn new(upper: SymbolicSparseColMatRef<'_, usize>, values: &[f64]) -> Result<Self, String> {
        // faer's default picks the simplicial (column by column) factorisation for these matrices;
        // the supernodal one (dense blocks) took 0.58× its time on benches/data/character_5k.txt and
        // 0.9× on character_1k.txt and hair_2k.txt (whole bbw, one thread).
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(upper, Side::Upper, SymmetricOrdering::Identity, params).map_err(|e| format!("{e:?}"))?;
        let mut factor = vec![0.0; symbolic.len_val()];
        let mut buffer = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        symbolic
            .factorize_numeric_llt(
                &mut factor,
                SparseColMatRef::new(upper, values),
                Side::Upper,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
        Ok(Self { symbolic, values: factor })
    }

    /// Solves A X = B in place (`rhs` is B on entry, X on exit).
    pub(super) fn solve(&self, rhs: MatMut<'_, f64>) {
        let mut buffer = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq));
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut buffer));
    }
}
