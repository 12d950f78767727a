#!/usr/bin/env python3
"""Bounded biharmonic weights: puppet's `geom::bbw` against libigl's `igl.bbw`, same meshes and handles.

Cases (benches/data):
  * character_1k.txt, character_5k.txt: the Triangle `pq30` character meshes of bench/arap_libigl.py
    with their 12 landmark handles;
  * hair_2k.txt: a hair-like band (a cap over the head continued by two wavy strands, 35 px wide)
    meshed by Triangle (`pq30a12`, ~2.1k vertices), pinned by the 103 boundary vertices of its
    scalp arc — the dense-pin case. `--write-data` rebuilds it.

In the same run, for each case:
  * libigl (PyPI `libigl`): `igl.bbw(V, F, b, I)` — Voronoi mass matrix, active set, rows
    unnormalised — median of REPEATS calls;
  * ours: `cargo run --release --example bbw_time` on the same file, with the default barycentric
    mass matrix (what the rig uses) and with libigl's Voronoi one; median of REPEATS calls after a
    warm-up, rows normalised (the example also writes the weights before normalisation);
  * accuracy: ours (Voronoi) against libigl's weights, both before normalisation; ours
    (barycentric) against an independent QP oracle: Q = L M⁻¹ L from libigl's `cotmatrix` and
    barycentric `massmatrix`, each handle solved by the interior-point solver clarabel (PyPI).

Tolerances (the script exits 1 past them): |ours (Voronoi) − libigl| ≤ 1e-5 (the same QP solved by
two active-set codes to their stopping tolerances); |ours − oracle| ≤ 1e-3 (the issue's goal);
ours normalised rows sum to 1 within 1e-12.

Usage (from the repository root): python3 bench/bbw_libigl.py [--repeats N] [--no-oracle] [--write-data]
Needs: pip install libigl numpy scipy clarabel (and triangle for --write-data).
"""

import math
import os
import subprocess
import sys
import tempfile
import time

import igl
import numpy as np
import scipy.sparse as sp

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES = ["character_1k.txt", "character_5k.txt", "hair_2k.txt"]
LIBIGL_TOLERANCE = 1e-5
ORACLE_TOLERANCE = 1e-3


def hair_centreline(n=800):
    """Left strand tip (bottom) up to the head, over the top (circle centre (200, 200), radius 117),
    down to the right strand tip; the strands wave by ±10 px."""
    pts = []
    q = n // 4
    for k in range(q):
        t = k / q
        pts.append((83 + 10 * math.sin(3 * math.pi * (1 - t)) * (1 - t), 400 - 200 * t))
    for k in range(2 * q):
        a = math.pi - math.pi * k / (2 * q)
        pts.append((200 + 117 * math.cos(a), 200 - 117 * math.sin(a)))
    for k in range(q + 1):
        t = k / q
        pts.append((317 + 10 * math.sin(3 * math.pi * t) * t, 200 + 200 * t))
    return np.array(pts)


def hair_mesh():
    """The band of half-width 18.5 px around the centreline (tapering at the tips), boundary
    resampled every 3 px, meshed by Triangle; handles: the boundary vertices on the scalp arc
    (radius 98.5 around (200, 200), upper half), ordered by angle."""
    import triangle

    c = hair_centreline()
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    s /= s[-1]
    half = 17.5 * np.minimum(1, np.minimum(s, 1 - s) / 0.15) ** 0.5 + 1.0
    d = np.gradient(c, axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    normal = np.stack([d[:, 1], -d[:, 0]], 1)
    poly = np.concatenate([c + half[:, None] * normal, (c - half[:, None] * normal)[::-1]])
    closed = np.concatenate([poly, poly[:1]])
    arc = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    u = np.linspace(0, arc[-1], int(math.ceil(arc[-1] / 3.0)), endpoint=False)
    boundary = np.stack([np.interp(u, arc, closed[:, 0]), np.interp(u, arc, closed[:, 1])], 1)
    segments = np.array([[i, (i + 1) % len(boundary)] for i in range(len(boundary))])
    t = triangle.triangulate({"vertices": boundary, "segments": segments}, "pq30a12")
    V = np.array([[float(f"{v:.3f}") for v in row] for row in t["vertices"]])
    F = np.asarray(t["triangles"], dtype=np.int64)
    markers = t["vertex_markers"].ravel()
    r = np.linalg.norm(V - [200, 200], axis=1)
    scalp = np.where((markers == 1) & (np.abs(r - 98.5) < 0.2) & (V[:, 1] <= 200))[0]
    scalp = scalp[np.argsort(np.arctan2(200 - V[scalp, 1], V[scalp, 0] - 200))]
    a, b, cc = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    signed = (b[:, 0] - a[:, 0]) * (cc[:, 1] - a[:, 1]) - (cc[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    F[signed < 0] = F[signed < 0][:, [0, 2, 1]]
    return V, F, scalp


def write_problem(path, V, F, handles):
    with open(path, "w") as f:
        f.write(f"{len(V)} {len(F)} {len(handles)}\n")
        for x, y in V:
            f.write(f"{x:.3f} {y:.3f}\n")
        for a, b, c in F:
            f.write(f"{a} {b} {c}\n")
        for h in handles:
            f.write(f"{h} {V[h, 0]:.3f} {V[h, 1]:.3f}\n")


def read_problem(path):
    with open(path) as f:
        lines = f.read().split("\n")
    v, f_, h = map(int, lines[0].split())
    V = np.array([[float(x) for x in l.split()] for l in lines[1 : 1 + v]])
    F = np.array([[int(x) for x in l.split()] for l in lines[1 + v : 1 + v + f_]], dtype=np.int64)
    H = np.array([int(l.split()[0]) for l in lines[1 + v + f_ : 1 + v + f_ + h]], dtype=np.int64)
    return V, F, H


def run_libigl(V, F, H, repeats):
    bc = np.eye(len(H))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        W = igl.bbw(V, F, H, bc)
        times.append(time.perf_counter() - t0)
    return W, 1e3 * float(np.median(times))


def run_ours(problem, weights, repeats, mass):
    out = subprocess.run(
        ["cargo", "run", "--release", "--quiet", "--example", "bbw_time", "--", problem, weights, str(repeats), mass],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    fields = dict(item.split("=", 1) for item in out.split() if "=" in item)
    return np.loadtxt(weights, ndmin=2), fields


def oracle(V, F, H):
    """Each handle's bounded weights (before normalisation) from clarabel, Q from libigl."""
    import clarabel

    L = igl.cotmatrix(V, F)
    M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_BARYCENTRIC).diagonal()
    Q = (L @ sp.diags(M.mean() / M) @ L).tocsc()
    free = np.setdiff1d(np.arange(len(V)), H)
    m = len(free)
    P = sp.triu(Q[free][:, free]).tocsc()
    A = sp.vstack([sp.eye(m), -sp.eye(m)]).tocsc()
    b = np.concatenate([np.ones(m), np.zeros(m)])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-12
    W = np.zeros((len(V), len(H)))
    for k, h in enumerate(H):
        q = Q[free][:, [h]].toarray().ravel()
        solution = clarabel.DefaultSolver(P, q, A, b, [clarabel.NonnegativeConeT(2 * m)], settings).solve()
        W[free, k] = np.clip(np.asarray(solution.x), 0.0, 1.0)
        W[h, k] = 1.0
    return W


def main():
    repeats = int(sys.argv[sys.argv.index("--repeats") + 1]) if "--repeats" in sys.argv else 5
    with_oracle = "--no-oracle" not in sys.argv
    if "--write-data" in sys.argv:
        V, F, H = hair_mesh()
        write_problem(os.path.join(ROOT, "benches", "data", "hair_2k.txt"), V, F, H)
    from importlib.metadata import version

    print(f"libigl {version('libigl')}, numpy {np.__version__}; median of {repeats} calls each; "
          f"load average before: {os.getloadavg()[0]:.2f}")
    subprocess.run(["cargo", "build", "--release", "--quiet", "--example", "bbw_time"], cwd=ROOT, check=True)
    rows, failures = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for case in CASES:
            problem = os.path.join(ROOT, "benches", "data", case)
            V, F, H = read_problem(problem)
            W_igl, igl_ms = run_libigl(V, F, H, repeats)
            W_bary, bary = run_ours(problem, os.path.join(tmp, "bary.txt"), repeats, "barycentric")
            W_vor, vor = run_ours(problem, os.path.join(tmp, "vor.txt"), repeats, "voronoi")
            vs_igl = float(np.abs(W_vor - W_igl).max())
            vs_oracle = float(np.abs(W_bary - oracle(V, F, H)).max()) if with_oracle else float("nan")
            ours_ms = float(bary["median_ms"])
            rows.append((case, len(V), len(H), igl_ms, ours_ms, float(vor["median_ms"]), ours_ms / igl_ms,
                         vs_igl, vs_oracle, float(np.abs(W_igl.sum(1) - 1).max()),
                         float(bary["max_row_sum_deviation"]), float(bary["normalised_row_error"])))
            if vs_igl > LIBIGL_TOLERANCE:
                failures.append(f"{case}: ours (Voronoi) differs from libigl by {vs_igl:.2e}")
            if with_oracle and not vs_oracle <= ORACLE_TOLERANCE:
                failures.append(f"{case}: ours differs from the QP oracle by {vs_oracle:.2e}")
            if float(bary["normalised_row_error"]) > 1e-12:
                failures.append(f"{case}: our rows sum to 1 only within {bary['normalised_row_error']}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    print()
    print("| mesh | vertices | handles | libigl ms | ours ms (barycentric) | ours ms (Voronoi) | ours / libigl "
          "| max abs(ours Voronoi − libigl) | max abs(ours − QP oracle) | libigl max abs(row sum − 1) "
          "| ours before / after normalising |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for c, v, h, ims, oms, vms, ratio, d_igl, d_oracle, igl_dev, dev, err in rows:
        print(f"| {c} | {v} | {h} | {ims:.1f} | {oms:.1f} | {vms:.1f} | {ratio:.2f} | {d_igl:.1e} | {d_oracle:.1e} "
              f"| {igl_dev:.3f} | {dev:.3f} / {err:.0e} |")
    if failures:
        print("FAIL:\n  " + "\n  ".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()
