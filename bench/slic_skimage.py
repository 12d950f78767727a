#!/usr/bin/env python3
"""The peer of `parts/slic/128` (benches/parts.rs): scikit-image's SLIC on the same pose, with
the same settings (about 100 superpixels, compactness 10, CIELAB, ten iterations, connectivity
enforced, restricted to the foreground mask: alpha >= 0.5).

  python3 bench/slic_skimage.py POSE.png [REPEATS]

The pose is the first cell of `puppet synth --sprite-sheet --frames 10 --size 128x128 --seed
9000` (cut with `bench/parts_flow.py cells`). Prints the median time per call over REPEATS
(default 200) after a warm-up, and the superpixel count. Setup: pip install scikit-image.
"""

import sys
import time

import numpy as np
from skimage.io import imread
from skimage.segmentation import slic


def main():
    path = sys.argv[1]
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    rgba = imread(path).astype(np.float64) / 255.0
    rgb, mask = rgba[..., :3], rgba[..., 3] >= 0.5
    run = lambda: slic(rgb, n_segments=100, compactness=10, max_num_iter=10, mask=mask, start_label=1, enforce_connectivity=True)
    for _ in range(5):
        labels = run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    print(f"skimage slic {path}: median {1e3 * float(np.median(times)):.3f} ms over {repeats}, {labels.max()} superpixels")


if __name__ == "__main__":
    main()
