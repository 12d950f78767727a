#!/usr/bin/env python3
"""The table of bench/guide_kenney.sh: per Kenney character and run (from scratch or from the
prior, full steps or a third), the mean held-out L2 of walk0, walk4 and fall (the frames every
Kenney figure holds out), default fit and one pass, each also as a multiple of DIS flow's L2 on
the same frames.

    python3 bench/guide_kenney.py runs/guide-kenney
"""
import json
import pathlib
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


def main(root):
    print("| character | run | default fit L2 (× DIS) | one pass L2 (× DIS) |")
    print("|---|---|---|---|")
    for d in sorted(pathlib.Path(root).iterdir()):
        if not (d / "dis.txt").is_file():
            continue
        dis = dis_mean(d / "dis.txt")
        runs = sorted((r for r in d.iterdir() if (r / "one-pass.json").is_file()), key=lambda r: (int(r.name.split("-")[1]), r.name))
        for r in runs:
            default, one = l2_mean(r / "default.json"), l2_mean(r / "one-pass.json")
            print(f"| {d.name} | {r.name} | {default:.1f} ({default / dis:.2f}) | {one:.1f} ({one / dis:.2f}) |")
        print(f"| {d.name} | DIS flow | {dis:.1f} (1.00) | |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/guide-kenney")
