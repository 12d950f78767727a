#!/usr/bin/env python3
"""ARAP with handles: puppet's `geom::ArapSolver` against libigl, same mesh, handles, targets.

Builds a 2D character-like outline (head, torso, two arms, two legs), triangulates it with
Shewchuk's Triangle (PyPI `triangle`) at ~1k and ~5k vertices, picks 12 handles at landmarks
(head, hands, elbows, shoulders, hips, knees, feet) and moves them into a new pose. Then, in the same
run:
  * libigl (PyPI `libigl`): `igl.ARAPData` with energy = ARAP_ENERGY_TYPE_SPOKES (Sorkine & Alexa
    2007, the energy of neural-puppet.md eq. 2; libigl's 2D default would be ELEMENTS, i.e.
    per-triangle rotations, a different problem), max_iter = 10, `igl.arap_precomputation` and
    `igl.arap_solve`;
  * ours: `cargo run --release --example arap_solve` on the same mesh file, precomputation
    (`ArapSolver::new`) and `solve(.., 10, ..)`.
Both start from the rest mesh with the handle rows already moved to their targets: libigl's
arap_solve fits the first rotations before it enforces the handles, ours after; with the handles
pre-set both run exactly the same iteration.

Times are the median of REPEATS runs each (wall clock, one process, warm). Prints a table:
vertices, precompute ms, 10-iteration solve ms (libigl / ours), max |ours - libigl| in pixels.

Usage (from the repository root): python3 bench/arap_libigl.py [--write-data]
  --write-data also (re)writes benches/data/character_{1k,5k}.txt for the criterion bench.
"""

import math
import os
import subprocess
import sys
import tempfile
import time

import igl
import numpy as np
import triangle

REPEATS = 20
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def character_outline():
    """A gingerbread-like character outline in pixels (y down), as a closed polygon."""
    pts = []
    # Head: circle centre (200, 90), radius 60, from the right of the neck over the top to the left.
    cx, cy, r = 200.0, 90.0, 60.0
    a0 = math.atan2(148.0 - cy, 222.0 - cx)
    a1 = math.atan2(148.0 - cy, 178.0 - cx) - 2 * math.pi
    for k in range(40):
        a = a0 + (a1 - a0) * k / 39
        pts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    body = [
        (178, 150), (120, 170), (60, 230), (28, 262), (48, 285), (80, 258), (132, 222),
        (136, 360), (118, 470), (105, 560), (168, 562), (182, 470), (200, 405),
        (218, 470), (232, 562), (295, 560), (282, 470), (264, 360), (268, 222),
        (320, 258), (352, 285), (372, 262), (340, 230), (280, 170), (222, 150),
    ]
    pts.extend((float(x), float(y)) for x, y in body)
    return np.array(pts)


def resample(poly, step):
    """Splits polygon edges so that no boundary edge is longer than `step`."""
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        k = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
        for t in range(k):
            out.append(a + (b - a) * t / k)
    return np.array(out)


def to_file_precision(a):
    return np.array([float(f"{v:.3f}") for v in a.ravel()]).reshape(a.shape)


def polygon_area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def character_mesh(target_vertices):
    """Quality Delaunay mesh of the outline with about `target_vertices` vertices."""
    outline = character_outline()
    area = polygon_area(outline)
    # Triangles ≈ 2·V for a mesh of this kind; spacing h of an equilateral triangle of that area.
    tri_area = area / (1.8 * target_vertices)
    h = math.sqrt(tri_area * 4 / math.sqrt(3))
    for _ in range(8):
        boundary = resample(outline, h)
        segs = np.array([[i, (i + 1) % len(boundary)] for i in range(len(boundary))])
        t = triangle.triangulate({"vertices": boundary, "segments": segs}, f"pq30a{tri_area:.6f}")
        nv = len(t["vertices"])
        if abs(nv - target_vertices) < 0.05 * target_vertices:
            break
        scale = target_vertices / nv
        tri_area /= scale
        h /= math.sqrt(scale)
    # Rounded to 1/1000 px, exactly as the problem file stores them, so that both libraries see
    # bit-identical input (and the committed files stay small).
    V = to_file_precision(np.asarray(t["vertices"], dtype=np.float64))
    F = np.asarray(t["triangles"], dtype=np.int64)
    # Our convention: positive signed area with y down (puppet::Mesh). Triangle's output is CCW
    # in a y-up frame, which is also positive with the usual formula; enforce it anyway.
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    F[signed < 0] = F[signed < 0][:, [0, 2, 1]]
    return V, F


# 12 landmarks (rest position) and where the pose moves them (offsets in pixels).
LANDMARKS = [
    ("head top", (200, 40), (25, -5)),
    ("left hand", (40, 270), (30, -150)),
    ("left elbow", (95, 235), (15, -60)),
    ("left shoulder", (135, 185), (5, -10)),
    ("right hand", (358, 270), (-20, 60)),
    ("right elbow", (300, 235), (-10, 30)),
    ("right shoulder", (265, 185), (0, 0)),
    ("left hip", (150, 380), (-5, 0)),
    ("right hip", (250, 380), (5, 0)),
    ("left knee", (150, 470), (-30, -10)),
    ("left foot", (135, 552), (-70, -40)),
    ("right foot", (262, 552), (10, 0)),
]


def handles_and_targets(V):
    handles, targets = [], []
    for _, rest, offset in LANDMARKS:
        d = np.linalg.norm(V - np.array(rest, dtype=np.float64), axis=1)
        i = int(np.argmin(d))
        assert i not in handles
        handles.append(i)
        targets.append(V[i] + np.array(offset, dtype=np.float64))
    return np.array(handles, dtype=np.int32), to_file_precision(np.array(targets))


def write_problem(path, V, F, handles, targets):
    with open(path, "w") as f:
        f.write(f"{len(V)} {len(F)} {len(handles)}\n")
        for x, y in V:
            f.write(f"{x:.3f} {y:.3f}\n")
        for a, b, c in F:
            f.write(f"{a} {b} {c}\n")
        for h, (x, y) in zip(handles, targets):
            f.write(f"{h} {x:.3f} {y:.3f}\n")


def run_libigl(V, F, handles, targets):
    U0 = V.copy()
    U0[handles] = targets
    pre, sol = [], []
    for _ in range(REPEATS):
        data = igl.ARAPData()
        data.energy = igl.ARAP_ENERGY_TYPE_SPOKES
        data.max_iter = 10
        t0 = time.perf_counter()
        igl.arap_precomputation(V, F, 2, handles, data)
        t1 = time.perf_counter()
        U = igl.arap_solve(targets, data, U0)
        t2 = time.perf_counter()
        pre.append(t1 - t0)
        sol.append(t2 - t1)
    return U, 1e3 * float(np.median(pre)), 1e3 * float(np.median(sol))


def run_ours(problem, result):
    out = subprocess.run(
        ["cargo", "run", "--release", "--quiet", "--example", "arap_solve", "--", problem, result, str(REPEATS)],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    fields = dict(line.split("=", 1) for line in out.split() if "=" in line)
    U = np.loadtxt(result).reshape(-1, 2)
    return U, float(fields["precompute_ms"]), float(fields["solve10_ms"])


def main():
    write_data = "--write-data" in sys.argv
    from importlib.metadata import version

    print(f"libigl {version('libigl')}, triangle {version('triangle')}, numpy {np.__version__}; median of {REPEATS} runs")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, target in (("1k", 1000), ("5k", 5000)):
            V, F = character_mesh(target)
            handles, targets = handles_and_targets(V)
            problem = os.path.join(tmp, f"character_{label}.txt")
            write_problem(problem, V, F, handles, targets)
            if write_data:
                os.makedirs(os.path.join(ROOT, "benches", "data"), exist_ok=True)
                write_problem(os.path.join(ROOT, "benches", "data", f"character_{label}.txt"), V, F, handles, targets)
            U_igl, igl_pre, igl_sol = run_libigl(V, F, handles, targets)
            U_ours, our_pre, our_sol = run_ours(problem, os.path.join(tmp, f"result_{label}.txt"))
            diff = float(np.abs(U_ours - U_igl).max())
            moved = float(np.abs(U_igl - V).max())
            handle_err = float(np.abs(U_ours[handles] - targets).max())
            rows.append((len(V), len(F), igl_pre, our_pre, igl_sol, our_sol, diff, moved, handle_err))
    print()
    print("| vertices | triangles | precompute ms libigl / ours | 10-iteration solve ms libigl / ours | max abs(ours - libigl) px | max displacement px | our handle error px |")
    print("|---|---|---|---|---|---|---|")
    for v, f, ip, op, isl, osl, d, m, he in rows:
        print(f"| {v} | {f} | {ip:.2f} / {op:.2f} | {isl:.2f} / {osl:.2f} | {d:.2e} | {m:.1f} | {he:.1e} |")


if __name__ == "__main__":
    main()
