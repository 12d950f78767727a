#!/usr/bin/env python3
"""The deformation network in PyTorch on the CPU, side by side with ours (issue 5's speed goal).

The same network as `puppet::model::deformation` (neural-puppet.md §3.2): three convolutions
(kernel 5, stride 2, padding 2) to 32/64/128 channels, FC 128·(S/8)² → 1024 → 512 → 512 (z),
decoder FC 512 → 512 → 1024 → 2·V + 2, outputs × 16 px, per-vertex offsets plus the global bias
added to the rest vertices; ReLU between layers. One training step is forward, MSE loss on the
vertices, backward, Adam update (lr 1e-4, eps 1e-8), at batch 16, 128², V = 600 — exactly what
`benches/backend.rs` times. Adam runs in PyTorch's default (foreach) and `fused=True` forms.

Then the script runs `cargo bench --bench backend` with BACKEND_CPU_REPORT=1 (unless
--skip-rust) and prints both in one table. Run from the repository root:

    python3 bench/train_torch.py [--threads 2] [--steps 20] [--skip-rust]
"""
import argparse
import os
import re
import resource
import subprocess
import time

import torch
from torch import nn

BATCH = 16
VERTICES = 600


class DeformationNet(nn.Module):
    def __init__(self, size, vertices):
        super().__init__()
        self.vertices = vertices
        conv = lambda i, o: nn.Conv2d(i, o, 5, stride=2, padding=2)
        self.convs = nn.ModuleList([conv(4, 32), conv(32, 64), conv(64, 128)])
        flat = 128 * (size // 8) ** 2
        self.encoder = nn.ModuleList([nn.Linear(flat, 1024), nn.Linear(1024, 512), nn.Linear(512, 512)])
        last = nn.Linear(1024, 2 * vertices + 2)
        nn.init.zeros_(last.weight)
        nn.init.zeros_(last.bias)
        self.decoder = nn.ModuleList([nn.Linear(512, 512), nn.Linear(512, 1024), last])

    def forward(self, x, rest):
        for c in self.convs:
            x = torch.relu(c(x))
        h = x.flatten(1)
        for i, fc in enumerate(self.encoder):
            h = fc(h)
            if i + 1 < len(self.encoder):
                h = torch.relu(h)
        for i, fc in enumerate(self.decoder):
            h = fc(h)
            if i + 1 < len(self.decoder):
                h = torch.relu(h)
        h = h * 16.0
        offsets = h[:, : 2 * self.vertices].reshape(-1, self.vertices, 2)
        bias = h[:, 2 * self.vertices :].reshape(-1, 1, 2)
        return offsets + bias + rest


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(size, steps, fused):
    torch.manual_seed(0)
    net = DeformationNet(size, VERTICES)
    opt = torch.optim.Adam(net.parameters(), lr=1e-4, eps=1e-8, fused=fused)
    images = torch.rand(BATCH, 4, size, size)
    rest = torch.tensor([[(i % 40) * 3.0, (i // 40) * 8.0] for i in range(VERTICES)])
    target = torch.rand(BATCH, VERTICES, 2) * 120.0

    def step():
        opt.zero_grad(set_to_none=True)
        loss = ((net(images, rest) - target) ** 2).mean()
        loss.backward()
        opt.step()

    for _ in range(3):
        step()
    times = []
    cpu0 = cpu_seconds()
    for _ in range(steps):
        t = time.perf_counter()
        step()
        times.append(time.perf_counter() - t)
    cpu = (cpu_seconds() - cpu0) / steps
    times.sort()
    median = times[len(times) // 2]
    return median, sum(times) / steps, cpu


def run_rust():
    env = dict(os.environ, BACKEND_CPU_REPORT="1")
    cmd = ["cargo", "bench", "--bench", "backend"]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"cpu-report (\S+): wall ([\d.]+) ms, cpu ([\d.]+) ms", line)
        if m:
            rows.append((m.group(1), float(m.group(2)) / 1e3, float(m.group(3)) / 1e3))
    return rows, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--skip-rust", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, batch {BATCH}, {args.size}², V = {VERTICES}")
    table = []
    for fused in (False, True):
        median, mean, cpu = measure(args.size, args.steps, fused)
        name = f"PyTorch Adam({'fused=True' if fused else 'default'})"
        table.append((name, median, cpu))
        print(f"{name}: median {median * 1e3:.1f} ms, mean {mean * 1e3:.1f} ms, cpu {cpu * 1e3:.1f} ms per step")
    if not args.skip_rust:
        rows, out = run_rust()
        print(out)
        for name, wall, cpu in rows:
            table.append((f"puppet {name}", wall, cpu))
    print("\n| what | ms / step | images/s | CPU ms / step | CPU / wall |")
    print("|---|---|---|---|---|")
    for name, wall, cpu in table:
        print(f"| {name} | {wall * 1e3:.0f} | {BATCH / wall:.1f} | {cpu * 1e3:.0f} | {cpu / wall:.2f} |")


if __name__ == "__main__":
    main()
