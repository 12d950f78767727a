#!/usr/bin/env python3
"""The classical baseline of issue 16: part finding on optical flow (OpenCV DIS) instead of the
correspondence network, with the same back end (`puppet parts --flows`).

  cells SHEET_DIR OUT   cut a `puppet synth --sprite-sheet` folder by the grid its truth.json
                        records: OUT/poses/pose_NNN.png and OUT/labels/pose_NNN.png (the truth)
  dis POSES FLOWS       DIS flow (medium preset at full resolution, finest scale 0, as bench/flow_dis.py) from
                        every pose to every other, on the poses composited on white in grey:
                        FLOWS/flow_SSS_TTT.flo (Middlebury .flo, what `puppet parts --flows` reads)

bench/parts_dis.sh runs both over held-out seeds and scores them with `puppet eval-parts`.
Setup: pip install opencv-python-headless numpy.
"""

import argparse
import glob
import json
import os
import sys

import cv2
import numpy as np


def on_white_grey(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        sys.exit(f"parts_flow.py: cannot read {path}")
    if img.ndim == 2 or img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGRA if img.ndim == 2 else cv2.COLOR_BGR2BGRA)
    rgba = img.astype(np.float64) / 255.0
    a = rgba[..., 3:4]
    rgb = rgba[..., :3] * a + (1.0 - a)
    return cv2.cvtColor((rgb * 255.0).round().astype(np.uint8), cv2.COLOR_BGR2GRAY)


def cells(args):
    truth = json.load(open(os.path.join(args.sheet, "truth.json")))
    layout, w, h = truth["sheet"], truth["width"], truth["height"]
    for kind, name in (("poses", layout["file"]), ("labels", layout["labels"])):
        sheet = cv2.imread(os.path.join(args.sheet, name), cv2.IMREAD_UNCHANGED)
        os.makedirs(os.path.join(args.out, kind), exist_ok=True)
        for k in range(len(truth["frames"])):
            c, r = k % layout["columns"], k // layout["columns"]
            cell = sheet[r * h:(r + 1) * h, c * w:(c + 1) * w]
            cv2.imwrite(os.path.join(args.out, kind, f"pose_{k:03d}.png"), cell)


def dis(args):
    files = sorted(glob.glob(os.path.join(args.poses, "*.png")))
    if len(files) < 2:
        sys.exit(f"parts_flow.py: fewer than two poses in {args.poses}")
    grey = [on_white_grey(f) for f in files]
    flow = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    flow.setFinestScale(0)
    os.makedirs(args.flows, exist_ok=True)
    for s, a in enumerate(grey):
        for t, b in enumerate(grey):
            if s != t:
                f = flow.calc(a, b, None)
                cv2.writeOpticalFlow(os.path.join(args.flows, f"flow_{s:03d}_{t:03d}.flo"), f)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("cells")
    c.add_argument("sheet")
    c.add_argument("out")
    d = sub.add_parser("dis")
    d.add_argument("poses")
    d.add_argument("flows")
    args = parser.parse_args()
    {"cells": cells, "dis": dis}[args.command](args)


if __name__ == "__main__":
    main()
