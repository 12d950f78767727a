//! As-rigid-as-possible (ARAP) deformation energy, best-fit rotations and the local/global solver
//! with positional handles, for 2D triangle meshes (Sorkine & Alexa 2007, "spokes" cells).
//!
//! The energy is neural-puppet.md §3.2 eq. 2 (the training regulariser L_reg):
//!
//! ```text
//! E(v̂) = Σ_i Σ_{j ∈ N(i)} w_ij ‖(v̂_i − v̂_j) − R_i (v_i − v_j)‖²,     R_i = argmin over rotations
//! ```
//!
//! with v the rest positions, v̂ the deformed ones, N(i) the mesh neighbours of i and w_ij the
//! cotangent weights of [`cotan_weights`] (½(cot α + cot β)). Every undirected edge appears twice,
//! once in the cell of i (with R_i) and once in the cell of j (with R_j).
//!
//! **Rotations (local step).** Write e_ij = v_i − v_j, ê_ij = v̂_i − v̂_j and R = [[c, −s], [s, c]].
//! Cell i's energy is Σ_j w_ij (‖ê_ij‖² + ‖e_ij‖²) − 2 Σ_j w_ij ê_ij·(R e_ij), and
//! Σ_j w_ij ê_ij·(R e_ij) = c·A_i + s·B_i with A_i = Σ_j w_ij e_ij·ê_ij and
//! B_i = Σ_j w_ij (e_ij × ê_ij) (2D cross product e_x ê_y − e_y ê_x). So the optimum is
//! (c, s) = (A_i, B_i)/‖(A_i, B_i)‖ — the angle of the weighted covariance, no SVD. This holds for
//! any sign of the weights (‖R e‖ = ‖e‖ whatever R). When A_i = B_i = 0 (e.g. a collapsed cell)
//! every rotation is optimal and we take the identity.
//!
//! **Gradient.** E(v̂) = min_R F(v̂, R) with F the double sum above for fixed rotations. At the
//! optimum ∂F/∂R_i = 0 along the rotation manifold, so by the envelope theorem the R_i(v̂)
//! dependence drops out and ∇E = ∂F/∂v̂ at R = R*(v̂). Edge (i, j) enters F as
//! w_ij(‖r_i‖² + ‖r_j‖²) with r_i = ê_ij − R_i e_ij and r_j = ê_ji − R_j e_ji = −(ê_ij − R_j e_ij), hence
//!
//! ```text
//! ∂E/∂v̂_i = Σ_j 2 w_ij (r_i − r_j) = Σ_j 4 w_ij [ (v̂_i − v̂_j) − ½ (R_i + R_j)(v_i − v_j) ]
//! ```
//!
//! (Sorkine & Alexa eq. 8). E is not differentiable where some A_i = B_i = 0; there the formula
//! gives the gradient for R_i = I, a valid subgradient choice. The tests check it against central
//! differences.
//!
//! **Global step.** For fixed rotations, setting ∂F/∂v̂ = 0 gives −L v̂ = b with L the cotangent
//! Laplacian (negative semi-definite) and b_i = Σ_j ½ w_ij (R_i + R_j)(v_i − v_j); handles are
//! fixed unknowns of [`MinQuadWithFixed`], which factorises −L restricted to the free vertices once.
//! Each local and each global step minimises F exactly, so E never increases over iterations.
//!
//! Units: positions in pixels; w_ij dimensionless; E in pixels².

use num_traits::Float;
use rayon::prelude::*;

use super::cotan_laplacian::{cotan_weights, laplacian_from_edges, positions_f64};
use super::min_quad_with_fixed::MinQuadWithFixed;
use crate::error::{Error, Result};
use faer::sparse::{SparseColMat, Triplet};

/// One undirected edge of the ARAP energy, with its rest vector.
#[derive(Clone, Copy, Debug)]
struct ArapEdge<T> {
    i: u32,
    j: u32,
    /// Cotangent weight w_ij.
    w: T,
    /// Rest edge vector v_i − v_j.
    e: [T; 2],
}

/// The ARAP energy of one rest mesh (neural-puppet.md §3.2 eq. 2), with edges and cotangent
/// weights precomputed once so that the energy and its gradient can be evaluated many times,
/// batched, in `f32` (training) or `f64` (checks, the solver).
///
/// Rotations are returned as `[c, s]` = [cos θ, sin θ], the matrix R = [[c, −s], [s, c]] that maps
/// rest edge vectors onto deformed ones; θ turns +x towards +y (clockwise on screen, y down).
#[derive(Clone, Debug)]
pub struct ArapEnergy<T> {
    vertex_count: usize,
    edges: Vec<ArapEdge<T>>,
}

impl<T: Float + Send + Sync> ArapEnergy<T> {
    /// Precomputes cotangent weights (in f64, then rounded to `T`) and rest edge vectors.
    ///
    /// `rest`: `#V` rest positions `[x, y]` in pixels; `triangles`: `#F` index triples.
    ///
    /// # Errors
    /// [`Error::Geometry`] if the mesh has no vertex, a position is not finite, an index is out of
    /// range or a triangle is degenerate (see [`cotan_weights`]).
    pub fn new(rest: &[[T; 2]], triangles: &[[u32; 3]]) -> Result<Self> {
        if rest.is_empty() {
            return Err(Error::geometry("arap mesh", "has no vertex"));
        }
        let p = positions_f64(rest)?;
        let edges = cotan_weights(&p, triangles)?;
        Ok(Self::from_weights(&p, &edges))
    }

    fn from_weights(p: &[[f64; 2]], edges: &[super::CotanEdge]) -> Self {
        let cast = |v: f64| T::from(v).expect("Float can represent any finite f64 (possibly as inf)");
        let edges = edges
            .iter()
            .map(|e| {
                let (a, b) = (p[e.i as usize], p[e.j as usize]);
                ArapEdge {
                    i: e.i,
                    j: e.j,
                    w: cast(e.w),
                    e: [cast(a[0] - b[0]), cast(a[1] - b[1])],
                }
            })
            .collect();
        Self {
            vertex_count: p.len(),
            edges,
        }
    }

    /// Number of vertices `#V` the positions must have.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// Best-fit rotation `[cos θ, sin θ]` of every vertex's cell for the `#V` deformed positions
    /// (identity where the weighted covariance is zero).
    ///
    /// # Panics
    /// If `deformed.len() != #V` (a caller bug).
    pub fn rotations(&self, deformed: &[[T; 2]]) -> Vec<[T; 2]> {
        self.check_len(deformed.len());
        let mut rot = vec![[T::zero(); 2]; self.vertex_count];
        self.fit_rotations(deformed.as_flattened(), &mut rot);
        rot
    }

    /// ARAP energy E (eq. 2) of one deformed configuration, in pixels².
    ///
    /// # Panics
    /// If `deformed.len() != #V` (a caller bug).
    pub fn energy(&self, deformed: &[[T; 2]]) -> T {
        self.check_len(deformed.len());
        let mut rot = vec![[T::zero(); 2]; self.vertex_count];
        self.energy_one(deformed.as_flattened(), &mut rot, None)
    }

    /// Energies and gradients of a batch: `deformed` is `B × #V × 2` row-major (batch, vertex,
    /// coordinate), `grad_out` the same shape and is overwritten with ∂E_b/∂v̂; returns the `B`
    /// energies. Batch items run in parallel (rayon).
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `deformed.len()` is not a multiple of `2·#V` or `grad_out` differs
    /// from it in length.
    pub fn energy_and_gradient(&self, deformed: &[T], grad_out: &mut [T]) -> Result<Vec<T>> {
        let stride = 2 * self.vertex_count;
        if !deformed.len().is_multiple_of(stride) || grad_out.len() != deformed.len() {
            return Err(Error::mismatch(
                "arap: the positions and the gradient buffer",
                format!("{} and {} values", deformed.len(), grad_out.len()),
                format!("the same multiple of 2×{} vertices", self.vertex_count),
            ));
        }
        Ok(deformed
            .par_chunks(stride)
            .zip(grad_out.par_chunks_mut(stride))
            .map_init(
                || vec![[T::zero(); 2]; self.vertex_count],
                |rot, (x, g)| self.energy_one(x, rot, Some(g)),
            )
            .collect())
    }

    fn check_len(&self, len: usize) {
        assert_eq!(
            len, self.vertex_count,
            "arap: {len} deformed positions for a mesh of {} vertices",
            self.vertex_count
        );
    }

    /// Local step: `rot[i]` ← optimal `[c, s]` for flat positions `x` (`2·#V`).
    fn fit_rotations(&self, x: &[T], rot: &mut [[T; 2]]) {
        rot.fill([T::zero(); 2]);
        for e in &self.edges {
            let (i, j) = (e.i as usize, e.j as usize);
            let d = [x[2 * i] - x[2 * j], x[2 * i + 1] - x[2 * j + 1]];
            // A += w e·ê, B += w e×ê; ê_ji = −ê_ij and e_ji = −e_ij leave both unchanged, so
            // the same terms go to both cells.
            let a = e.w * (e.e[0] * d[0] + e.e[1] * d[1]);
            let b = e.w * (e.e[0] * d[1] - e.e[1] * d[0]);
            rot[i][0] = rot[i][0] + a;
            rot[i][1] = rot[i][1] + b;
            rot[j][0] = rot[j][0] + a;
            rot[j][1] = rot[j][1] + b;
        }
        for r in rot.iter_mut() {
            let norm = r[0].hypot(r[1]);
            *r = if norm > T::min_positive_value() {
                [r[0] / norm, r[1] / norm]
            } else {
                [T::one(), T::zero()]
            };
        }
    }

    /// The global step's right-hand side for rotations `rot`: `rhs[i]` ← Σ_j ½ w_ij (R_i + R_j)
    /// (v_i − v_j).
    fn rotated_rest_edges(&self, rot: &[[T; 2]], rhs: &mut [[T; 2]]) {
        rhs.fill([T::zero(); 2]);
        let half = T::one() / (T::one() + T::one());
        for e in &self.edges {
            let (i, j) = (e.i as usize, e.j as usize);
            let ([ci, si], [cj, sj]) = (rot[i], rot[j]);
            let (c, s) = (half * e.w * (ci + cj), half * e.w * (si + sj));
            let v = [c * e.e[0] - s * e.e[1], s * e.e[0] + c * e.e[1]];
            rhs[i] = [rhs[i][0] + v[0], rhs[i][1] + v[1]];
            rhs[j] = [rhs[j][0] - v[0], rhs[j][1] - v[1]];
        }
    }

    /// Energy of flat positions `x`; adds nothing to, but overwrites, `grad` when given.
    fn energy_one(&self, x: &[T], rot: &mut [[T; 2]], grad: Option<&mut [T]>) -> T {
        self.fit_rotations(x, rot);
        let two = T::one() + T::one();
        let mut energy = T::zero();
        let mut grad = grad;
        if let Some(g) = grad.as_deref_mut() {
            g.fill(T::zero());
        }
        for e in &self.edges {
            let (i, j) = (e.i as usize, e.j as usize);
            let d = [x[2 * i] - x[2 * j], x[2 * i + 1] - x[2 * j + 1]];
            let ([ci, si], [cj, sj]) = (rot[i], rot[j]);
            // r_i = ê − R_i e;  q_j = ê − R_j e = −r_j.
            let ri = [d[0] - (ci * e.e[0] - si * e.e[1]), d[1] - (si * e.e[0] + ci * e.e[1])];
            let qj = [d[0] - (cj * e.e[0] - sj * e.e[1]), d[1] - (sj * e.e[0] + cj * e.e[1])];
            energy = energy + e.w * (ri[0] * ri[0] + ri[1] * ri[1] + qj[0] * qj[0] + qj[1] * qj[1]);
            if let Some(g) = grad.as_deref_mut() {
                let gx = two * e.w * (ri[0] + qj[0]);
                let gy = two * e.w * (ri[1] + qj[1]);
                g[2 * i] = g[2 * i] + gx;
                g[2 * i + 1] = g[2 * i + 1] + gy;
                g[2 * j] = g[2 * j] - gx;
                g[2 * j + 1] = g[2 * j + 1] - gy;
            }
        }
        energy
    }
}

/// ARAP energy (neural-puppet.md §3.2 eq. 2) of `deformed` against `rest`, in pixels², with
/// cotangent weights. For repeated evaluation build an [`ArapEnergy`] once instead.
///
/// # Errors
/// As [`ArapEnergy::new`], and [`Error::Mismatch`] if `deformed` and `rest` differ in length.
pub fn arap_energy(rest: &[[f64; 2]], deformed: &[[f64; 2]], triangles: &[[u32; 3]]) -> Result<f64> {
    check_same_len(rest.len(), deformed.len())?;
    Ok(ArapEnergy::new(rest, triangles)?.energy(deformed))
}

/// Best-fit rotations `[cos θ, sin θ]` of every vertex cell (see [`ArapEnergy::rotations`]).
///
/// # Errors
/// As [`arap_energy`].
pub fn best_fit_rotations(rest: &[[f64; 2]], deformed: &[[f64; 2]], triangles: &[[u32; 3]]) -> Result<Vec<[f64; 2]>> {
    check_same_len(rest.len(), deformed.len())?;
    Ok(ArapEnergy::new(rest, triangles)?.rotations(deformed))
}

fn check_same_len(rest: usize, deformed: usize) -> Result<()> {
    if rest == deformed {
        Ok(())
    } else {
        Err(Error::mismatch(
            "arap: the deformed positions",
            deformed,
            format!("{rest} (one per rest position)"),
        ))
    }
}

/// ARAP deformation with positional handles (Sorkine & Alexa 2007; apes-part-extraction.md
/// appendix B): alternates best-fit rotations (local step) and a sparse linear solve (global
/// step) whose matrix, −L restricted to the free vertices, is factorised once in
/// [`new`](Self::new).
///
/// ```
/// # use puppet::geom::ArapSolver;
/// // A unit square of two triangles; pin vertices 0 and 2 and pull 2 to the right.
/// let rest = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
/// let tris = [[0, 1, 2], [0, 2, 3]];
/// let mut solver = ArapSolver::new(&rest, &tris, &[0, 2])?;
/// let out = solver.solve(&[[0.0, 0.0], [1.2, 1.0]], 10, &rest);
/// assert_eq!(out[2], [1.2, 1.0]); // handles are met exactly
/// # Ok::<(), puppet::Error>(())
/// ```
#[derive(Debug)]
pub struct ArapSolver {
    energy: ArapEnergy<f64>,
    system: MinQuadWithFixed,
    /// Scratch: rotations `[c, s]` and the right-hand side, `#V` each.
    rot: Vec<[f64; 2]>,
    rhs: Vec<[f64; 2]>,
}

impl ArapSolver {
    /// Precomputes cotangent weights and factorises −L on the free (non-handle) vertices.
    ///
    /// `rest`: `#V` rest positions in pixels; `triangles`: `#F` index triples (a mesh may have
    /// several connected components); `handles`: distinct vertex indices whose positions
    /// [`solve`](Self::solve) prescribes, in the order its `targets` are given.
    ///
    /// # Errors
    /// [`Error::Geometry`] for a bad mesh (as [`ArapEnergy::new`]), a handle out of range or
    /// repeated, or a connected component (a vertex in no triangle counts as its own component)
    /// without any handle: its position would be undetermined (a singular system). The message
    /// names one vertex of each such component.
    pub fn new(rest: &[[f64; 2]], triangles: &[[u32; 3]], handles: &[u32]) -> Result<Self> {
        if rest.is_empty() {
            return Err(Error::geometry("arap mesh", "has no vertex"));
        }
        let p = positions_f64(rest)?;
        let edges = cotan_weights(&p, triangles)?;
        let energy = ArapEnergy::from_weights(&p, &edges);
        if let Some((k, &h)) = handles.iter().enumerate().find(|&(_, &h)| h as usize >= rest.len()) {
            return Err(Error::geometry(
                format!("arap handle {k}"),
                format!("is vertex {h}, past the {} vertices", rest.len()),
            ));
        }
        check_every_component_has(rest.len(), triangles, handles, "handle")?;
        let mut q = laplacian_from_edges(rest.len(), &edges)?;
        // −L is the quadratic form's matrix (half the Hessian of F); negate in place.
        q.val_mut().iter_mut().for_each(|v| *v = -*v);
        let system = MinQuadWithFixed::new(q.as_ref(), handles)?;
        let n = rest.len();
        Ok(Self {
            energy,
            system,
            rot: vec![[1.0, 0.0]; n],
            rhs: vec![[0.0; 2]; n],
        })
    }

    /// Number of vertices `#V`.
    pub fn vertex_count(&self) -> usize {
        self.energy.vertex_count()
    }

    /// The handle vertices, in the order `targets` is given.
    pub fn handles(&self) -> &[u32] {
        self.system.fixed()
    }

    /// The ARAP energy being minimised (for monitoring), at `#V` positions.
    pub fn energy(&self) -> &ArapEnergy<f64> {
        &self.energy
    }

    /// Deforms the mesh so that handle `k` lands on `targets[k]` exactly and the rest is as rigid
    /// as possible: starting from `initial` (its handle rows replaced by the targets), runs
    /// `iterations` × (local rotation fit, global solve) and returns the `#V` positions.
    /// `iterations = 0` returns `initial` with the handles moved. Given an `initial` whose handle
    /// rows already hold the targets, this is the same iteration as libigl's `arap_solve` with
    /// `ARAP_ENERGY_TYPE_SPOKES` (libigl fits its first rotations before moving the handles); the
    /// two agree to ~1e-11 px on 1k/5k-vertex meshes (bench/arap_libigl.py).
    ///
    /// Typical use (apes-part-extraction.md appendix B): `initial = rest` and a few iterations
    /// (libigl's default is 10); the result is not a converged minimum, only a decreasing energy.
    ///
    /// Non-finite targets or initial positions propagate into the result (NaN), they do not panic.
    ///
    /// # Panics
    /// If `targets.len()` differs from the number of handles or `initial.len()` from `#V` (caller
    /// bugs).
    pub fn solve(&mut self, targets: &[[f64; 2]], iterations: usize, initial: &[[f64; 2]]) -> Vec<[f64; 2]> {
        assert_eq!(
            targets.len(),
            self.system.fixed().len(),
            "arap: {} targets for {} handles",
            targets.len(),
            self.system.fixed().len()
        );
        self.energy.check_len(initial.len());
        let mut x = initial.to_vec();
        for (&h, t) in self.system.fixed().iter().zip(targets) {
            x[h as usize] = *t;
        }
        for _ in 0..iterations {
            self.energy.fit_rotations(x.as_flattened(), &mut self.rot);
            self.energy.rotated_rest_edges(&self.rot, &mut self.rhs);
            self.system.solve(&self.rhs, targets, &mut x);
        }
        x
    }
}

/// A point of the mesh given by barycentric weights on one triangle's corners, which
/// [`ArapFit`] pulls towards a target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshPoint {
    /// The triangle's corners.
    pub corners: [u32; 3],
    /// Their barycentric weights (summing to one for a point inside the triangle).
    pub weights: [f64; 3],
}

impl MeshPoint {
    /// Where the point lies among `positions`.
    pub fn locate(&self, positions: &[[f64; 2]]) -> [f64; 2] {
        let mut p = [0.0; 2];
        for (&c, &b) in self.corners.iter().zip(&self.weights) {
            p[0] += b * positions[c as usize][0];
            p[1] += b * positions[c as usize][1];
        }
        p
    }
}

/// ARAP deformation pulled by soft targets (apes-part-extraction.md appendix B, with
/// correspondences in place of the paper's image term): minimises
/// `stiffness · E(v̂) + Σ_k ‖p_k(v̂) − y_k‖²` over the deformed positions v̂, where E is the ARAP
/// energy of [`ArapEnergy`] and p_k a [`MeshPoint`] — so noisy targets are averaged, not met, and
/// the mesh bends only as far as they agree. Local/global iterations as [`ArapSolver`]; the
/// global step's matrix, 2·stiffness·(−L) + Σ_k b_k b_kᵀ (half the Hessian of the objective for
/// fixed rotations), is factorised once in [`new`](Self::new), so a fit costs two sparse
/// triangular solves per iteration.
#[derive(Debug)]
pub struct ArapFit {
    energy: ArapEnergy<f64>,
    system: MinQuadWithFixed,
    points: Vec<MeshPoint>,
    stiffness: f64,
    /// Scratch: rotations and the right-hand side, `#V` each.
    rot: Vec<[f64; 2]>,
    rhs: Vec<[f64; 2]>,
}

impl ArapFit {
    /// Precomputes cotangent weights and factorises the global step's matrix for pulling the
    /// `points` of the mesh (`rest`, `triangles`) with weight 1 each against the ARAP energy's
    /// `stiffness`.
    ///
    /// # Errors
    /// [`Error::Geometry`] for a bad mesh (as [`ArapEnergy::new`]), a point naming a vertex out
    /// of range or with a weight that is not finite, a stiffness that is not positive and finite,
    /// or a connected component without any point of non-zero weight (its position would be
    /// undetermined).
    pub fn new(rest: &[[f64; 2]], triangles: &[[u32; 3]], points: &[MeshPoint], stiffness: f64) -> Result<Self> {
        if rest.is_empty() {
            return Err(Error::geometry("arap mesh", "has no vertex"));
        }
        if !(stiffness > 0.0 && stiffness.is_finite()) {
            return Err(Error::geometry(
                "arap fit",
                format!("stiffness {stiffness} is not a positive number"),
            ));
        }
        let n = rest.len();
        if let Some((k, point)) = points
            .iter()
            .enumerate()
            .find(|(_, q)| q.corners.iter().any(|&c| c as usize >= n) || q.weights.iter().any(|w| !w.is_finite()))
        {
            return Err(Error::geometry(
                format!("arap fit point {k}"),
                format!("{point:?} names a vertex past the {n} vertices or has a weight that is not finite"),
            ));
        }
        let p = positions_f64(rest)?;
        let edges = cotan_weights(&p, triangles)?;
        let energy = ArapEnergy::from_weights(&p, &edges);
        let pulled: Vec<u32> = points
            .iter()
            .flat_map(|q| q.corners.iter().zip(&q.weights).filter(|(_, w)| **w != 0.0).map(|(&c, _)| c))
            .collect();
        check_every_component_has(n, triangles, &pulled, "point pulling it")?;
        let mut entries = std::collections::BTreeMap::<(usize, usize), f64>::new();
        let mut add = |i: usize, j: usize, v: f64| *entries.entry((i, j)).or_insert(0.0) += v;
        for e in &edges {
            let (i, j, w) = (e.i as usize, e.j as usize, 2.0 * stiffness * e.w);
            add(i, i, w);
            add(j, j, w);
            add(i, j, -w);
            add(j, i, -w);
        }
        for q in points {
            for (&a, &wa) in q.corners.iter().zip(&q.weights) {
                for (&b, &wb) in q.corners.iter().zip(&q.weights) {
                    add(a as usize, b as usize, wa * wb);
                }
            }
        }
        let triplets: Vec<Triplet<usize, usize, f64>> = entries.into_iter().map(|((i, j), v)| Triplet::new(i, j, v)).collect();
        let q = SparseColMat::try_new_from_triplets(n, n, &triplets)
            .map_err(|e| Error::geometry("arap fit", format!("cannot assemble the {n}×{n} sparse matrix: {e:?}")))?;
        let system = MinQuadWithFixed::new(q.as_ref(), &[])?;
        Ok(Self {
            energy,
            system,
            points: points.to_vec(),
            stiffness,
            rot: vec![[1.0, 0.0]; n],
            rhs: vec![[0.0; 2]; n],
        })
    }

    /// The ARAP energy of the fit, at `#V` positions.
    pub fn energy(&self) -> &ArapEnergy<f64> {
        &self.energy
    }

    /// The objective `stiffness · E(v̂) + Σ_k ‖p_k(v̂) − y_k‖²` at `deformed`.
    ///
    /// # Panics
    /// As [`solve`](Self::solve).
    pub fn objective(&self, targets: &[[f64; 2]], deformed: &[[f64; 2]]) -> f64 {
        self.check_targets(targets.len());
        let pull: f64 = self
            .points
            .iter()
            .zip(targets)
            .map(|(q, y)| {
                let p = q.locate(deformed);
                (p[0] - y[0]).powi(2) + (p[1] - y[1]).powi(2)
            })
            .sum();
        self.stiffness * self.energy.energy(deformed) + pull
    }

    /// Pulls point `k` towards `targets[k]`: starting from `initial`, runs `iterations` ×
    /// (local rotation fit, global solve) and returns the `#V` positions. The objective never
    /// increases from one iteration to the next.
    ///
    /// # Panics
    /// If `targets.len()` differs from the number of points or `initial.len()` from `#V` (caller
    /// bugs).
    pub fn solve(&mut self, targets: &[[f64; 2]], iterations: usize, initial: &[[f64; 2]]) -> Vec<[f64; 2]> {
        self.check_targets(targets.len());
        self.energy.check_len(initial.len());
        let mut x = initial.to_vec();
        for _ in 0..iterations {
            self.energy.fit_rotations(x.as_flattened(), &mut self.rot);
            self.energy.rotated_rest_edges(&self.rot, &mut self.rhs);
            for r in &mut self.rhs {
                *r = [2.0 * self.stiffness * r[0], 2.0 * self.stiffness * r[1]];
            }
            for (q, y) in self.points.iter().zip(targets) {
                for (&c, &w) in q.corners.iter().zip(&q.weights) {
                    let r = &mut self.rhs[c as usize];
                    *r = [r[0] + w * y[0], r[1] + w * y[1]];
                }
            }
            self.system.solve(&self.rhs, &[], &mut x);
        }
        x
    }

    fn check_targets(&self, len: usize) {
        assert_eq!(len, self.points.len(), "arap fit: {len} targets for {} points", self.points.len());
    }
}

/// Union-find over triangles: every connected component must contain one of `handles` (a
/// `what`, for the message).
fn check_every_component_has(n: usize, triangles: &[[u32; 3]], handles: &[u32], what: &str) -> Result<()> {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for t in triangles {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut has_handle = vec![false; n];
    for &h in handles {
        let root = find(&mut parent, h);
        has_handle[root as usize] = true;
    }
    let mut missing = Vec::new();
    for v in 0..n as u32 {
        if find(&mut parent, v) == v && !has_handle[v as usize] {
            missing.push(v);
        }
    }
    match missing.len() {
        0 => Ok(()),
        count => {
            let shown: Vec<String> = missing.iter().take(8).map(|v| v.to_string()).collect();
            Err(Error::geometry(
                "arap mesh",
                format!(
                    "{count} connected component(s) have no {what}, so their position is undetermined \
                     (expected at least one {what} per component); they contain vertices {}{}",
                    shown.join(", "),
                    if count > 8 { ", …" } else { "" }
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    /// A jittered `nx × ny` grid with cell size `h` pixels, positive-area triangles.
    fn grid(nx: usize, ny: usize, h: f64, seed: u64) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut p = Vec::new();
        for y in 0..=ny {
            for x in 0..=nx {
                p.push([
                    h * (x as f64 + rng.random_range(-0.25..0.25)),
                    h * (y as f64 + rng.random_range(-0.25..0.25)),
                ]);
            }
        }
        let id = |x: usize, y: usize| (y * (nx + 1) + x) as u32;
        let mut t = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                t.push([id(x, y), id(x + 1, y), id(x, y + 1)]);
                t.push([id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        (p, t)
    }

    fn jitter(p: &[[f64; 2]], amount: f64, seed: u64) -> Vec<[f64; 2]> {
        let mut rng = StdRng::seed_from_u64(seed);
        p.iter()
            .map(|v| [v[0] + rng.random_range(-amount..amount), v[1] + rng.random_range(-amount..amount)])
            .collect()
    }

    /// Checks an analytic vector-Jacobian product against central differences of <g, f(x)>
    /// (STYLE.md).
    fn assert_vjp_fd(f: impl Fn(&[f64]) -> Vec<f64>, x: &[f64], g: &[f64], vjp: &[f64]) {
        let h = 1e-6; // truncation ~h², rounding ~eps/h ≈ 1e-10: both far below the tolerance
        let l = |x: &[f64]| f(x).iter().zip(g).map(|(a, b)| a * b).sum::<f64>();
        for i in 0..x.len() {
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            (xp[i], xm[i]) = (x[i] + h, x[i] - h);
            let fd = (l(&xp) - l(&xm)) / (2.0 * h);
            assert!((vjp[i] - fd).abs() <= 1e-6 * (1.0 + fd.abs()), "x[{i}]: {} vs fd {fd}", vjp[i]);
        }
    }

    #[test]
    fn rigid_motion_has_exact_rotations_and_zero_energy() {
        let (rest, tris) = grid(8, 6, 30.0, 1);
        let energy = ArapEnergy::new(&rest, &tris).unwrap();
        for theta in [0.0, 0.3, -2.0, 3.1] {
            let (c, s) = (f64::cos(theta), f64::sin(theta));
            let moved: Vec<[f64; 2]> = rest
                .iter()
                .map(|v| [c * v[0] - s * v[1] + 17.5, s * v[0] + c * v[1] - 40.0])
                .collect();
            for (i, r) in energy.rotations(&moved).iter().enumerate() {
                assert!((r[0] - c).abs() < 1e-12 && (r[1] - s).abs() < 1e-12, "θ={theta} vertex {i}: {r:?}");
            }
            let e = energy.energy(&moved);
            assert!(e.abs() < 1e-10, "θ={theta}: energy {e}");
            let mut g = vec![0.0; 2 * rest.len()];
            energy.energy_and_gradient(moved.as_flattened(), &mut g).unwrap();
            assert!(g.iter().all(|v| v.abs() < 1e-9), "rigid motion has non-zero gradient");
        }
        // A non-rigid deformation does cost energy.
        assert!(energy.energy(&jitter(&rest, 3.0, 2)) > 1.0);
    }

    #[test]
    fn energy_matches_the_double_sum_of_eq_2() {
        // Straight from eq. 2: for every vertex i and neighbour j, with R_i fitted by brute force
        // over 20 000 angles (then refined), independent of the closed form.
        let (rest, tris) = grid(3, 3, 10.0, 5);
        let deformed = jitter(&rest, 2.0, 6);
        let edges = cotan_weights(&rest, &tris).unwrap();
        let mut nbrs = vec![Vec::new(); rest.len()];
        for e in &edges {
            nbrs[e.i as usize].push((e.j as usize, e.w));
            nbrs[e.j as usize].push((e.i as usize, e.w));
        }
        let cell = |i: usize, th: f64| -> f64 {
            let (c, s) = (th.cos(), th.sin());
            nbrs[i]
                .iter()
                .map(|&(j, w)| {
                    let e = [rest[i][0] - rest[j][0], rest[i][1] - rest[j][1]];
                    let d = [deformed[i][0] - deformed[j][0], deformed[i][1] - deformed[j][1]];
                    let r = [d[0] - (c * e[0] - s * e[1]), d[1] - (s * e[0] + c * e[1])];
                    w * (r[0] * r[0] + r[1] * r[1])
                })
                .sum()
        };
        let mut total = 0.0;
        for i in 0..rest.len() {
            let mut best = (0..20_000)
                .map(|k| k as f64 * std::f64::consts::TAU / 20_000.0)
                .fold((f64::MAX, 0.0), |b, th| {
                    let v = cell(i, th);
                    if v < b.0 {
                        (v, th)
                    } else {
                        b
                    }
                });
            let mut step = std::f64::consts::TAU / 20_000.0;
            for _ in 0..60 {
                for th in [best.1 - step, best.1 + step] {
                    if cell(i, th) < best.0 {
                        best = (cell(i, th), th);
                    }
                }
                step *= 0.5;
            }
            total += best.0;
        }
        let ours = arap_energy(&rest, &deformed, &tris).unwrap();
        assert!((ours - total).abs() <= 1e-9 * total, "closed form {ours} vs brute force {total}");
    }

    #[test]
    fn gradient_matches_central_differences() {
        let (rest, tris) = grid(4, 3, 20.0, 7);
        let deformed = jitter(&rest, 4.0, 8);
        let energy = ArapEnergy::new(&rest, &tris).unwrap();
        let x: Vec<f64> = deformed.as_flattened().to_vec();
        let mut grad = vec![0.0; x.len()];
        let e = energy.energy_and_gradient(&x, &mut grad).unwrap();
        assert_eq!(e.len(), 1);
        let f = |x: &[f64]| {
            let mut g = vec![0.0; x.len()];
            energy.energy_and_gradient(x, &mut g).unwrap()
        };
        assert_vjp_fd(f, &x, &[1.0], &grad);
    }

    #[test]
    fn f32_batch_matches_f64_items() {
        let (rest, tris) = grid(10, 8, 25.0, 9);
        let e64 = ArapEnergy::new(&rest, &tris).unwrap();
        let rest32: Vec<[f32; 2]> = rest.iter().map(|v| [v[0] as f32, v[1] as f32]).collect();
        let e32 = ArapEnergy::new(&rest32, &tris).unwrap();
        let items: Vec<Vec<[f64; 2]>> = (0..5).map(|b| jitter(&rest, 2.0 + b as f64, 10 + b)).collect();
        let flat32: Vec<f32> = items.iter().flat_map(|it| it.as_flattened().iter().map(|&v| v as f32)).collect();
        let mut g32 = vec![0.0f32; flat32.len()];
        let energies = e32.energy_and_gradient(&flat32, &mut g32).unwrap();
        assert_eq!(energies.len(), items.len());
        for (b, item) in items.iter().enumerate() {
            // Compare with f64 at the f32-rounded positions so only arithmetic precision differs.
            let x: Vec<f64> = flat32[b * 2 * rest.len()..(b + 1) * 2 * rest.len()]
                .iter()
                .map(|&v| v as f64)
                .collect();
            let mut g = vec![0.0; x.len()];
            let e = e64.energy_and_gradient(&x, &mut g).unwrap()[0];
            assert!((energies[b] as f64 - e).abs() <= 1e-4 * e, "item {b}: {} vs {e}", energies[b]);
            let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (k, (&a, &r)) in g32[b * x.len()..(b + 1) * x.len()].iter().zip(&g).enumerate() {
                assert!((a as f64 - r).abs() <= 1e-3 * gmax, "item {b} grad[{k}]: {a} vs {r}");
            }
            assert_eq!(item.len(), rest.len());
        }
        let mut short = vec![0.0f32; 3];
        assert!(e32.energy_and_gradient(&flat32[..3], &mut short).is_err());
    }

    /// A dense reference of the same iteration: rotations from the 2×2 covariance matrix
    /// S_i = Σ_j w_ij ê_ij e_ijᵀ (closest rotation of a 2×2 matrix), the full 2V×... system
    /// assembled densely and solved by Gaussian elimination with partial pivoting.
    fn dense_reference(rest: &[[f64; 2]], tris: &[[u32; 3]], handles: &[u32], targets: &[[f64; 2]], iterations: usize) -> Vec<[f64; 2]> {
        let n = rest.len();
        let edges = cotan_weights(rest, tris).unwrap();
        let mut w = vec![vec![0.0; n]; n];
        for e in &edges {
            w[e.i as usize][e.j as usize] = e.w;
            w[e.j as usize][e.i as usize] = e.w;
        }
        let mut x = rest.to_vec();
        for (&h, t) in handles.iter().zip(targets) {
            x[h as usize] = *t;
        }
        for _ in 0..iterations {
            let rot: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let mut s = [[0.0; 2]; 2];
                    for j in 0..n {
                        let e = [rest[i][0] - rest[j][0], rest[i][1] - rest[j][1]];
                        let d = [x[i][0] - x[j][0], x[i][1] - x[j][1]];
                        for (a, row) in s.iter_mut().enumerate() {
                            for (b, v) in row.iter_mut().enumerate() {
                                *v += w[i][j] * d[a] * e[b];
                            }
                        }
                    }
                    let (c, sn) = (s[0][0] + s[1][1], s[1][0] - s[0][1]);
                    let norm = c.hypot(sn);
                    [c / norm, sn / norm]
                })
                .collect();
            // Rows: free vertices get Σ_j w_ij (x_i − x_j) = Σ_j ½ w_ij (R_i + R_j) e_ij; handles
            // get x_i = target.
            for dim in 0..2 {
                let mut a = vec![vec![0.0; n + 1]; n];
                for i in 0..n {
                    if let Some(k) = handles.iter().position(|&h| h as usize == i) {
                        a[i][i] = 1.0;
                        a[i][n] = targets[k][dim];
                        continue;
                    }
                    for j in 0..n {
                        if w[i][j] == 0.0 {
                            continue;
                        }
                        a[i][i] += w[i][j];
                        a[i][j] -= w[i][j];
                        let (c, s) = (rot[i][0] + rot[j][0], rot[i][1] + rot[j][1]);
                        let e = [rest[i][0] - rest[j][0], rest[i][1] - rest[j][1]];
                        let re = [c * e[0] - s * e[1], s * e[0] + c * e[1]];
                        a[i][n] += 0.5 * w[i][j] * re[dim];
                    }
                }
                for col in 0..n {
                    let piv = (col..n).max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs())).unwrap();
                    a.swap(col, piv);
                    let pivot = a[col].clone();
                    for (r, row) in a.iter_mut().enumerate() {
                        if r != col {
                            let f = row[col] / pivot[col];
                            for (v, p) in row[col..].iter_mut().zip(&pivot[col..]) {
                                *v -= f * p;
                            }
                        }
                    }
                }
                for i in 0..n {
                    x[i][dim] = a[i][n] / a[i][i];
                }
            }
        }
        x
    }

    fn max_diff(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p[0] - q[0]).abs().max((p[1] - q[1]).abs()))
            .fold(0.0, f64::max)
    }

    #[test]
    fn solver_matches_dense_reference() {
        let (rest, tris) = grid(5, 4, 20.0, 11);
        let handles = [0u32, 5, 24, 29, 14];
        let targets = [[0.0, 0.0], [120.0, -30.0], [-10.0, 90.0], [90.0, 110.0], [60.0, 40.0]];
        let mut solver = ArapSolver::new(&rest, &tris, &handles).unwrap();
        for iterations in [1, 4, 10] {
            let ours = solver.solve(&targets, iterations, &rest);
            let reference = dense_reference(&rest, &tris, &handles, &targets, iterations);
            let d = max_diff(&ours, &reference);
            assert!(d < 1e-9, "{iterations} iterations: max |ours − dense| = {d} px");
        }
    }

    #[test]
    fn handles_are_met_exactly_and_energy_never_increases() {
        let (rest, tris) = grid(12, 9, 15.0, 12);
        let handles = [0u32, 12, 60, 129, 120];
        let mut rng = StdRng::seed_from_u64(13);
        let targets: Vec<[f64; 2]> = handles
            .iter()
            .map(|&h| {
                [
                    rest[h as usize][0] + rng.random_range(-40.0..40.0),
                    rest[h as usize][1] + rng.random_range(-40.0..40.0),
                ]
            })
            .collect();
        let mut solver = ArapSolver::new(&rest, &tris, &handles).unwrap();
        let mut previous = f64::INFINITY;
        for iterations in 0..15 {
            let x = solver.solve(&targets, iterations, &rest);
            for (&h, t) in handles.iter().zip(&targets) {
                assert_eq!(x[h as usize], *t, "handle {h} after {iterations} iterations");
            }
            let e = solver.energy().energy(&x);
            assert!(
                e <= previous * (1.0 + 1e-12),
                "iteration {iterations}: energy rose from {previous} to {e}"
            );
            previous = e;
        }
        // The deformation did real work: from the handle-only start the energy dropped a lot.
        let start_positions = solver.solve(&targets, 0, &rest);
        let start = solver.energy().energy(&start_positions);
        assert!(previous < 0.5 * start, "energy {start} → {previous}");
    }

    #[test]
    fn rigid_targets_give_the_rigid_motion() {
        let (rest, tris) = grid(6, 6, 10.0, 14);
        let (c, s) = (0.6f64, 0.8f64);
        let motion = |v: [f64; 2]| [c * v[0] - s * v[1] + 5.0, s * v[0] + c * v[1] + 7.0];
        let handles = [0u32, 6, 48];
        let targets: Vec<[f64; 2]> = handles.iter().map(|&h| motion(rest[h as usize])).collect();
        let mut solver = ArapSolver::new(&rest, &tris, &handles).unwrap();
        let x = solver.solve(&targets, 200, &rest);
        let expected: Vec<[f64; 2]> = rest.iter().map(|&v| motion(v)).collect();
        assert!(max_diff(&x, &expected) < 1e-6, "max diff {}", max_diff(&x, &expected));
    }

    /// Points at the centres of every `step`-th triangle of a mesh.
    fn centre_points(tris: &[[u32; 3]], step: usize) -> Vec<MeshPoint> {
        tris.iter()
            .step_by(step)
            .map(|&corners| MeshPoint {
                corners,
                weights: [1.0 / 3.0; 3],
            })
            .collect()
    }

    #[test]
    fn fit_to_rigidly_moved_points_gives_the_rigid_motion() {
        let (rest, tris) = grid(6, 4, 10.0, 21);
        let (c, s) = (0.8f64, -0.6f64);
        let motion = |v: [f64; 2]| [c * v[0] - s * v[1] - 4.0, s * v[0] + c * v[1] + 9.0];
        let points = centre_points(&tris, 5);
        let targets: Vec<[f64; 2]> = points.iter().map(|q| motion(q.locate(&rest))).collect();
        let mut fit = ArapFit::new(&rest, &tris, &points, 0.5).unwrap();
        let x = fit.solve(&targets, 300, &rest);
        let expected: Vec<[f64; 2]> = rest.iter().map(|&v| motion(v)).collect();
        assert!(max_diff(&x, &expected) < 1e-5, "max diff {}", max_diff(&x, &expected));
    }

    #[test]
    fn fit_never_raises_its_objective_and_ends_where_its_gradient_vanishes() {
        let (rest, tris) = grid(5, 5, 12.0, 22);
        let points = centre_points(&tris, 3);
        // Targets that no rigid motion meets: every point pulled its own way.
        let targets: Vec<[f64; 2]> = jitter(&points.iter().map(|q| q.locate(&rest)).collect::<Vec<_>>(), 6.0, 23);
        let mut fit = ArapFit::new(&rest, &tris, &points, 0.3).unwrap();
        let mut previous = f64::INFINITY;
        let mut x = rest.clone();
        for _ in 0..40 {
            x = fit.solve(&targets, 1, &x);
            let f = fit.objective(&targets, &x);
            assert!(f <= previous * (1.0 + 1e-12), "objective rose from {previous} to {f}");
            previous = f;
        }
        let x = fit.solve(&targets, 2000, &x);
        // At the minimum the objective's central differences vanish (E is differentiable there:
        // every cell is deformed, none collapsed); a wrong factor between the ARAP and the pull
        // terms of the global step would leave a gradient of the size of the pulls.
        let h = 1e-5;
        let mut largest = 0.0f64;
        for i in 0..x.len() {
            for d in 0..2 {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[i][d] += h;
                xm[i][d] -= h;
                let g = (fit.objective(&targets, &xp) - fit.objective(&targets, &xm)) / (2.0 * h);
                largest = largest.max(g.abs());
            }
        }
        let pull = fit.objective(&targets, &rest);
        assert!(
            largest < 1e-4 * pull.sqrt(),
            "gradient {largest} at the fit (objective at rest {pull})"
        );
    }

    #[test]
    fn fit_reports_a_component_no_point_pulls() {
        let (mut rest, mut tris) = grid(2, 2, 10.0, 24);
        let offset = rest.len() as u32;
        rest.extend([[100.0, 0.0], [110.0, 0.0], [100.0, 10.0]]);
        tris.push([offset, offset + 1, offset + 2]);
        let points = centre_points(&tris[..2], 1);
        let err = ArapFit::new(&rest, &tris, &points, 1.0).unwrap_err().to_string();
        assert!(err.contains("1 connected component(s) have no point pulling it"), "{err}");
        let bad = [MeshPoint {
            corners: [0, 1, 99],
            weights: [0.5, 0.5, 0.0],
        }];
        let err = ArapFit::new(&rest, &tris, &bad, 1.0).unwrap_err().to_string();
        assert!(err.contains("point 0") && err.contains("past the 12 vertices"), "{err}");
        assert!(ArapFit::new(&rest, &tris, &points, 0.0).is_err());
    }

    #[test]
    fn components_without_handles_are_reported() {
        // Two separate triangles; an isolated vertex 6.
        let rest = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [5.0, 0.0], [6.0, 0.0], [5.0, 1.0], [9.0, 9.0]];
        let tris = [[0, 1, 2], [3, 4, 5]];
        let err = ArapSolver::new(&rest, &tris, &[1]).unwrap_err().to_string();
        assert!(
            err.contains("2 connected component(s) have no handle") && err.contains("vertices 3, 6"),
            "{err}"
        );
        assert!(ArapSolver::new(&rest, &tris, &[1, 4, 6]).is_ok());
        assert!(ArapSolver::new(&rest, &tris, &[1, 4, 9]).unwrap_err().to_string().contains("past"));
        assert!(ArapSolver::new(&rest, &tris, &[1, 4, 6, 4])
            .unwrap_err()
            .to_string()
            .contains("twice"));
        // One handle per component: each component follows its handle rigidly (energy 0).
        let mut solver = ArapSolver::new(&rest, &tris, &[1, 4, 6]).unwrap();
        let x = solver.solve(&[[3.0, 0.0], [6.0, 2.0], [9.0, 9.0]], 50, &rest);
        assert_eq!((x[1], x[4], x[6]), ([3.0, 0.0], [6.0, 2.0], [9.0, 9.0]));
        let e = solver.energy().energy(&x);
        assert!(e < 1e-12, "energy {e}: {x:?}");
    }

    #[test]
    fn mismatched_lengths_are_errors() {
        let (rest, tris) = grid(2, 2, 1.0, 0);
        assert!(arap_energy(&rest, &rest[1..], &tris).is_err());
        assert!(best_fit_rotations(&rest, &rest[1..], &tris).is_err());
        assert!(ArapEnergy::<f64>::new(&[], &[]).is_err());
    }
}
