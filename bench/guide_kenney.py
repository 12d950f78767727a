#!/usr/bin/env python3
"""The table of bench/guide_kenney.sh: per Kenney character and run (from scratch or from the
prior, full steps or a third), the mean held-out L2 of walk0, walk4 and fall (the frames every
Kenney figure holds out), default fit and one pass, each also as a multiple of DIS flow's L2 on
the same frames. Runs trained with other seeds (RUN-sN, `SEEDS=` of guide_kenney.sh) are then
averaged per run over the seeds, ± the standard error of the mean, and each from-the-prior run's
default fit is set against scratch's at full steps (issue 56's steps goal: the prior at a third
of the steps as good as scratch at all of them).

    python3 bench/guide_kenney.py runs/guide-kenney
"""
import json
import pathlib
import statistics
import sys

FRAMES = ("walk0", "walk4", "fall")


def dis_mean(path):
    """DIS flow's (full resolution) mean L2 over FRAMES, from `flow_dis.py warp`'s table."""
    values = [float(line.split()[2]) for line in open(path) if any(f"_{f}." in line.split()[0] for f in FRAMES)]
    assert len(values) == len(FRAMES), f"{path}: {len(values)} of the frames"
    return sum(values) / len(values)


def l2_mean(path):
    """The model's mean L2 over FRAMES from an `eval -o` report."""
    frames = json.load(open(path))["frames"]
    values = [r["l2"] for r in frames if any(f"_{f}." in r["frame"] for f in FRAMES)]
    assert len(values) == len(FRAMES), f"{path}: {len(values)} of the frames"
    return sum(values) / len(values)


def mean_se(values):
    """The mean and its standard error ("" for one value)."""
    mean = statistics.mean(values)
    if len(values) < 2:
        return mean, ""
    return mean, f" ± {statistics.stdev(values) / len(values) ** 0.5:.3f}"


def main(root):
    print("| character | run | default fit L2 (× DIS) | one pass L2 (× DIS) |")
    print("|---|---|---|---|")
    seeds = {}  # (character, run without its seed) -> [(default × DIS, one pass × DIS)]
    for d in sorted(pathlib.Path(root).iterdir()):
        if not (d / "dis.txt").is_file():
            continue
        dis = dis_mean(d / "dis.txt")
        runs = sorted((r for r in d.iterdir() if (r / "one-pass.json").is_file()), key=lambda r: (int(r.name.split("-")[1]), r.name))
        for r in runs:
            default, one = l2_mean(r / "default.json"), l2_mean(r / "one-pass.json")
            print(f"| {d.name} | {r.name} | {default:.1f} ({default / dis:.2f}) | {one:.1f} ({one / dis:.2f}) |")
            run = "-".join(r.name.split("-")[:2])
            seeds.setdefault((d.name, run), []).append((default / dis, one / dis))
        print(f"| {d.name} | DIS flow | {dis:.1f} (1.00) | |")
    if all(len(v) == 1 for v in seeds.values()):
        return
    print()
    print("| character | run | seeds | default fit × DIS | one pass × DIS | default fit / scratch's at full steps |")
    print("|---|---|---|---|---|---|")
    for (character, run), values in seeds.items():
        default, default_se = mean_se([v[0] for v in values])
        one, one_se = mean_se([v[1] for v in values])
        full = max((int(r.split("-")[1]) for c, r in seeds if c == character), default=0)
        scratch = seeds.get((character, f"scratch-{full}"))
        ratio = f"{default / statistics.mean(v[0] for v in scratch):.2f}" if scratch else ""
        print(f"| {character} | {run} | {len(values)} | {default:.3f}{default_se} | {one:.3f}{one_se} | {ratio} |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/guide-kenney")
