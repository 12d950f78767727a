#!/usr/bin/env python3
"""Compare puppet's layer mesher (spade CDT + refinement) with Shewchuk's Triangle.

Both tools mesh the SAME polygon: the outer boundary of Kenney's robot (robot_idle.png from the
`arcade` wheel, 96x128 palette PNG), alpha upscaled 4x bilinearly and thresholded at 0.5,
traced with OpenCV and simplified to ~250 points. The polygon is written to a JSON file
(default benches/data/robot4x.json, also used by benches/mesh.rs). For each target size, the
area bound is chosen so Triangle (`pq30a<area>`) gives ~N vertices; our mesher then runs with
the same area bound and min angle through `examples/mesh_polygon.rs`.

Setup:
    pip install triangle numpy pillow opencv-python-headless
    pip download arcade --no-deps -d /tmp/arcade && cd /tmp/arcade && unzip -o *.whl \
        'arcade/resources/assets/images/animated_characters/robot/*'
Run from the repository root:
    python3 bench/triangle_compare.py [--png PATH] [--out benches/data/robot4x.json] [--runs 20]
"""
import argparse
import json
import math
import statistics
import subprocess
import time

import cv2
import numpy as np
import triangle
from PIL import Image

DEFAULT_PNG = "/tmp/arcade/arcade/resources/assets/images/animated_characters/robot/robot_idle.png"


def robot_polygon(png, scale, target_points):
    """Outer boundary of the upscaled robot as an (N, 2) array in pixel coordinates."""
    alpha = Image.open(png).convert("RGBA").getchannel("A")
    w, h = alpha.size
    big = np.asarray(alpha.resize((w * scale, h * scale), Image.BILINEAR))
    mask = (big > 127).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outer = max(contours, key=cv2.contourArea)
    # Bisect the Douglas-Peucker tolerance for ~target_points points.
    lo, hi = 0.01, 50.0
    for _ in range(60):
        eps = 0.5 * (lo + hi)
        n = len(cv2.approxPolyDP(outer, eps, True))
        if n > target_points:
            lo = eps
        else:
            hi = eps
    poly = cv2.approxPolyDP(outer, hi, True)[:, 0, :].astype(np.float64)
    # OpenCV puts pixel centres at integer coordinates; puppet at +0.5.
    return poly + 0.5, mask.shape


def min_angle_deg(vertices, triangles):
    p = vertices[triangles]  # (T, 3, 2)
    best = 180.0
    for k in range(3):
        a, b, c = p[:, k], p[:, (k + 1) % 3], p[:, (k + 2) % 3]
        u, v = b - a, c - a
        cross = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
        dot = (u * v).sum(axis=1)
        best = min(best, float(np.degrees(np.arctan2(cross, dot)).min()))
    return best


def triangle_mesh(poly, area, angle):
    n = len(poly)
    data = {"vertices": poly, "segments": np.array([[i, (i + 1) % n] for i in range(n)])}
    return triangle.triangulate(data, f"pq{angle}a{area:.6f}Q")


def area_for_vertices(poly, target, angle):
    """Area bound (bisected in log space) for which Triangle gives ~target vertices."""
    lo, hi = 1e-2, 1e5
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        n = len(triangle_mesh(poly, mid, angle)["vertices"])
        if n > target:
            lo = mid
        else:
            hi = mid
    return hi


def triangle_stats(poly, area, angle, times):
    out = triangle_mesh(poly, area, angle)
    v, t = out["vertices"], out["triangles"]
    a = v[t]
    areas = 0.5 * np.abs((a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1]) - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1]))
    return {"tool": "Triangle (pq%ga)" % angle, "vertices": len(v), "triangles": len(t),
            "min_angle": min_angle_deg(v, t), "max_area": float(areas.max()),
            "median_ms": statistics.median(times), "min_ms": min(times), "runs": len(times)}


def time_both(poly, path, area, angle, runs, rounds):
    """Alternates the two tools in `rounds` rounds of runs/rounds runs each, so that both see the
    same machine load; returns (Triangle row, puppet row) with medians over all runs."""
    tri_times, ours_times, ours = [], [], None
    per_round = max(1, runs // rounds)
    for _ in range(rounds):
        for _ in range(per_round):
            t0 = time.perf_counter()
            triangle_mesh(poly, area, angle)
            tri_times.append((time.perf_counter() - t0) * 1e3)
        out = subprocess.run(["target/release/examples/mesh_polygon", path, "--max-area", f"{area:.6f}",
                              "--min-angle", str(angle), "--runs", str(per_round)],
                             check=True, capture_output=True, text=True).stdout
        ours = json.loads(out)
        ours_times += ours["times_ms"]
    ours.update(median_ms=statistics.median(ours_times), min_ms=min(ours_times), runs=len(ours_times))
    return triangle_stats(poly, area, angle, tri_times), ours


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--png", default=DEFAULT_PNG)
    ap.add_argument("--out", default="benches/data/robot4x.json")
    ap.add_argument("--scale", type=int, default=4)
    ap.add_argument("--points", type=int, default=250)
    ap.add_argument("--angle", type=float, default=30.0)
    ap.add_argument("--runs", type=int, default=20, help="runs per tool and size (>= 20 for the table)")
    ap.add_argument("--rounds", type=int, default=5, help="alternate the tools this many times")
    ap.add_argument("--targets", default="1000,5000")
    args = ap.parse_args()

    poly, shape = robot_polygon(args.png, args.scale, args.points)
    with open(args.out, "w") as f:
        json.dump({"source": "Kenney robot_idle.png (arcade wheel), alpha x%d bilinear > 0.5, "
                             "OpenCV outer contour, approxPolyDP" % args.scale,
                   "image_size": [int(shape[1]), int(shape[0])],
                   "rings": [[[round(float(x), 3), round(float(y), 3)] for x, y in poly]]}, f)
        f.write("\n")
    # Reload the rounded polygon so both tools see exactly the same coordinates.
    with open(args.out) as f:
        poly = np.array(json.load(f)["rings"][0], dtype=np.float64)
    print(f"polygon: {len(poly)} points, image {shape[1]}x{shape[0]}, written to {args.out}")
    subprocess.run(["cargo", "build", "--release", "--quiet", "--example", "mesh_polygon"], check=True)

    rows = []
    for target in [int(t) for t in args.targets.split(",")]:
        area = area_for_vertices(poly, target, args.angle)
        for row in time_both(poly, args.out, area, args.angle, args.runs, args.rounds):
            rows.append((target, area, row))
    print(f"{'target':>6} {'area px²':>9} {'tool':<18} {'vertices':>8} {'triangles':>9} {'min angle':>9} "
          f"{'max area':>8} {'median ms':>9} {'min ms':>7}")
    for target, area, r in rows:
        print(f"{target:>6} {area:>9.3f} {r['tool']:<18} {r['vertices']:>8} {r['triangles']:>9} "
              f"{r['min_angle']:>9.2f} {r['max_area']:>8.2f} {r['median_ms']:>9.3f} {r['min_ms']:>7.3f}")
    for k in range(0, len(rows), 2):
        (target, _, t), (_, _, o) = rows[k], rows[k + 1]
        print(f"~{target} vertices: puppet/Triangle time ratio {o['median_ms'] / t['median_ms']:.2f}x (median), "
              f"{o['min_ms'] / t['min_ms']:.2f}x (min)")


if __name__ == "__main__":
    main()
