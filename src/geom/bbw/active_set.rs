//! One handle's box-constrained QP: the primal–dual active-set method, projected Newton where it
//! cycles, and the reduced solves on the free weights.

use std::collections::hash_map::DefaultHasher;
use std::collections::HashSet;
use std::hash::{Hash, Hasher};

use faer::sparse::SymbolicSparseColMatRef;
use faer::Mat;

use super::admm::Admm;
use super::factor::Factor;
use super::system::Biharmonic;
use super::{BbwError, BbwOptions};

/// Where a weight is during the active-set iterations.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum State {
    Free,
    AtZero,
    AtOne,
}

impl State {
    /// Where a weight `x` that was free goes: to the bound it passed by more than `tol`.
    pub(super) fn of(x: f64, tol: f64) -> Self {
        if x < -tol {
            State::AtZero
        } else if x > 1.0 + tol {
            State::AtOne
        } else {
            State::Free
        }
    }

    /// The value a fixed weight is held at.
    fn bound(self) -> Option<f64> {
        match self {
            State::Free => None,
            State::AtZero => Some(0.0),
            State::AtOne => Some(1.0),
        }
    }
}

/// An ADMM estimate within this of a bound starts the active-set method held at that bound. A
/// few ADMM iterations leave most weights far from their pin slightly above 0, and on thin
/// layers, where a weight is 1 along most of a stroke, slightly below 1; every weight started
/// free enlarges each active-set iteration's factorisation (and takes iterations to fix); one
/// held wrongly is released by its multiplier (benches/README.md "bbw").
const WARM_START_MARGIN: f64 = 1e-3;

impl Biharmonic {
    /// Handle k's weights at the free unknowns (clamped to [0, 1]) and the active-set iterations
    /// taken: the primal–dual active-set method from the unconstrained minimiser `x0` (or from
    /// `admm`'s estimate of the active set, when given), and projected Newton from where it
    /// stopped if it cycles.
    pub(super) fn solve_handle(
        &self,
        k: usize,
        x0: &[f64],
        admm: Option<&Admm>,
        options: &BbwOptions,
    ) -> Result<(Vec<f64>, usize), BbwError> {
        let mut work = Work::new(self, k);
        let tol = options.tolerance;
        let start = match admm {
            // Weights the ADMM iterate holds at or near a bound start fixed there.
            Some(admm) => admm
                .estimate(&work.b, x0, options.warm_start_iterations)
                .into_iter()
                .map(|z| match z {
                    z if z <= WARM_START_MARGIN => State::AtZero,
                    z if z >= 1.0 - WARM_START_MARGIN => State::AtOne,
                    _ => State::Free,
                })
                .collect(),
            None => x0.iter().map(|&x| State::of(x, tol)).collect(),
        };
        let budget = options.max_iterations;
        let (mut x, pdas_iterations) = match self.active_set(&mut work, start, tol, budget)? {
            Outcome::Converged(x, iterations) => return Ok((x, iterations)),
            Outcome::Stopped(x, iterations) => (x, iterations),
        };
        match self.projected_newton(&mut work, &mut x, options.tolerance, budget - pdas_iterations)? {
            Some(iterations) => Ok((x, pdas_iterations + iterations)),
            None => Err(BbwError::NotConverged {
                handle: k,
                vertex: self.handles[k],
                iterations: budget,
            }),
        }
    }

    /// Primal–dual active set (Hintermüller, Ito & Kunisch 2002): fix the free weights that
    /// left [0, 1] by more than `tol` at the bound they passed, release a fixed weight whose
    /// scaled multiplier (Qx − b)_j / Q_jj points into the box by more than `tol`, solve Q_FF
    /// exactly on the free set, until no weight changes state ([`Outcome::Converged`]). On
    /// matrices that are not M-matrices (Q is not) it can cycle; a repeated state, or the
    /// iteration budget, ends it with the latest iterate clamped ([`Outcome::Stopped`]).
    pub(super) fn active_set(&self, work: &mut Work, mut state: Vec<State>, tol: f64, budget: usize) -> Result<Outcome, BbwError> {
        let m = self.len();
        let (ptr, idx, q) = (self.q.col_ptr(), self.q.row_idx(), &self.q_val[..]);
        let mut x: Vec<f64> = state.iter().map(|s| s.bound().unwrap_or(0.0)).collect();
        let mut seen = HashSet::new();
        let mut rhs = vec![0.0; m];
        let mut free = vec![false; m];
        for iteration in 1..=budget {
            // x_F = Q_FF⁻¹ (b_F − Q_F,one · 1): the minimiser with the fixed weights at their bounds.
            for j in 0..m {
                free[j] = state[j] == State::Free;
                if free[j] {
                    rhs[j] = work.b[j]
                        - (ptr[j]..ptr[j + 1])
                            .filter(|&e| state[idx[e]] == State::AtOne)
                            .map(|e| q[e])
                            .sum::<f64>();
                }
            }
            self.solve_on(work, &free, &rhs, &mut x)?;
            for j in 0..m {
                match state[j] {
                    State::AtZero => x[j] = 0.0,
                    State::AtOne => x[j] = 1.0,
                    State::Free => {}
                }
            }
            let mut changed = false;
            for j in 0..m {
                let next = match state[j] {
                    State::Free => State::of(x[j], tol),
                    fixed => {
                        let g = (self.q_times(&x, j) - work.b[j]) / q[self.diagonal[j]];
                        match fixed {
                            State::AtZero if g < -tol => State::Free,
                            State::AtOne if g > tol => State::Free,
                            _ => fixed,
                        }
                    }
                };
                changed |= next != state[j];
                state[j] = next;
            }
            x.iter_mut().for_each(|w| *w = w.clamp(0.0, 1.0));
            if !changed {
                return Ok(Outcome::Converged(x, iteration));
            }
            let mut hasher = DefaultHasher::new();
            state.hash(&mut hasher);
            if !seen.insert(hasher.finish()) {
                return Ok(Outcome::Stopped(x, iteration));
            }
        }
        x.iter_mut().for_each(|w| *w = w.clamp(0.0, 1.0));
        Ok(Outcome::Stopped(x, budget))
    }

    /// Projected Newton with an Armijo search along the projection arc (Bertsekas 1982,
    /// "Projected Newton methods for optimization problems with simple constraints"), from the
    /// feasible `x`, updated in place: each step solves Q_FF exactly on the weights that are not
    /// at a bound with the gradient pushing outwards, and scales the gradient by 1/Q_jj on the
    /// others. The energy decreases at every step, so it converges where the active-set method
    /// cycles, at the price of more (and larger) solves. Stops when the scaled projected
    /// gradient ‖x − P(x − D⁻¹g)‖∞ is at most `tol`; returns the iterations, `None` past `budget`.
    pub(super) fn projected_newton(&self, work: &mut Work, x: &mut [f64], tol: f64, budget: usize) -> Result<Option<usize>, BbwError> {
        // Bertsekas' ε: weights within it of a bound (and pushed outwards) count as at the bound.
        const EPSILON: f64 = 1e-3;
        let m = self.len();
        let q = &self.q_val[..];
        let mut qx: Vec<f64> = (0..m).map(|j| self.q_times(x, j)).collect();
        let (mut g, mut d, mut free) = (vec![0.0; m], vec![0.0; m], vec![false; m]);
        let (mut step, mut q_step, mut minus_g) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for iteration in 0..=budget {
            let mut stationarity: f64 = 0.0;
            for j in 0..m {
                g[j] = qx[j] - work.b[j];
                minus_g[j] = -g[j];
                stationarity = stationarity.max((x[j] - (x[j] - g[j] / q[self.diagonal[j]]).clamp(0.0, 1.0)).abs());
            }
            if stationarity <= tol {
                return Ok(Some(iteration));
            }
            if iteration == budget {
                break;
            }
            let eps = EPSILON.min(stationarity);
            for j in 0..m {
                let push = g[j] / q[self.diagonal[j]];
                free[j] = !((x[j] <= eps && push > 0.0) || (x[j] >= 1.0 - eps && push < 0.0));
            }
            self.solve_on(work, &free, &minus_g, &mut d)?;
            for j in (0..m).filter(|&j| !free[j]) {
                d[j] = -g[j] / q[self.diagonal[j]];
            }
            let mut alpha = 1.0;
            loop {
                for j in 0..m {
                    step[j] = (x[j] + alpha * d[j]).clamp(0.0, 1.0) - x[j];
                }
                (0..m).for_each(|j| q_step[j] = self.q_times(&step, j));
                // The energy change gᵀs + ½ sᵀQs, computed from the step s itself (no cancellation
                // between two nearly equal energies), against Armijo's σ = 10⁻⁴ times the promise.
                let change: f64 = (0..m).map(|j| step[j] * (g[j] + 0.5 * q_step[j])).sum();
                let promised: f64 = (0..m).map(|j| if free[j] { -alpha * g[j] * d[j] } else { -g[j] * step[j] }).sum();
                if -change >= 1e-4 * promised || alpha < 1e-12 {
                    break;
                }
                alpha *= 0.5;
            }
            for j in 0..m {
                x[j] += step[j];
                qx[j] += q_step[j];
            }
        }
        Ok(None)
    }

    /// (Q x)_j.
    fn q_times(&self, x: &[f64], j: usize) -> f64 {
        let (ptr, idx) = (self.q.col_ptr(), self.q.row_idx());
        (ptr[j]..ptr[j + 1]).map(|e| self.q_val[e] * x[idx[e]]).sum()
    }

    /// Solves Q_FF y_F = r_F over the unknowns marked `free` and writes y into `out` there (other
    /// entries untouched). Q_FF keeps the shared AMD order, so it needs no ordering of its own.
    fn solve_on(&self, work: &mut Work, free: &[bool], r: &[f64], out: &mut [f64]) -> Result<(), BbwError> {
        let (ptr, idx, q) = (self.q.col_ptr(), self.q.row_idx(), &self.q_val[..]);
        let mut count = 0;
        for (j, &f) in free.iter().enumerate() {
            if f {
                work.local[j] = count;
                count += 1;
            }
        }
        if count == 0 {
            return Ok(());
        }
        let (sub_ptr, sub_idx, sub_val) = (&mut work.sub_ptr, &mut work.sub_idx, &mut work.sub_val);
        sub_ptr.clear();
        sub_idx.clear();
        sub_val.clear();
        sub_ptr.push(0);
        let mut rhs = Mat::zeros(count, 1);
        for j in (0..free.len()).filter(|&j| free[j]) {
            // Upper triangle: rows ≤ j, which come first in the sorted column.
            for e in ptr[j]..=self.diagonal[j] {
                if free[idx[e]] {
                    sub_idx.push(work.local[idx[e]]);
                    sub_val.push(q[e]);
                }
            }
            sub_ptr.push(sub_idx.len());
            rhs[(work.local[j], 0)] = r[j];
        }
        let sub = SymbolicSparseColMatRef::new_checked(count, count, sub_ptr, None, sub_idx);
        let factor = Factor::new(sub, sub_val).map_err(|problem| BbwError::Factorisation {
            stage: format!("handle {}", work.handle),
            size: count,
            problem,
        })?;
        factor.solve(rhs.as_mut());
        for j in (0..free.len()).filter(|&j| free[j]) {
            out[j] = rhs[(work.local[j], 0)];
        }
        Ok(())
    }
}

/// How [`Biharmonic::active_set`] ended.
pub(super) enum Outcome {
    /// No weight changed state: the weights (clamped) and the iterations.
    Converged(Vec<f64>, usize),
    /// It cycled or ran out of iterations: the latest weights (clamped) and the iterations.
    Stopped(Vec<f64>, usize),
}

/// One handle's right-hand side and buffers.
pub(super) struct Work {
    handle: usize,
    /// b_k = −Q_f,h_k: the linear term of ½xᵀQ_ff x − bᵀx.
    b: Vec<f64>,
    /// Free unknown → row of the reduced system.
    local: Vec<usize>,
    sub_ptr: Vec<usize>,
    sub_idx: Vec<usize>,
    sub_val: Vec<f64>,
}

impl Work {
    pub(super) fn new(system: &Biharmonic, handle: usize) -> Self {
        let m = system.len();
        let mut b = vec![0.0; m];
        for &(i, v) in &system.coupling[handle] {
            b[i] = -v;
        }
        Self {
            handle,
            b,
            local: vec![0; m],
            sub_ptr: Vec::new(),
            sub_idx: Vec::new(),
            sub_val: Vec::new(),
        }
    }
}
