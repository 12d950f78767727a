//! The ADMM warm start: a few iterations on one factorisation shared by every handle, which
//! estimate where each handle's weight is held at 0 or 1.

use faer::Mat;

use super::factor::Factor;

/// ρ of the ADMM warm start, relative to the mean diagonal of Q_ff. Measured (20 iterations, one
/// thread): 10⁻³, 3·10⁻³ and 10⁻² of it left the active-set method 8, 6 and 11 iterations on
/// benches/data/character_1k.txt and 30, 29 and 20 on hair_2k.txt; 3·10⁻³ was fastest overall.
pub(super) const ADMM_RHO: f64 = 3e-3;

/// ADMM for one handle's box-constrained QP (Boyd et al. 2011, "Distributed optimization and
/// statistical learning via the alternating direction method of multipliers", §5.2, with OSQP's
/// over-relaxation α = 1.6): x = (Q_ff + ρI)⁻¹(b + ρ(z − u)), z = clamp(αx + (1−α)z + u, 0, 1),
/// u += αx + (1−α)z_old − z. Its factorisation is shared by all handles. A few iterations do not
/// reach the 1e-3 accuracy asked of the weights (on benches/data/character_5k.txt 3,000 did not:
/// 7e-3), but they place most of the contact region, which the active-set method otherwise
/// grows a few vertices per iteration.
pub(super) struct Admm {
    pub(super) factor: Factor,
    pub(super) rho: f64,
}

impl Admm {
    /// z after `iterations` ADMM iterations from z = clamp(`x0`), u = 0: in [0, 1], and exactly at
    /// a bound where the iterations hold the weight there.
    pub(super) fn estimate(&self, b: &[f64], x0: &[f64], iterations: usize) -> Vec<f64> {
        const ALPHA: f64 = 1.6;
        let m = b.len();
        let mut z: Vec<f64> = x0.iter().map(|x| x.clamp(0.0, 1.0)).collect();
        let mut u = vec![0.0; m];
        let mut x = Mat::zeros(m, 1);
        for _ in 0..iterations {
            for j in 0..m {
                x[(j, 0)] = b[j] + self.rho * (z[j] - u[j]);
            }
            self.factor.solve(x.as_mut());
            for j in 0..m {
                let relaxed = ALPHA * x[(j, 0)] + (1.0 - ALPHA) * z[j];
                let next = (relaxed + u[j]).clamp(0.0, 1.0);
                u[j] += relaxed - next;
                z[j] = next;
            }
        }
        z
    }
}
