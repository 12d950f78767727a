#!/usr/bin/env python3
"""The optical-flow peer (DESIGN.md "Peers"): OpenCV DIS flow in place of the paper's PWC-Net.

Two uses, both reading what the Rust side wrote to files:

  warp  (issue 5, neural-puppet.md Table 1 protocol): for each target frame, DIS flow is computed
        target -> reference (I0 = target, I1 = reference) at full resolution (finest scale 0),
        the reference frame is warped into the target (cv2.remap at x + flow), and the L2 of
        DESIGN.md (RGB composited on white, values in [0, 255], Frobenius norm) to the target is
        printed, with the unchanged reference and DIS's medium preset beside it.

        python3 bench/flow_dis.py warp --reference data/kenney/robot/frames/robot_idle.png \
            data/kenney/robot/frames/robot_walk*.png data/kenney/robot/frames/robot_{jump,fall}.png
        python3 bench/flow_dis.py warp --reference SEQ/frames/frame_000.png --split MODEL/split.json

  pck   (issue 6, Table 2 protocol): reads the keypoints file of `puppet correspond --sequence`
        (each ordered held-out pair a -> b: visible keypoints in a, their truth in b, our
        matches), computes DIS flow a -> b (full resolution), moves each keypoint by the flow
        sampled bilinearly at it, and prints PCK@{0.1, 0.05, 0.025} (within alpha * max(W, H),
        per pair, averaged over pairs) for DIS and for ours from the same file.

        python3 bench/flow_dis.py pck keypoints.json

  posed (issue 56, the prior's baseline): reads the folders `puppet prior data` wrote (one per
        character: pose_NNN.png and pose_NNN.json with every template vertex and its visibility),
        takes the disjoint pairs of consecutive poses (0 -> 1, 2 -> 3, ...), computes DIS flow
        a -> b, moves each vertex visible in both by the flow sampled at it, and prints
        PCK@{0.1, 0.05, 0.025} against its true place in b (per pair, averaged over pairs), per
        character and over all of them.

        puppet prior data data/kenney/robot data/rigs/dicebear/notionists-1 -o out/prior --poses 16
        python3 bench/flow_dis.py posed out/prior/*

Flow is computed on the frames composited on white and converted to grey (DIS works on 8-bit
grey images). Setup: pip install opencv-python-headless numpy.
"""

import argparse
import json
import os
import sys

import cv2
import numpy as np


def load_rgba(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        sys.exit(f"flow_dis.py: cannot read {path}")
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGRA)
    elif img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2BGRA)
    return img.astype(np.float64) / 255.0  # B, G, R, A in [0, 1]


def on_white(rgba):
    a = rgba[..., 3:4]
    return rgba[..., :3] * a + (1.0 - a)


def grey(rgba):
    return cv2.cvtColor((on_white(rgba) * 255.0).round().astype(np.uint8), cv2.COLOR_BGR2GRAY)


def l2(a_rgb, b_rgb):
    return float(np.sqrt(np.sum((255.0 * (a_rgb - b_rgb)) ** 2)))


def dis(preset, full_resolution):
    d = cv2.DISOpticalFlow_create(preset)
    if full_resolution:
        d.setFinestScale(0)
    return d


def flow(d, i0, i1):
    return d.calc(i0, i1, None)


def warp(reference_rgba, f):
    """Pulls the reference into the target's frame: out(x) = reference(x + flow(x))."""
    h, w = f.shape[:2]
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    mx, my = gx + f[..., 0], gy + f[..., 1]
    # Straight alpha: resample premultiplied colour so transparent pixels do not bleed.
    pre = reference_rgba.copy()
    pre[..., :3] *= pre[..., 3:4]
    out = cv2.remap(pre.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    out = out.astype(np.float64)
    a = out[..., 3:4]
    rgb = np.where(a > 1e-6, out[..., :3] / np.maximum(a, 1e-6), 0.0)
    return np.concatenate([np.clip(rgb, 0, 1), np.clip(a, 0, 1)], axis=-1)


def cmd_warp(args):
    frames = list(args.frames)
    if args.split:
        with open(args.split) as fh:
            split = json.load(fh)
        base = os.path.join(os.path.dirname(os.path.abspath(args.split)), split["frames"]) if not os.path.isabs(split["frames"]) else split["frames"]
        folder = os.path.join(base, "frames") if os.path.isdir(os.path.join(base, "frames")) else base
        frames += [os.path.join(folder, name) for name in split["test"]]
    if not frames:
        sys.exit("flow_dis.py warp: no target frames")
    ref = load_rgba(args.reference)
    ref_grey = grey(ref)
    methods = {"DIS full res": dis(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, True), "DIS medium": dis(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, False)}
    totals = {"reference": [], **{m: [] for m in methods}}
    print(f"{'frame':<32} {'reference':>10} " + " ".join(f"{m:>13}" for m in methods))
    for path in frames:
        target = load_rgba(path)
        if target.shape != ref.shape:
            sys.exit(f"flow_dis.py: {path} is {target.shape[1]}x{target.shape[0]}, the reference {ref.shape[1]}x{ref.shape[0]}")
        t_rgb = on_white(target)
        row = {"reference": l2(on_white(ref), t_rgb)}
        for m, d in methods.items():
            row[m] = l2(on_white(warp(ref, flow(d, grey(target), ref_grey))), t_rgb)
        for k, v in row.items():
            totals[k].append(v)
        print(f"{os.path.basename(path):<32} {row['reference']:>10.1f} " + " ".join(f"{row[m]:>13.1f}" for m in methods))
    print(f"{'mean':<32} {np.mean(totals['reference']):>10.1f} " + " ".join(f"{np.mean(totals[m]):>13.1f}" for m in methods))


def bilinear(f, x, y):
    """Flow sampled at pixel-centre coordinates (x, y) (pixel (i, j) has centre (i + .5, j + .5))."""
    h, w = f.shape[:2]
    gx, gy = x - 0.5, y - 0.5
    x0, y0 = int(np.floor(gx)), int(np.floor(gy))
    tx, ty = gx - x0, gy - y0
    out = np.zeros(2)
    for dx, dy, wgt in ((0, 0, (1 - tx) * (1 - ty)), (1, 0, tx * (1 - ty)), (0, 1, (1 - tx) * ty), (1, 1, tx * ty)):
        xi, yi = min(max(x0 + dx, 0), w - 1), min(max(y0 + dy, 0), h - 1)
        out += wgt * f[yi, xi]
    return out


def pck_of(pred, truth, alpha, size):
    if len(truth) == 0:
        return 1.0
    d = np.linalg.norm(np.asarray(pred, dtype=np.float64) - np.asarray(truth, dtype=np.float64), axis=1)
    d = np.where(np.isfinite(d), d, np.inf)
    return float(np.mean(d <= alpha * size))


def cmd_pck(args):
    with open(args.keypoints) as fh:
        data = json.load(fh)
    alphas, size = data["alphas"], max(data["width"], data["height"])
    d = dis(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, True)
    ours, peer = np.zeros(len(alphas)), np.zeros(len(alphas))
    cache = {}

    def grey_of(path):
        if path not in cache:
            cache[path] = grey(load_rgba(path))
        return cache[path]

    for pair in data["pairs"]:
        f = flow(d, grey_of(pair["a"]), grey_of(pair["b"]))
        pts = pair["points_a"]
        dis_b = [[x + v[0], y + v[1]] for (x, y), v in ((p, bilinear(f, p[0], p[1])) for p in pts)]
        ours_b = [p if p is not None else [np.inf, np.inf] for p in pair["ours_b"]]
        for i, a in enumerate(alphas):
            peer[i] += pck_of(dis_b, pair["truth_b"], a, size)
            ours[i] += pck_of(ours_b, pair["truth_b"], a, size)
    n = max(len(data["pairs"]), 1)
    print(f"{len(data['pairs'])} pairs, {sum(len(p['points_a']) for p in data['pairs'])} keypoints, L = {size} px")
    print("method        " + " ".join(f"PCK@{a:<6}" for a in alphas))
    print("ours          " + " ".join(f"{100 * v / n:>9.2f}%" for v in ours))
    print("DIS (OpenCV)  " + " ".join(f"{100 * v / n:>9.2f}%" for v in peer))
    stored = data.get("ours")
    if stored is not None and not np.allclose(np.asarray(stored) * n, ours, atol=1e-6 * n):
        print(f"warning: the file's own scores {stored} differ from the recomputed ones", file=sys.stderr)


def cmd_posed(args):
    alphas = [0.1, 0.05, 0.025]
    d = dis(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, True)
    print("character                 pairs  vertices " + " ".join(f"PCK@{a:<6}" for a in alphas))
    totals, count = np.zeros(len(alphas)), 0
    for folder in args.folders:
        poses = sorted(f[: -len(".json")] for f in os.listdir(folder) if f.startswith("pose_") and f.endswith(".json"))
        sums, pairs, points = np.zeros(len(alphas)), 0, 0
        for a, b in zip(poses[0::2], poses[1::2]):
            with open(os.path.join(folder, a + ".json")) as fh:
                ta = json.load(fh)
            with open(os.path.join(folder, b + ".json")) as fh:
                tb = json.load(fh)
            ia, ib = load_rgba(os.path.join(folder, a + ".png")), load_rgba(os.path.join(folder, b + ".png"))
            size = max(ia.shape[0], ia.shape[1])
            f = flow(d, grey(ia), grey(ib))
            both = [k for k, (va, vb) in enumerate(zip(ta["visible"], tb["visible"])) if va and vb]
            pred = [[ta["vertices"][k][0] + v[0], ta["vertices"][k][1] + v[1]]
                    for k, v in ((k, bilinear(f, *ta["vertices"][k])) for k in both)]
            truth = [tb["vertices"][k] for k in both]
            sums += [pck_of(pred, truth, al, size) for al in alphas]
            pairs += 1
            points += len(both)
        if pairs:
            print(f"{os.path.basename(folder.rstrip('/')):<25} {pairs:>5} {points:>9} "
                  + " ".join(f"{100 * v / pairs:>9.2f}%" for v in sums))
            totals += sums / pairs
            count += 1
    if count:
        print(f"{'mean over characters':<25} {'':>5} {'':>9} " + " ".join(f"{100 * v / count:>9.2f}%" for v in totals))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("warp", help="L2 of the DIS-warped reference frame (issue 5)")
    w.add_argument("--reference", required=True)
    w.add_argument("--split", help="a model's split.json: add its held-out frames as targets")
    w.add_argument("frames", nargs="*")
    k = sub.add_parser("pck", help="PCK of DIS vs ours on `puppet correspond --sequence` keypoints (issue 6)")
    k.add_argument("keypoints")
    q = sub.add_parser("posed", help="PCK of DIS on the pose pairs of `puppet prior data` (issue 56)")
    q.add_argument("folders", nargs="+")
    args = p.parse_args()
    cv2.setNumThreads(2)
    {"warp": cmd_warp, "pck": cmd_pck, "posed": cmd_posed}[args.cmd](args)


if __name__ == "__main__":
    main()
