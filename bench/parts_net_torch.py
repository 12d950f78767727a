#!/usr/bin/env python3
"""One training step of the correspondence network (issue 16, `puppet train-parts`) in PyTorch on
the CPU — the peer of `parts/train_step/4x2x128` in benches/parts.rs.

The same network as `puppet::model::correspondence` at the defaults of configs/parts-net.toml:
input 4×128² (premultiplied RGBA), channels ch(l) = min(16·2^l, 64), depth 5, 32 features.
Every block is gated: a convolution to 2·C channels, split in half, LeakyReLU 0.2 of
InstanceNorm2d(affine, eps 1e-5) of the first half times the sigmoid of the second. Down:
Conv2d k4 s2 p1. Up: nearest 2× upsampling then Conv2d k3 p1, the skip concatenated below the
innermost level. Head: Conv2d k3 p1 over [last block, input] to 32 features, unit length
(eps 1e-6 under the root). Loss: for each of 4 pairs and both directions, 256 anchors and their
256 matches plus 1024 negatives of the other pose; InfoNCE with τ = 0.07 (log-sum-exp over the
1280 candidates minus the positive), averaged. Adam lr 1e-3, β (0.9, 0.999), ε 1e-8, default
(foreach) and fused. Random inputs and indices (the step's cost does not depend on them).

    python3 bench/parts_net_torch.py [--threads 2] [--steps 10]
"""
import argparse
import statistics
import time

import torch
import torch.nn as nn
import torch.nn.functional as F


class Gated(nn.Module):
    def __init__(self, cin, cout, kernel, stride, padding):
        super().__init__()
        self.conv = nn.Conv2d(cin, 2 * cout, kernel, stride, padding)
        self.norm = nn.InstanceNorm2d(cout, affine=True, eps=1e-5)

    def forward(self, x):
        f, g = self.conv(x).chunk(2, dim=1)
        return F.leaky_relu(self.norm(f), 0.2) * torch.sigmoid(g)


class Net(nn.Module):
    def __init__(self, base=16, most=64, depth=5, features=32):
        super().__init__()
        ch = lambda l: min(base << l, most)
        self.downs = nn.ModuleList(Gated(4 if i == 0 else ch(i - 1), ch(i), 4, 2, 1) for i in range(depth))
        self.ups = nn.ModuleList(
            Gated(ch(i) if i == depth - 1 else 2 * ch(i), base if i == 0 else ch(i - 1), 3, 1, 1) for i in range(depth)
        )
        self.head = nn.Conv2d(base + 4, features, 3, 1, 1)
        self.depth = depth

    def forward(self, x):
        levels = [x]
        for d in self.downs:
            levels.append(d(levels[-1]))
        y = levels[self.depth]
        for i in reversed(range(self.depth)):
            if i < self.depth - 1:
                y = torch.cat([y, levels[i + 1]], 1)
            y = self.ups[i](F.interpolate(y, scale_factor=2, mode="nearest"))
        f = self.head(torch.cat([y, x], 1))
        return f / torch.sqrt((f * f).sum(1, keepdim=True) + 1e-6)


def info_nce(a, b, src, pos, neg, tau=0.07):
    anchors = a[src]
    candidates = b[torch.cat([pos, neg])]
    positive = (anchors * candidates[: len(src)]).sum(1) / tau
    logits = anchors @ candidates.T / tau
    return (torch.logsumexp(logits, 1) - positive).mean()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--steps", type=int, default=10)
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(1)
    pairs, size, anchors, negatives = 4, 128, 256, 1024
    x = torch.rand(2 * pairs, 4, size, size)
    print(f"PyTorch {torch.__version__}, {args.threads} threads, 4 pairs of 128² poses")
    for fused in (False, True):
        net = Net()
        opt = torch.optim.Adam(net.parameters(), lr=1e-3, eps=1e-8, fused=fused)
        times = []
        for step in range(args.steps + 2):
            t0 = time.perf_counter()
            f = net(x).flatten(2).transpose(1, 2)  # [B, S², F]
            terms = []
            for k in range(pairs):
                for a, b in ((f[k], f[pairs + k]), (f[pairs + k], f[k])):
                    src = torch.randint(0, size * size, (anchors,))
                    pos = torch.randint(0, size * size, (anchors,))
                    neg = torch.randint(0, size * size, (negatives,))
                    terms.append(info_nce(a, b, src, pos, neg))
            loss = torch.stack(terms).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            if step >= 2:
                times.append(time.perf_counter() - t0)
        params = sum(p.numel() for p in net.parameters())
        median = statistics.median(times)
        print(f"{'fused' if fused else 'default'} Adam: median {median * 1e3:.0f} ms per step "
              f"({2 * pairs / median:.1f} images/s), {params} parameters")


if __name__ == "__main__":
    main()
