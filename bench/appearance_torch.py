#!/usr/bin/env python3
"""The appearance GAN's training step in PyTorch on the CPU, side by side with ours.

The same networks as `puppet::model::appearance` (neural-puppet.md §3.3; pix2pix shapes), RGBA
(4 channels) in and out, at 128² (7 downsamplings), channels base·2^level capped at max:

- generator (U-Net): down convs Conv2d k4 s2 p1 with bias, LeakyReLU 0.2 before every one but
  the first, InstanceNorm2d(affine, eps 1e-5) after down conv i for 0 < i < depth − 1; up path
  ReLU → ConvTranspose2d k4 s2 p1, InstanceNorm after ups[i] for i > 0, dropout 0.5 after
  ups[i] for dropout_from ≤ i < depth − 1 (dropout_from = (depth − 1) − (depth − 5)), skip
  concatenation [skip, up]; output clamp(input + tanh(h), 0, 1) (residual);
- critic (PatchGAN, no normalisation): convs k4 p1, strides 2, 2, 2, 1, 1, channels base, 2·base,
  4·base, 8·base (capped), then 1; LeakyReLU 0.2 between; N(0, 0.02) weights.

One step — what `benches/appearance.rs` times — is: generator forward; WGAN-GP critic loss
mean D(G(x)) − mean D(y) + 10·mean((‖∇D(x̂)‖₂ − 1)²) with x̂ = mix·y + (1 − mix)·G(x) per sample
and ∇D from torch.autograd.grad(create_graph=True) of the patch-score sum, backward, Adam on the
critic; then −mean D(G(x)) + 100·mean|G(x) − y| with the critic's weights frozen, backward, Adam
on the generator. Adam lr 2e-4, betas (0.5, 0.999), eps 1e-8, in PyTorch's default (foreach)
and `fused=True` forms. Batch 9 (the Kenney robot's nine training frames), uniform noise inputs.
Sizes `small` (base 16, max 64) and `full` (base 64, max 512).

Then the script runs `APPEARANCE_CPU_REPORT=1 cargo bench --bench appearance` (unless
--skip-rust) and prints both in one table, with Burn images/s ÷ PyTorch images/s. Run from the
repository root:

    python3 bench/appearance_torch.py [--threads 2] [--steps 10] [--skip-rust]

`--steps` timed steps for `small`; `full` takes a third of them (at least 3).

On a machine where other jobs keep the cores busy, PyTorch's OpenMP threads spin at every
barrier while the other thread waits for a core: with 2 threads on such a machine the small
generator's forward took 0.9 s against 0.08 s with 1 thread. `OMP_WAIT_POLICY=PASSIVE` (set
before Python starts; libgomp reads it once) makes them sleep instead (0.1 s there). On an idle
machine the default policy is the fair one.
"""
import argparse
import os
import re
import resource
import subprocess
import time
import warnings

# The PyPI wheel warns on import when NumPy is absent; nothing here uses NumPy.
warnings.filterwarnings("ignore", message="Failed to initialize NumPy")

import torch  # noqa: E402
from torch import nn  # noqa: E402

BATCH = 9
SLOPE = 0.2
SIZES = {"small": (16, 64), "full": (64, 512)}


def depth_of(size):
    depth = 0
    while size % 2 == 0 and size > 1 and depth < 8:
        size //= 2
        depth += 1
    return depth


def normal_init(module):
    for m in module.modules():
        if isinstance(m, (nn.Conv2d, nn.ConvTranspose2d)):
            nn.init.normal_(m.weight, 0.0, 0.02)
            nn.init.zeros_(m.bias)


class Generator(nn.Module):
    def __init__(self, size, base, top, dropout=0.5):
        super().__init__()
        depth = depth_of(size)
        ch = lambda level: min(base << level, top)
        self.depth = depth
        self.downs = nn.ModuleList(
            [nn.Conv2d(4 if i == 0 else ch(i - 1), ch(i), 4, stride=2, padding=1) for i in range(depth)]
        )
        self.down_norms = nn.ModuleList([nn.InstanceNorm2d(ch(i), affine=True, eps=1e-5) for i in range(1, depth - 1)])
        self.ups = nn.ModuleList(
            [
                nn.ConvTranspose2d(ch(i) if i == depth - 1 else 2 * ch(i), 4 if i == 0 else ch(i - 1), 4, stride=2, padding=1)
                for i in range(depth)
            ]
        )
        self.up_norms = nn.ModuleList([nn.InstanceNorm2d(ch(i - 1), affine=True, eps=1e-5) for i in range(1, depth)])
        self.dropout = nn.Dropout(dropout)
        self.dropout_from = max(depth - 1 - max(depth - 5, 0), 0)
        normal_init(self)

    def forward(self, render):
        depth = self.depth
        skips = []
        h = render
        for i, down in enumerate(self.downs):
            if i > 0:
                h = nn.functional.leaky_relu(h, SLOPE)
            h = down(h)
            if 0 < i < depth - 1:
                h = self.down_norms[i - 1](h)
            skips.append(h)
        for i in reversed(range(depth)):
            h = self.ups[i](torch.relu(h))
            if i > 0:
                h = self.up_norms[i - 1](h)
                if self.dropout_from <= i < depth - 1:
                    h = self.dropout(h)
                h = torch.cat([skips[i - 1], h], 1)
        return (render + torch.tanh(h)).clamp(0.0, 1.0)


class Critic(nn.Module):
    def __init__(self, base, top, inputs=4):
        super().__init__()
        ch = lambda level: min(base << level, top)
        convs, i_ch = [], inputs
        for k, stride in enumerate((2, 2, 2, 1)):
            convs.append(nn.Conv2d(i_ch, ch(k), 4, stride=stride, padding=1))
            i_ch = ch(k)
        convs.append(nn.Conv2d(i_ch, 1, 4, stride=1, padding=1))
        self.convs = nn.ModuleList(convs)
        normal_init(self)

    def forward(self, x):
        for k, conv in enumerate(self.convs):
            x = conv(x)
            if k + 1 < len(self.convs):
                x = nn.functional.leaky_relu(x, SLOPE)
        return x


def params(module):
    return sum(p.numel() for p in module.parameters())


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(name, size, steps, fused):
    base, top = SIZES[name]
    torch.manual_seed(0)
    gen, critic = Generator(size, base, top), Critic(base, top)
    gen.train()
    adam = lambda m: torch.optim.Adam(m.parameters(), lr=2e-4, betas=(0.5, 0.999), eps=1e-8, fused=fused)
    opt_g, opt_d = adam(gen), adam(critic)
    renders = torch.rand(BATCH, 4, size, size)
    frames = torch.rand(BATCH, 4, size, size)
    mix = torch.rand(BATCH, 1, 1, 1)

    def step():
        fake = gen(renders)
        # Critic: WGAN-GP.
        detached = fake.detach()
        real_scores = critic(frames)
        fake_scores = critic(detached)
        between = (frames * mix + detached * (1.0 - mix)).requires_grad_(True)
        scores = critic(between)
        (g,) = torch.autograd.grad(scores, between, grad_outputs=torch.ones_like(scores), create_graph=True)
        norms = (g.flatten(1).square().sum(1) + 1e-12).sqrt()
        penalty = ((norms - 1.0) ** 2).mean()
        d_loss = fake_scores.mean() - real_scores.mean() + 10.0 * penalty
        opt_d.zero_grad(set_to_none=True)
        d_loss.backward()
        opt_d.step()
        # Generator, through the frozen (updated) critic.
        for p in critic.parameters():
            p.requires_grad_(False)
        g_loss = -critic(fake).mean() + 100.0 * (fake - frames).abs().mean()
        opt_g.zero_grad(set_to_none=True)
        g_loss.backward()
        opt_g.step()
        for p in critic.parameters():
            p.requires_grad_(True)

    step()
    times = []
    cpu0 = cpu_seconds()
    for _ in range(steps):
        t = time.perf_counter()
        step()
        times.append(time.perf_counter() - t)
    cpu = (cpu_seconds() - cpu0) / steps
    times.sort()
    return times[len(times) // 2], sum(times) / steps, cpu


UNITS = {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def run_rust():
    env = dict(os.environ, APPEARANCE_CPU_REPORT="1")
    cmd = ["cargo", "bench", "--bench", "appearance"]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    report, criterion = {}, {}
    for m in re.finditer(r"cpu-report appearance/step/(\w+)/\S+: wall ([\d.]+) ms, cpu ([\d.]+) ms", out):
        report[m.group(1)] = (float(m.group(2)) / 1e3, float(m.group(3)) / 1e3)
    for m in re.finditer(r"appearance/step/(\w+)/batch=\d+\s+time:\s+\[\S+ \S+ ([\d.]+) (\S+) \S+ \S+\]", out):
        criterion[m.group(1)] = float(m.group(2)) * UNITS[m.group(3)]
    return report, criterion, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--sizes", default="small,full", help="comma-separated: small, full")
    ap.add_argument("--skip-rust", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    sizes = [s for s in args.sizes.split(",") if s]
    policy = os.environ.get("OMP_WAIT_POLICY", "unset")
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, OMP_WAIT_POLICY {policy}, batch {BATCH}, {args.size}², RGBA")
    for name in sizes:
        base, top = SIZES[name]
        print(f"params {name}: generator {params(Generator(args.size, base, top)):,}, critic {params(Critic(base, top)):,}")
    torch_rows = {}
    for name in sizes:
        steps = args.steps if name == "small" else max(3, args.steps // 3)
        for fused in (False, True):
            median, mean, cpu = measure(name, args.size, steps, fused)
            adam = "fused=True" if fused else "default"
            torch_rows[(name, fused)] = median
            print(
                f"PyTorch {name} Adam({adam}): median {median * 1e3:.0f} ms, mean {mean * 1e3:.0f} ms, "
                f"cpu {cpu * 1e3:.0f} ms per step ({BATCH / median:.2f} images/s, {steps} steps, CPU/wall {cpu / mean:.2f})",
                flush=True,
            )
    report, criterion = {}, {}
    if not args.skip_rust:
        report, criterion, out = run_rust()
        print(out)
    print("\n| size | PyTorch default Adam | PyTorch fused Adam | puppet (criterion) | puppet (cpu-report) | ratio to default / fused |")
    print("|---|---|---|---|---|---|")
    ips = lambda seconds: f"{BATCH / seconds:.2f} img/s ({seconds:.2f} s)" if seconds else "—"
    for name in sizes:
        default, fused = torch_rows[(name, False)], torch_rows[(name, True)]
        ours = criterion.get(name) or report.get(name, (None,))[0]
        ratio = f"{default / ours:.2f} / {fused / ours:.2f}" if ours else "—"
        wall = report.get(name, (None,))[0]
        print(f"| {name} | {ips(default)} | {ips(fused)} | {ips(criterion.get(name))} | {ips(wall)} | {ratio} |")


if __name__ == "__main__":
    main()
