#!/usr/bin/env python3
"""Dense SoftRas-style rasterizer in PyTorch on the CPU, side by side with ours (issue 3).

The peer: every pixel against every face, the signed distance of the pixel centre to each
triangle, D = sigmoid(±d²/σ), the silhouette M = 1 − Π_j (1 − D_j), an L2 loss on M, and the
backward pass by autograd. Same sizes as `benches/render.rs`: 128×128 pixels, the same 996-face,
11-layer character (geometry rebuilt here by the same procedure), σ = 0.5 px².
Batch 16 does not fit in memory for the dense peer (P×F×B tensors), so it runs one image at a
time and the per-image time is compared.

Then the script runs `cargo bench --bench render` (filter below) with RENDER_CPU_REPORT=1 and
prints both results in one table. Run from the repository root:

    python3 bench/softras_torch.py [--repeats 3] [--threads 2] [--skip-rust]
"""
import argparse
import math
import os
import re
import subprocess
import time

import torch

SIZE = 128
BATCH = 16
SIGMA = 0.5


def rect(r, nx, ny):
    x0, y0, x1, y1 = r
    verts = [(x0 + (x1 - x0) * i / nx, y0 + (y1 - y0) * j / ny) for j in range(ny + 1) for i in range(nx + 1)]
    idx = lambda i, j: j * (nx + 1) + i
    tris = []
    for j in range(ny):
        for i in range(nx):
            tris.append((idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)))
            tris.append((idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)))
    return verts, tris


def disc(c, radius, n, rings):
    verts = [tuple(c)]
    for r in range(1, rings + 1):
        for k in range(n):
            th = 2 * math.pi * k / n
            rad = radius * r / rings
            verts.append((c[0] + rad * math.cos(th), c[1] + rad * math.sin(th)))
    idx = lambda r, k: 1 + (r - 1) * n + k % n
    tris = [(0, idx(1, k), idx(1, k + 1)) for k in range(n)]
    for r in range(1, rings):
        for k in range(n):
            tris.append((idx(r, k), idx(r + 1, k), idx(r + 1, k + 1)))
            tris.append((idx(r, k), idx(r + 1, k + 1), idx(r, k + 1)))
    return verts, tris


def character():
    """The character of benches/render.rs::character, as (vertices [V,2], faces [F,3])."""
    parts = [
        rect((20, 40, 64, 52), 12, 4), rect((50, 84, 62, 124), 4, 12), rect((40, 36, 88, 90), 8, 6),
        rect((66, 84, 78, 124), 4, 12), rect((56, 24, 72, 40), 4, 12), disc((64, 22), 18, 20, 3),
        disc((64, 12), 12, 20, 3), rect((64, 44, 112, 56), 12, 4), disc((112, 50), 7, 12, 3),
        rect((40, 70, 88, 78), 12, 4), rect((48, 34, 80, 42), 8, 4),
    ]
    verts, faces = [], []
    for v, t in parts:
        base = len(verts)
        verts += v
        faces += [(a + base, b + base, c + base) for a, b, c in t]
    return torch.tensor(verts, dtype=torch.float32), torch.tensor(faces, dtype=torch.long)


def silhouette(verts, faces, size, sigma):
    """Dense SoftRas silhouette of one pose: verts [V,2] → M [H,W]."""
    ys, xs = torch.meshgrid(torch.arange(size, dtype=torch.float32) + 0.5,
                            torch.arange(size, dtype=torch.float32) + 0.5, indexing="ij")
    p = torch.stack([xs.reshape(-1), ys.reshape(-1)], dim=1)[:, None, :]  # [P,1,2]
    tri = verts[faces]  # [F,3,2]
    d2 = []
    cross = []
    for k in range(3):
        a, b = tri[:, k], tri[:, (k + 1) % 3]  # [F,2]
        e = b - a
        ap = p - a  # [P,F,2]
        t = ((ap * e).sum(-1) / (e * e).sum(-1).clamp_min(1e-12)).clamp(0, 1)
        q = ap - t[..., None] * e
        d2.append((q * q).sum(-1))
        cross.append(e[:, 0] * ap[..., 1] - e[:, 1] * ap[..., 0])
    dist2 = torch.stack(d2).min(0).values  # [P,F]
    area = (tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1]) - (tri[:, 2, 0] - tri[:, 0, 0]) * (tri[:, 1, 1] - tri[:, 0, 1])
    s = torch.sign(area)
    inside = (torch.stack(cross) * s >= 0).all(0) & (s != 0)
    signed = torch.where(inside, dist2, -dist2)
    d = torch.sigmoid(signed / sigma)
    m = 1 - torch.prod(1 - d, dim=1)
    return m.reshape(size, size)


def run_torch(repeats):
    verts0, faces = character()
    target = silhouette(verts0, faces, SIZE, SIGMA).detach()
    times = []
    for r in range(repeats + 1):
        v = (verts0 + 0.3 * torch.randn_like(verts0)).requires_grad_(True)
        wall, cpu = time.perf_counter(), time.process_time()
        m = silhouette(v, faces, SIZE, SIGMA)
        loss = ((m - target) ** 2).sum()
        loss.backward()
        assert v.grad is not None and torch.isfinite(v.grad).all()
        if r > 0:  # the first run warms up the allocator
            times.append((time.perf_counter() - wall, time.process_time() - cpu))
    return faces.shape[0], times


def run_rust(filt):
    env = dict(os.environ, RENDER_CPU_REPORT="1")
    cmd = ["cargo", "bench", "--bench", "render", "--", "--warm-up-time", "1", "--measurement-time", "3", filt]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"cpu-report (\S+): wall ([\d.]+) ms, cpu ([\d.]+) ms per batch of (\d+)", line)
        if m:
            rows.append((m.group(1), float(m.group(2)), float(m.group(3)), int(m.group(4))))
    crit = re.findall(r"^(render/\S+)\s*\n\s*time:\s*\[[\d.]+ \w+ ([\d.]+ \w+)", out, re.M)
    return rows, crit


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--skip-rust", action="store_true")
    ap.add_argument("--filter", default="fwd_bwd|crisp_fwd")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    load = os.getloadavg()[0]
    faces, times = run_torch(args.repeats)
    print(f"machine: {os.cpu_count()} cores, load average {load:.1f}; torch {torch.__version__}, {args.threads} threads")
    print(f"dense PyTorch SoftRas silhouette, {faces} faces, {SIZE}², batch 1, fwd+bwd (autograd):")
    for wall, cpu in times:
        print(f"  wall {wall * 1e3:8.1f} ms, cpu {cpu * 1e3:8.1f} ms per image")
    best_wall = min(t[0] for t in times)
    best_cpu = min(t[1] for t in times)
    if args.skip_rust:
        return
    rows, crit = run_rust(args.filter)
    print(f"\nours (cargo bench --bench render -- '{args.filter}'), batch {BATCH}, full RGBA + silhouette, σ = {SIGMA}:")
    print(f"  {'id':58s} {'wall/batch':>11s} {'cpu/batch':>10s} {'wall/img':>9s} {'cpu/img':>8s} {'peer/ours (wall, cpu per img)':>30s}")
    for name, wall, cpu, batch in rows:
        wi, ci = wall / batch, cpu / batch
        ratio = f"{best_wall * 1e3 / wi:8.0f}× {best_cpu * 1e3 / ci:8.0f}×" if "fwd_bwd" in name else ""
        print(f"  {name:58s} {wall:9.1f}ms {cpu:8.1f}ms {wi:7.2f}ms {ci:6.2f}ms {ratio:>30s}")
    # Goal: forward+backward within 5× a crisp forward-only render of the same batch.
    by = {name: (wall, cpu) for name, wall, cpu, _ in rows}
    for name, (wall, cpu) in by.items():
        crisp = by.get(name.replace("fwd_bwd", "crisp_fwd"))
        if "fwd_bwd" in name and crisp:
            print(f"  {name}: {wall / crisp[0]:.2f}× the crisp forward (wall), {cpu / crisp[1]:.2f}× (cpu)")
    print("\ncriterion medians (wall, per batch):")
    for name, t in crit:
        print(f"  {name:58s} {t}")


if __name__ == "__main__":
    main()
