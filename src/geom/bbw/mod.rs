//! Bounded biharmonic weights (BBW; Jacobson, Baran, Popović & Sorkine 2011, "Bounded Biharmonic
//! Weights for Real-Time Deformation") on a 2D triangle mesh with point handles: the skinning
//! weights through which the pins of an accessory rig move an accessory layer
//! (accessory-rigs.md §3.5: "we represent the pins as BBW handles").
//!
//! **Problem.** For each handle k separately, over the weights w_k of all `#V` vertices:
//!
//! ```text
//! minimise ½ w_kᵀ L M⁻¹ L w_k   subject to   0 ≤ w_k ≤ 1,   w_k[h_j] = δ_jk for every handle j
//! ```
//!
//! with L the cotangent Laplacian of [`cotan_weights`] (negative semi-definite; LM⁻¹L is positive
//! semi-definite) and M a diagonal mass matrix ([`MassMatrix`], barycentric by default). M⁻¹Lw is
//! the pointwise Laplacian of w, so ½ wᵀLM⁻¹Lw = ½ (M⁻¹Lw)ᵀM(M⁻¹Lw) discretises the paper's
//! energy ½∫(Δw)² (natural boundary conditions), as libigl's `bbw` does. Like libigl, each handle
//! is solved on its own, without the partition-of-unity constraint, so the bounded rows do not
//! sum to one (up to 24 % off on benches/data/character_1k.txt, 91 % on the 103-pin hair_2k.txt);
//! [`bbw`] then divides each vertex's row by its sum, because translation-only skinning needs
//! Σ_k w_k = 1 exactly. [`BbwWeights::row_sums`] keeps the sums.
//!
//! **Scale.** Cotangents are dimensionless and M scales with area, so LM⁻¹L scales with 1/area;
//! M is divided by its mean, which makes Q = LM⁻¹L dimensionless and the weights (and every
//! iteration) independent of the mesh's unit.
//!
//! **Solver.** Each handle's problem is a convex QP with box constraints. Q is assembled once in
//! the free unknowns (the vertices that are not handles), renumbered by one approximate minimum
//! degree (AMD) ordering. Then, sharing factorisations between handles and running the handles
//! in parallel (rayon):
//! 1. one sparse LLᵀ (faer) of Q_ff gives every handle's unconstrained weights (one multi-column
//!    solve);
//! 2. one sparse LLᵀ of Q_ff + ρI drives [`BbwOptions::warm_start_iterations`] ADMM iterations per
//!    handle, which estimate where the weight is held at 0 or 1;
//! 3. from there, the primal–dual active-set method (Hintermüller, Ito & Kunisch 2002) solves the
//!    QP exactly: fix the weights outside [0, 1] at their bound, solve Q_FF w_F = … on the free
//!    vertices, release fixed weights whose multiplier has the wrong sign, until nothing changes.
//!    Each solve factorises only the free block Q_FF, in the shared AMD order restricted to it,
//!    so a handle whose weight is zero on most of the mesh factors a small matrix;
//! 4. the active-set method can cycle (Q is not an M-matrix); a repeated state switches to
//!    projected Newton (Bertsekas 1982), whose energy decreases at every step.
//!
//! Why this and not plain ADMM on one shared factorisation: measured on one thread (2-core VM,
//! loaded by another build; benches/README.md "bbw" has the final figures), ADMM took 198 ms to
//! come within 1e-3 of the QP optimum on benches/data/character_1k.txt (ρ = 10⁻² of Q's mean
//! diagonal, 394 iterations per handle; ρ 3× smaller or larger was slower) where the active-set
//! method took 51 ms to reach 1.3e-5, and on character_5k.txt ADMM was still 7e-3 away after
//! 16.5 s (3,000 iterations per handle) where the active-set method took 0.77 s. The active-set
//! method on full-size systems (fixed weights as identity rows, so that all handles and
//! iterations share one symbolic factorisation) took 1.7× the time of the reduced systems. The
//! active set grows towards the optimum by a few vertices per iteration (the multipliers of a
//! biharmonic obstacle problem live on the contact boundary only), hence 4–40 iterations per
//! handle from the unconstrained weights; 20 ADMM iterations cut that to 6–29 and the time by
//! 10–30 %.
//!
//! Connectivity: the weights of a connected component are determined only if it holds a handle
//! (otherwise Q_ff is singular there); such components are an error naming them, as are vertices
//! used by no triangle (they have no mass and no neighbours) unless they are handles, whose rows
//! are then δ.

mod active_set;
mod admm;
mod checks;
mod error;
mod factor;
mod system;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use super::cotan_laplacian::cotan_weights;
use checks::{check_components, check_handles, check_mesh, check_options};
pub use error::{BbwError, MeshComponent};
use system::Biharmonic;

/// Which diagonal mass matrix M enters Q = LM⁻¹L.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum MassMatrix {
    /// m_i = ⅓ Σ area of the triangles around vertex i (the default).
    #[default]
    Barycentric,
    /// Meyer et al.'s mixed Voronoi areas (libigl's `massmatrix` default for triangles, hence what
    /// `igl.bbw` uses): each triangle gives each corner its share of the circumcentric cell,
    /// (|e_b|² cot β + |e_c|² cot γ)/8, or ½ / ¼ / ¼ of its area when it is obtuse (½ to the
    /// obtuse corner). For comparisons with libigl.
    Voronoi,
}

/// Options of [`bbw`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct BbwOptions {
    /// Stopping tolerance of the active-set iterations, in weight units (weights are in [0, 1]).
    /// A free weight is fixed at a bound once it passes the bound by more than this; a fixed
    /// weight is released once its scaled multiplier (Qw − b)_i / Q_ii — the change of w_i alone
    /// that would lower the energy — points into the box by more than this. The final weights are
    /// clamped to [0, 1]. Default 1e-7: measured error against an interior-point QP solver
    /// (clarabel, tolerances 1e-12) 4.2e-6 and 5.2e-6 on benches/data/character_{1k,5k}.txt, at
    /// the same energy to 1e-12 (1e-6 gave 1.3e-5 for about the same time). This bounds the error only as well as Q is conditioned: on grids with
    /// overlapping, badly shaped triangles (negative cotangent weights) 1e-7 left errors up to
    /// 2.5e-3 and 1e-9 was needed.
    pub tolerance: f64,
    /// Most iterations (active set, then projected Newton if it cycles) for one handle before
    /// [`BbwError::NotConverged`]. Default 1000: a few dozen suffice on the benches/data meshes
    /// and random distorted grids, but dense pins on real art need a few hundred (docs/results.md
    /// "DiceBear characters").
    pub max_iterations: usize,
    /// ADMM iterations (on one factorisation shared by all handles) that estimate each handle's
    /// active set before the exact active-set method; 0 starts that method from the
    /// unconstrained weights instead. Default 20 (benches/README.md "bbw" measures it against
    /// none).
    pub warm_start_iterations: usize,
    /// The mass matrix M. Default [`MassMatrix::Barycentric`].
    pub mass: MassMatrix,
}

impl BbwOptions {
    /// The defaults listed on each field.
    pub const DEFAULT: Self = Self {
        tolerance: 1e-7,
        max_iterations: 1000,
        warm_start_iterations: 20,
        mass: MassMatrix::Barycentric,
    };

    /// Sets [`tolerance`](Self::tolerance).
    pub const fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Sets [`max_iterations`](Self::max_iterations).
    pub const fn with_max_iterations(mut self, max_iterations: usize) -> Self {
        self.max_iterations = max_iterations;
        self
    }

    /// Sets [`warm_start_iterations`](Self::warm_start_iterations).
    pub const fn with_warm_start_iterations(mut self, iterations: usize) -> Self {
        self.warm_start_iterations = iterations;
        self
    }

    /// Sets [`mass`](Self::mass).
    pub const fn with_mass(mut self, mass: MassMatrix) -> Self {
        self.mass = mass;
        self
    }
}

impl Default for BbwOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Bounded biharmonic weights of every vertex for every handle.
#[derive(Clone, Debug, PartialEq)]
pub struct BbwWeights {
    /// Number of handles `#H` (columns).
    pub handles: usize,
    /// `#V × #H`, row-major: `weights[v * handles + k]` is handle k's weight at vertex v. Every
    /// entry is in [0, 1], every row sums to 1 (to rounding), and the row of handle k's vertex is
    /// δ_k.
    pub weights: Vec<f64>,
    /// `#V` row sums Σ_k w_vk before the rows were normalised: `row(v)[k] * row_sums[v]` is the
    /// bounded weight itself (what libigl's `bbw` returns), and `|row_sums[v] − 1|` how far vertex v
    /// was from a partition of unity.
    pub row_sums: Vec<f64>,
    /// Most active-set iterations any handle needed.
    pub iterations: usize,
}

impl BbwWeights {
    /// Number of vertices `#V` (rows).
    pub fn vertices(&self) -> usize {
        self.weights.len().checked_div(self.handles).unwrap_or(0)
    }

    /// Largest |Σ_k w_vk − 1| over the vertices before normalisation (0 for an empty mesh).
    pub fn max_row_sum_deviation(&self) -> f64 {
        self.row_sums.iter().map(|s| (s - 1.0).abs()).fold(0.0, f64::max)
    }

    /// The weights of vertex `v` for handles 0 … `#H`−1.
    ///
    /// # Panics
    /// If `v` is not below [`vertices`](Self::vertices) (a caller bug).
    pub fn row(&self, v: usize) -> &[f64] {
        &self.weights[v * self.handles..(v + 1) * self.handles]
    }
}

/// Bounded biharmonic weights of a 2D triangle mesh for point handles (see the module doc for
/// the problem and the solver), rows normalised to sum to 1.
///
/// `positions`: `#V` points `[x, y]`, any unit (the weights do not depend on it). `triangles`:
/// `#F` corner triples, either winding. `handles`: `#H` distinct vertex indices; handle k's weight
/// is 1 at `handles[k]` and 0 at every other handle. Every connected component of the mesh needs
/// a handle, and every vertex must be in a triangle unless it is a handle.
///
/// Runs the handles in parallel on the rayon pool.
///
/// # Errors
/// [`BbwError`] naming the first bad position, triangle or handle, every unused vertex or every
/// handle-less component; an invalid option; a handle whose active set did not settle within
/// [`BbwOptions::max_iterations`].
pub fn bbw(positions: &[[f64; 2]], triangles: &[[u32; 3]], handles: &[u32], options: &BbwOptions) -> Result<BbwWeights, BbwError> {
    let raw = raw_weights(positions, triangles, handles, options)?;
    let h = handles.len();
    let mut weights = raw.weights;
    let mut row_sums = Vec::with_capacity(positions.len());
    for (v, row) in weights.chunks_exact_mut(h.max(1)).enumerate() {
        let sum: f64 = row.iter().sum();
        if sum <= 0.0 {
            return Err(BbwError::ZeroRow { vertex: v });
        }
        row.iter_mut().for_each(|w| *w /= sum);
        row_sums.push(sum);
    }
    Ok(BbwWeights {
        handles: h,
        weights,
        row_sums,
        iterations: raw.iterations,
    })
}

/// Lumped (diagonal) mass matrix of a 2D triangle mesh: `#V` vertex areas in the positions' unit
/// squared, summing to the mesh's total area. Vertices in no triangle get 0.
///
/// # Panics
/// If a triangle index is not below `#V` (a caller bug; [`bbw`] checks indices first).
pub fn lumped_mass(positions: &[[f64; 2]], triangles: &[[u32; 3]], kind: MassMatrix) -> Vec<f64> {
    let mut mass = vec![0.0; positions.len()];
    for tri in triangles {
        let c = tri.map(|i| positions[i as usize]);
        let area = 0.5 * twice_signed_area(c).abs();
        let shares = match kind {
            MassMatrix::Barycentric => [area / 3.0; 3],
            MassMatrix::Voronoi => voronoi_shares(c, area),
        };
        for (&i, share) in tri.iter().zip(shares) {
            mass[i as usize] += share;
        }
    }
    mass
}

/// Each corner's part of a triangle of area `area` under Meyer et al.'s mixed Voronoi rule.
fn voronoi_shares(c: [[f64; 2]; 3], area: f64) -> [f64; 3] {
    // l2[k]: squared length of the edge opposite corner k; 2·|b||c|·cos(corner k) = l2[k+1] + l2[k+2] − l2[k].
    let l2 = [0, 1, 2].map(|k| dist2(c[(k + 1) % 3], c[(k + 2) % 3]));
    let cos2 = [0, 1, 2].map(|k| l2[(k + 1) % 3] + l2[(k + 2) % 3] - l2[k]);
    if let Some(obtuse) = (0..3).find(|&k| cos2[k] < 0.0) {
        let mut shares = [area / 4.0; 3];
        shares[obtuse] = area / 2.0;
        return shares;
    }
    // cot of corner k = cos/sin = cos2[k] / (4·area).
    let cot = cos2.map(|v| v / (4.0 * area));
    [0, 1, 2].map(|k| (l2[(k + 1) % 3] * cot[(k + 1) % 3] + l2[(k + 2) % 3] * cot[(k + 2) % 3]) / 8.0)
}

/// Weights before the rows are normalised (each column the exact QP minimiser to the tolerance).
struct RawWeights {
    /// `#V × #H` row-major.
    weights: Vec<f64>,
    iterations: usize,
}

fn raw_weights(positions: &[[f64; 2]], triangles: &[[u32; 3]], handles: &[u32], options: &BbwOptions) -> Result<RawWeights, BbwError> {
    check_options(options)?;
    check_mesh(positions, triangles)?;
    check_handles(positions.len(), handles)?;
    check_components(positions.len(), triangles, handles)?;
    let n = positions.len();
    let h = handles.len();
    let mut weights = vec![0.0; n * h];
    for (k, &v) in handles.iter().enumerate() {
        weights[v as usize * h + k] = 1.0;
    }
    let free_count = n - h;
    if free_count == 0 {
        return Ok(RawWeights { weights, iterations: 0 });
    }
    let edges = cotan_weights(positions, triangles).map_err(|e| BbwError::Laplacian(e.to_string()))?;
    let mass = lumped_mass(positions, triangles, options.mass);
    let system = Biharmonic::new(n, &edges, &mass, handles)?;
    let initial = system.unconstrained()?;
    let admm = if options.warm_start_iterations > 0 {
        Some(system.admm()?)
    } else {
        None
    };
    let columns: Vec<(Vec<f64>, usize)> = (0..h)
        .into_par_iter()
        .map(|k| system.solve_handle(k, &initial[k], admm.as_ref(), options))
        .collect::<Result<_, _>>()?;
    let mut iterations = 0;
    for (k, (x, its)) in columns.iter().enumerate() {
        iterations = iterations.max(*its);
        for (&v, &w) in system.vertex.iter().zip(x) {
            weights[v as usize * h + k] = w;
        }
    }
    Ok(RawWeights { weights, iterations })
}

fn twice_signed_area(c: [[f64; 2]; 3]) -> f64 {
    (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1])
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}
