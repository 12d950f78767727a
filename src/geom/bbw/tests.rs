//! Tests of the bounded biharmonic weights, against clarabel as the oracle.

use super::active_set::{Outcome, State, Work};
use super::*;
use crate::geom::cotan_laplacian::cotan_laplacian;
use rand::{rngs::StdRng, Rng, SeedableRng};

type Mesh = (Vec<[f64; 2]>, Vec<[u32; 3]>);

/// An `nx × ny`-cell grid from `origin`, unit cells jittered by up to ±0.2 (seeded), two
/// triangles per cell with positive signed area (y down).
fn grid(nx: usize, ny: usize, origin: [f64; 2], seed: u64) -> Mesh {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut p = Vec::new();
    for y in 0..=ny {
        for x in 0..=nx {
            p.push([
                origin[0] + x as f64 + rng.random_range(-0.2..0.2),
                origin[1] + y as f64 + rng.random_range(-0.2..0.2),
            ]);
        }
    }
    (p, grid_triangles(nx, ny, 0))
}

fn grid_triangles(nx: usize, ny: usize, first: u32) -> Vec<[u32; 3]> {
    let id = |x: usize, y: usize| first + (y * (nx + 1) + x) as u32;
    let mut t = Vec::new();
    for y in 0..ny {
        for x in 0..nx {
            t.push([id(x, y), id(x + 1, y), id(x, y + 1)]);
            t.push([id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
        }
    }
    t
}

/// An L-shaped mesh (a grid with its upper-right quarter removed), so that weights have to
/// bend round a corner and many hit their bounds.
fn l_shape(seed: u64) -> Mesh {
    let (n, half) = (10, 5);
    let (p, t) = grid(n, n, [0.0, 0.0], seed);
    let keep = |v: u32| {
        let (x, y) = (v as usize % (n + 1), v as usize / (n + 1));
        !(x > half && y < half)
    };
    let t: Vec<[u32; 3]> = t.into_iter().filter(|tri| tri.iter().all(|&v| keep(v))).collect();
    // Renumber the vertices still used.
    let mut new = vec![u32::MAX; p.len()];
    let mut q = Vec::new();
    for tri in &t {
        for &v in tri {
            if new[v as usize] == u32::MAX {
                new[v as usize] = q.len() as u32;
                q.push(p[v as usize]);
            }
        }
    }
    (q, t.iter().map(|tri| tri.map(|v| new[v as usize])).collect())
}

/// Index of the vertex nearest to `target`.
fn nearest(p: &[[f64; 2]], target: [f64; 2]) -> u32 {
    (0..p.len())
        .min_by(|&a, &b| dist2(p[a], target).total_cmp(&dist2(p[b], target)))
        .unwrap() as u32
}

fn dense(n: usize, entries: impl Iterator<Item = (usize, usize, f64)>) -> Vec<Vec<f64>> {
    let mut d = vec![vec![0.0; n]; n];
    for (i, j, v) in entries {
        d[i][j] += v;
    }
    d
}

/// Q = L M̄⁻¹ L, dense, from the crate's cotangent Laplacian and [`lumped_mass`] — independent
/// of the sparse assembly and the AMD renumbering in [`Biharmonic`].
fn dense_bilaplacian(p: &[[f64; 2]], t: &[[u32; 3]], kind: MassMatrix) -> Vec<Vec<f64>> {
    let n = p.len();
    let l = cotan_laplacian(p, t).unwrap();
    let l = dense(n, l.triplet_iter().map(|e| (e.row, e.col, *e.val)));
    let m = lumped_mass(p, t, kind);
    let mean = m.iter().sum::<f64>() / n as f64;
    let mut q = vec![vec![0.0; n]; n];
    for i in 0..n {
        for k in 0..n {
            if l[i][k] != 0.0 {
                for j in 0..n {
                    q[i][j] += l[i][k] * l[k][j] * mean / m[k];
                }
            }
        }
    }
    q
}

/// Handle k's weights from the interior-point QP solver clarabel (the oracle): minimise
/// ½ xᵀ Q_ff x + (Q_fc y)ᵀ x over the free vertices subject to 0 ≤ x ≤ 1, y = δ_k.
fn oracle(q: &[Vec<f64>], handles: &[u32], k: usize) -> Vec<f64> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
    let n = q.len();
    let free: Vec<usize> = (0..n).filter(|v| !handles.contains(&(*v as u32))).collect();
    let m = free.len();
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for (c, &j) in free.iter().enumerate() {
        for (r, &i) in free.iter().enumerate().take(c + 1) {
            if q[i][j] != 0.0 {
                rowval.push(r);
                nzval.push(q[i][j]);
            }
        }
        colptr.push(rowval.len());
    }
    let p_mat = CscMatrix::new(m, m, colptr, rowval, nzval);
    let h = handles[k] as usize;
    let lin: Vec<f64> = free.iter().map(|&i| q[i][h]).collect();
    let a = CscMatrix::new(
        2 * m,
        m,
        (0..=m).map(|j| 2 * j).collect(),
        (0..m).flat_map(|j| [j, m + j]).collect(),
        (0..m).flat_map(|_| [1.0, -1.0]).collect(),
    );
    let b: Vec<f64> = (0..2 * m).map(|i| if i < m { 1.0 } else { 0.0 }).collect();
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .build()
        .unwrap();
    let mut solver = DefaultSolver::new(&p_mat, &lin, &a, &b, &[NonnegativeConeT(2 * m)], settings).unwrap();
    solver.solve();
    assert!(
        matches!(solver.solution.status, SolverStatus::Solved),
        "clarabel: {:?}",
        solver.solution.status
    );
    let mut w = vec![0.0; n];
    w[h] = 1.0;
    for (r, &i) in free.iter().enumerate() {
        w[i] = solver.solution.x[r].clamp(0.0, 1.0);
    }
    w
}

#[test]
fn weights_match_a_qp_solver_before_and_after_normalisation() {
    let (p, t) = l_shape(1);
    let handles: Vec<u32> = [[0.0, 0.0], [10.0, 10.0], [10.0, 5.0], [0.0, 10.0], [5.0, 5.0]]
        .iter()
        .map(|&c| nearest(&p, c))
        .collect();
    let q = dense_bilaplacian(&p, &t, MassMatrix::Barycentric);
    let options = BbwOptions::default();
    let raw = raw_weights(&p, &t, &handles, &options).unwrap();
    let h = handles.len();
    let expected: Vec<Vec<f64>> = (0..h).map(|k| oracle(&q, &handles, k)).collect();
    let mut worst: f64 = 0.0;
    let mut at_zero = 0;
    for (k, column) in expected.iter().enumerate() {
        for (v, &e) in column.iter().enumerate() {
            worst = worst.max((raw.weights[v * h + k] - e).abs());
            at_zero += usize::from(e < 1e-9);
        }
    }
    // Measured 5e-7 with the tolerance 1e-6.
    assert!(worst < 1e-4, "raw weights differ from the oracle by {worst:e}");
    assert!(at_zero > p.len() / 2, "only {at_zero} weights at 0: the bounds are not exercised");
    let cold = raw_weights(&p, &t, &handles, &options.with_warm_start_iterations(0)).unwrap();
    let warm_vs_cold = cold
        .weights
        .iter()
        .zip(&raw.weights)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(warm_vs_cold < 1e-5, "with and without the ADMM warm start: {warm_vs_cold:e} apart");
    let normalised = bbw(&p, &t, &handles, &options).unwrap();
    for v in 0..p.len() {
        let sum: f64 = (0..h).map(|k| expected[k][v]).sum();
        for (k, column) in expected.iter().enumerate() {
            let (ours, theirs) = (normalised.row(v)[k], column[v] / sum);
            assert!((ours - theirs).abs() < 1e-4, "vertex {v} handle {k}: {ours} vs oracle {theirs}");
        }
    }
}

/// libigl 2.6.3's `igl.bbw` (Voronoi mass, active set, unnormalised) on this mesh, from:
/// ```python
/// import igl, numpy as np, math
/// nx, ny = 5, 4
/// V = np.array([[x + 0.2 * math.sin(1.7 * x + 3.1 * y), y + 0.2 * math.cos(2.3 * x - 1.3 * y)]
///               for y in range(ny + 1) for x in range(nx + 1)])
/// i = lambda x, y: y * (nx + 1) + x
/// F = np.array([t for y in range(ny) for x in range(nx) for t in
///               ([i(x, y), i(x + 1, y), i(x, y + 1)], [i(x + 1, y), i(x + 1, y + 1), i(x, y + 1)])])
/// W = igl.bbw(V, F, np.array([0, 17, 29]), np.eye(3))
/// ```
const LIBIGL_WEIGHTS: [[f64; 3]; 30] = [
    [1.000000000, 0.000000000, 0.000000000],
    [0.855819711, 0.144955224, 0.006702951],
    [0.698574549, 0.297362964, 0.018937346],
    [0.439415665, 0.562743926, 0.028423957],
    [0.166878231, 0.894333435, 0.003887593],
    [0.080810274, 1.000000000, 0.000000000],
    [0.954215815, 0.020401916, 0.024383447],
    [0.869548136, 0.096687625, 0.035888831],
    [0.634776514, 0.337511734, 0.042131524],
    [0.332031974, 0.630798143, 0.062851201],
    [0.188359111, 0.817205525, 0.032668545],
    [0.098198971, 0.952564144, 0.000000000],
    [0.863701382, 0.061267202, 0.072539215],
    [0.708114359, 0.173688025, 0.117656346],
    [0.583619707, 0.298516618, 0.122451551],
    [0.387170761, 0.474815458, 0.147389271],
    [0.110132874, 0.724300642, 0.168834116],
    [0.000000000, 1.000000000, 0.000000000],
    [0.763680662, 0.090429767, 0.140469614],
    [0.710582294, 0.124508846, 0.159919106],
    [0.506654809, 0.258677878, 0.231683996],
    [0.271176956, 0.430560161, 0.297822625],
    [0.128274250, 0.428245455, 0.440571585],
    [0.047181410, 0.490504728, 0.456849658],
    [0.728000997, 0.095037255, 0.170111297],
    [0.635238966, 0.155951607, 0.203182830],
    [0.500400349, 0.218028785, 0.276285785],
    [0.347812711, 0.311074418, 0.337108069],
    [0.095324687, 0.323387293, 0.577138643],
    [0.000000000, 0.000000000, 1.000000000],
];

#[test]
fn voronoi_weights_match_libigl() {
    let (nx, ny) = (5, 4);
    let p: Vec<[f64; 2]> = (0..=ny)
        .flat_map(|y| {
            (0..=nx).map(move |x| {
                let (x, y) = (x as f64, y as f64);
                [x + 0.2 * (1.7 * x + 3.1 * y).sin(), y + 0.2 * (2.3 * x - 1.3 * y).cos()]
            })
        })
        .collect();
    let t = grid_triangles(nx, ny, 0);
    let options = BbwOptions::default().with_mass(MassMatrix::Voronoi);
    let raw = raw_weights(&p, &t, &[0, 17, 29], &options).unwrap();
    for (v, expected) in LIBIGL_WEIGHTS.iter().enumerate() {
        for (k, &e) in expected.iter().enumerate() {
            let ours = raw.weights[v * 3 + k];
            // libigl's values are printed to 1e-9; its active set and ours stop within ~1e-7.
            assert!((ours - e).abs() < 1e-6, "vertex {v} handle {k}: {ours} vs libigl {e}");
        }
    }
}

/// A grid whose rows are also stretched by up to ±2 % of their distance from the top, so that
/// far rows have badly shaped, even overlapping, triangles with negative cotangent weights,
/// and random handles. Seed 282 is the smallest of 600 such meshes on which the active-set
/// method cycled (456 vertices, 10 handles); it never did in 4,800 jittered grids without the
/// stretch.
fn stretched_grid(seed: u64) -> (Vec<[f64; 2]>, Vec<[u32; 3]>, Vec<u32>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let (nx, ny) = (rng.random_range(3..40), rng.random_range(3..40));
    let jitter = rng.random_range(0.0..0.35);
    let mut p = Vec::new();
    for y in 0..=ny {
        for x in 0..=nx {
            let dx = rng.random_range(-jitter..jitter);
            let stretch = rng.random_range(0.98..1.02);
            p.push([x as f64 + dx, y as f64 * stretch + rng.random_range(-jitter..jitter)]);
        }
    }
    let id = |x: usize, y: usize| (y * (nx + 1) + x) as u32;
    let mut t = Vec::new();
    for y in 0..ny {
        for x in 0..nx {
            let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
            if rng.random_bool(0.5) {
                t.extend([[a, b, d], [b, c, d]]);
            } else {
                t.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    let count = rng.random_range(1..30.min(p.len()));
    let mut handles: Vec<u32> = Vec::new();
    while handles.len() < count {
        let v = rng.random_range(0..p.len() as u32);
        if !handles.contains(&v) {
            handles.push(v);
        }
    }
    (p, t, handles)
}

#[test]
fn a_cycling_active_set_falls_back_to_projected_newton() {
    let (p, t, handles) = stretched_grid(282);
    assert_eq!((p.len(), handles.len()), (456, 10));
    // Cold start (the warm start avoids the cycle here) and a tolerance tight enough for this
    // ill-conditioned Q (see `BbwOptions::tolerance`).
    let options = BbwOptions::default()
        .with_tolerance(1e-9)
        .with_warm_start_iterations(0)
        .with_max_iterations(1000);
    let edges = cotan_weights(&p, &t).unwrap();
    let system = Biharmonic::new(p.len(), &edges, &lumped_mass(&p, &t, options.mass), &handles).unwrap();
    let initial = system.unconstrained().unwrap();
    let mut work = Work::new(&system, 0);
    let start = initial[0].iter().map(|&x| State::of(x, options.tolerance)).collect();
    let outcome = system
        .active_set(&mut work, start, options.tolerance, options.max_iterations)
        .unwrap();
    // Measured: the state of iteration 349 repeats an earlier one.
    assert!(
        matches!(outcome, Outcome::Stopped(_, iterations) if iterations < 1000),
        "the active set should cycle"
    );
    let raw = raw_weights(&p, &t, &handles, &options).unwrap();
    let q = dense_bilaplacian(&p, &t, options.mass);
    for k in [0, 1] {
        let expected = oracle(&q, &handles, k);
        let worst = (0..p.len())
            .map(|v| (raw.weights[v * handles.len() + k] - expected[v]).abs())
            .fold(0.0, f64::max);
        // Measured 4.5e-6 and 4.9e-6.
        assert!(worst < 1e-3, "handle {k}: {worst:e} from the oracle");
    }
}

#[test]
fn projected_newton_alone_matches_the_oracle() {
    let (p, t) = l_shape(13);
    let handles: Vec<u32> = [[0.0, 0.0], [10.0, 10.0], [4.0, 6.0]].iter().map(|&c| nearest(&p, c)).collect();
    let mass = MassMatrix::Barycentric;
    let system = Biharmonic::new(p.len(), &cotan_weights(&p, &t).unwrap(), &lumped_mass(&p, &t, mass), &handles).unwrap();
    let initial = system.unconstrained().unwrap();
    let q = dense_bilaplacian(&p, &t, mass);
    for (k, x0) in initial.iter().enumerate() {
        let mut x: Vec<f64> = x0.iter().map(|w| w.clamp(0.0, 1.0)).collect();
        let iterations = system.projected_newton(&mut Work::new(&system, k), &mut x, 1e-6, 200).unwrap();
        assert!(iterations.is_some(), "handle {k}: no convergence");
        let expected = oracle(&q, &handles, k);
        for (&v, &w) in system.vertex.iter().zip(&x) {
            assert!(
                (w - expected[v as usize]).abs() < 1e-4,
                "handle {k} vertex {v}: {w} vs {}",
                expected[v as usize]
            );
        }
    }
}

#[test]
fn rows_are_a_partition_of_unity_in_bounds_with_delta_at_handles() {
    let (p, t) = grid(12, 9, [0.0, 0.0], 2);
    let handles = [0, 12, 129, 60, 35, 100];
    let w = bbw(&p, &t, &handles, &BbwOptions::default()).unwrap();
    assert_eq!((w.vertices(), w.handles), (p.len(), handles.len()));
    assert!(w.max_row_sum_deviation() > 0.01, "bounded rows should not sum to one by themselves");
    for v in 0..p.len() {
        let row = w.row(v);
        let sum: f64 = row.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "vertex {v}: row sums to {sum}");
        assert!(row.iter().all(|&x| (0.0..=1.0).contains(&x)), "vertex {v}: {row:?}");
    }
    for (k, &h) in handles.iter().enumerate() {
        let expected: Vec<f64> = (0..handles.len()).map(|j| f64::from(u8::from(j == k))).collect();
        assert_eq!(w.row(h as usize), &expected[..], "handle {k}");
    }
}

#[test]
fn equal_handle_translations_translate_every_vertex() {
    // Translation-only linear blend skinning: v' = v + Σ_k w_vk d_k. With every d_k = d and
    // rows summing to one, every vertex must move by exactly d.
    let (p, t) = l_shape(3);
    let handles: Vec<u32> = [[0.0, 0.0], [10.0, 10.0], [10.0, 5.0], [3.0, 7.0]]
        .iter()
        .map(|&c| nearest(&p, c))
        .collect();
    let w = bbw(&p, &t, &handles, &BbwOptions::default()).unwrap();
    let d = [37.25, -12.5];
    for (v, rest) in p.iter().enumerate() {
        let moved = [0, 1].map(|c| rest[c] + w.row(v).iter().map(|wk| wk * d[c]).sum::<f64>());
        for c in 0..2 {
            assert!(
                (moved[c] - rest[c] - d[c]).abs() < 1e-12,
                "vertex {v}: moved by {:?}",
                [moved[0] - rest[0], moved[1] - rest[1]]
            );
        }
    }
}

#[test]
fn weights_do_not_depend_on_unit_or_position() {
    let (p, t) = l_shape(4);
    let handles: Vec<u32> = [[0.0, 0.0], [10.0, 10.0], [10.0, 5.0]].iter().map(|&c| nearest(&p, c)).collect();
    let reference = bbw(&p, &t, &handles, &BbwOptions::default()).unwrap();
    for (scale, shift) in [(1e-3, [0.0, 0.0]), (1e3, [-5e4, 2e3]), (1.0, [640.0, 480.0])] {
        let moved: Vec<[f64; 2]> = p.iter().map(|v| [v[0] * scale + shift[0], v[1] * scale + shift[1]]).collect();
        let w = bbw(&moved, &t, &handles, &BbwOptions::default()).unwrap();
        assert_eq!(w.iterations, reference.iterations, "scale {scale}: another iteration path");
        let worst = w
            .weights
            .iter()
            .zip(&reference.weights)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "scale {scale} shift {shift:?}: weights differ by {worst:e}");
    }
}

#[test]
fn components_are_solved_apart() {
    // Two grids side by side: two handles in the first, one in the second.
    let (mut p, mut t) = grid(6, 5, [0.0, 0.0], 5);
    let (q, _) = grid(4, 4, [20.0, 0.0], 6);
    let first = p.len() as u32;
    p.extend(q);
    t.extend(grid_triangles(4, 4, first));
    let handles = [0, 41, first + 12];
    let w = bbw(&p, &t, &handles, &BbwOptions::default()).unwrap();
    for v in 0..p.len() {
        let row = w.row(v);
        if (v as u32) < first {
            assert_eq!(row[2], 0.0, "vertex {v} of the first grid");
            assert!((row[0] + row[1] - 1.0).abs() < 1e-12);
        } else {
            assert_eq!(row, &[0.0, 0.0, 1.0], "vertex {v} of the second grid");
        }
    }
}

#[test]
fn a_component_without_handle_is_named() {
    // Three grids; the second has no handle.
    let (mut p, mut t) = grid(3, 3, [0.0, 0.0], 7);
    for (k, origin) in [[10.0, 0.0], [20.0, 0.0]].into_iter().enumerate() {
        let (q, _) = grid(2, 2, origin, 8 + k as u64);
        let first = p.len() as u32;
        p.extend(q);
        t.extend(grid_triangles(2, 2, first));
    }
    let err = bbw(&p, &t, &[0, 30], &BbwOptions::default()).unwrap_err();
    let BbwError::UnpinnedComponents { components } = &err else {
        panic!("{err}")
    };
    assert_eq!(
        components,
        &[MeshComponent {
            index: 1,
            first_vertex: 16,
            vertices: 9,
            triangles: 8
        }]
    );
    assert_eq!(
        err.to_string(),
        "bbw: component 1 (9 vertices from vertex 16, 8 triangles) has no handle \
         (expected at least one handle in every connected component)"
    );
    let err = bbw(&p, &t, &[], &BbwOptions::default()).unwrap_err().to_string();
    assert!(
        err.starts_with("bbw: 3 connected components have no handle: component 0 ("),
        "{err}"
    );
}

#[test]
fn unused_vertices_are_an_error_unless_they_are_handles() {
    let (mut p, t) = grid(3, 3, [0.0, 0.0], 9);
    p.push([50.0, 50.0]);
    p.push([60.0, 50.0]);
    let err = bbw(&p, &t, &[0, 16], &BbwOptions::default()).unwrap_err();
    assert!(matches!(&err, BbwError::UnusedVertices { vertices } if vertices == &[17]), "{err}");
    assert_eq!(
        err.to_string(),
        "bbw: vertex 17 is used by no triangle (expected every vertex in a triangle, or a handle)"
    );
    let w = bbw(&p, &t, &[0, 16, 17], &BbwOptions::default()).unwrap();
    assert_eq!(w.row(16), &[0.0, 1.0, 0.0]);
    assert_eq!(w.row(5)[1], 0.0, "an isolated handle moves nothing else");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let (p, t) = grid(2, 2, [0.0, 0.0], 10);
    let o = BbwOptions::default();
    let msg = |r: Result<BbwWeights, BbwError>| r.unwrap_err().to_string();
    let mut nan = p.clone();
    nan[4][1] = f64::NAN;
    let err = msg(bbw(&nan, &t, &[0], &o));
    assert!(
        err.starts_with("bbw: vertex 4: position [") && err.ends_with(", NaN] is not finite (expected finite x and y)"),
        "{err}"
    );
    let mut bad_index = t.clone();
    bad_index[3][2] = 99;
    assert!(
        msg(bbw(&p, &bad_index, &[0], &o)).contains("triangle 3 ")
            && msg(bbw(&p, &bad_index, &[0], &o)).contains("index 99 is past the 9 vertices")
    );
    let mut repeated_corner = t.clone();
    repeated_corner[1] = [1, 1, 4];
    assert!(msg(bbw(&p, &repeated_corner, &[0], &o)).contains("triangle 1 [1, 1, 4] is degenerate"));
    let flat = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
    assert!(matches!(
        bbw(&flat, &[[0, 1, 2]], &[0], &o),
        Err(BbwError::DegenerateTriangle { triangle: 0, .. })
    ));
    assert_eq!(msg(bbw(&p, &t, &[0, 9], &o)), "bbw: handle 1: vertex 9 is past the 9 vertices");
    assert_eq!(
        msg(bbw(&p, &t, &[3, 0, 3], &o)),
        "bbw: handles 0 and 2 are both vertex 3 (expected distinct vertices)"
    );
    assert!(msg(bbw(&p, &t, &[0], &o.with_tolerance(f64::NAN))).starts_with("bbw: option tolerance: NaN"));
    let (p, t) = l_shape(10);
    let handles: Vec<u32> = [[0.0, 0.0], [10.0, 10.0], [5.0, 5.0]].iter().map(|&c| nearest(&p, c)).collect();
    assert!(matches!(
        bbw(&p, &t, &handles, &o.with_max_iterations(0)),
        Err(BbwError::NotConverged { iterations: 0, .. })
    ));
}

#[test]
fn trivial_cases() {
    let (p, t) = grid(3, 2, [0.0, 0.0], 11);
    let one = bbw(&p, &t, &[5], &BbwOptions::default()).unwrap();
    assert!(one.weights.iter().all(|&w| w == 1.0), "a single handle has weight 1 everywhere");
    let all: Vec<u32> = (0..p.len() as u32).collect();
    let w = bbw(&p, &t, &all, &BbwOptions::default()).unwrap();
    assert_eq!((w.iterations, w.max_row_sum_deviation()), (0, 0.0));
    let empty = bbw(&[], &[], &[], &BbwOptions::default()).unwrap();
    assert_eq!((empty.vertices(), empty.weights.len()), (0, 0));
}

#[test]
fn lumped_mass_by_hand() {
    // Right triangle, legs 3 (x) and 4 (y), area 6. Barycentric: 2 each. Voronoi: the
    // circumcentre is the hypotenuse's midpoint (1.5, 2); the right-angle corner's cell is the
    // 1.5 × 2 rectangle (3), the other two corners get 1.5 each.
    let p = [[0.0, 0.0], [3.0, 0.0], [0.0, 4.0]];
    assert_eq!(lumped_mass(&p, &[[0, 1, 2]], MassMatrix::Barycentric), vec![2.0; 3]);
    let v = lumped_mass(&p, &[[0, 1, 2]], MassMatrix::Voronoi);
    for (got, want) in v.iter().zip([3.0, 1.5, 1.5]) {
        assert!((got - want).abs() < 1e-12, "{v:?}");
    }
    // Obtuse at vertex 2 (area 2): ½ to it, ¼ to the others.
    let obtuse = [[0.0, 0.0], [4.0, 0.0], [1.0, 1.0]];
    assert_eq!(lumped_mass(&obtuse, &[[0, 1, 2]], MassMatrix::Voronoi), vec![0.5, 0.5, 1.0]);
    // Both sum to the area of a whole mesh.
    let (p, t) = grid(5, 4, [0.0, 0.0], 12);
    let area: f64 = t.iter().map(|tri| 0.5 * twice_signed_area(tri.map(|i| p[i as usize]))).sum();
    for kind in [MassMatrix::Barycentric, MassMatrix::Voronoi] {
        let total: f64 = lumped_mass(&p, &t, kind).iter().sum();
        assert!((total - area).abs() < 1e-12 * area, "{kind:?}: {total} vs {area}");
    }
}
