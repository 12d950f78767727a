#!/usr/bin/env python3
"""Renders a Spine JSON skeleton written by `puppet export spine` at each key of one animation,
by Spine's documented rules alone (bones: setup values plus linearly interpolated rotate /
translate keys, parents first; weighted mesh vertices plus deform offsets; mesh UVs inside the
atlas region), and compares each render with puppet's own PNG of that pose.

    python3 bench/spine_render.py out/robot-spine/robot.json latent out/robot-walk/latent/step_*.png \
        -o out/robot-spine/check.png [--skin NAME]

Writes a sheet (rows: Spine-rule render, puppet's render, |difference| ×4) and prints, per key,
the share of pixels whose alpha differs by more than ½ and the mean |ΔRGBA| (0–255). Needs numpy
and Pillow; run by hand, not by the tests.
"""
import argparse
import json
import math
import os

import numpy as np
from PIL import Image


def interpolate(keys, time, values, default):
    """A timeline's value at `time`: `values(key)` of the keys around it, linearly interpolated
    (held before the first key and after the last); `default` without keys."""
    if not keys:
        return default
    later = [i for i, k in enumerate(keys) if k.get("time", 0.0) > time]
    if not later:
        return values(keys[-1])
    i = later[0]
    if i == 0:
        return values(keys[0])
    t0, t1 = keys[i - 1].get("time", 0.0), keys[i].get("time", 0.0)
    s = (time - t0) / (t1 - t0)
    return [a + (b - a) * s for a, b in zip(values(keys[i - 1]), values(keys[i]))]


def keyed(keys, time, fields):
    return interpolate(keys, time, lambda k: [k.get(f, 0.0) for f in fields], [0.0] * len(fields))


def deform(keys, time, length):
    """Deform offsets at `time` (keys hold arrays starting at `offset`)."""
    def full(k):
        v = [0.0] * length
        o = k.get("offset", 0)
        for i, x in enumerate(k.get("vertices", [])):
            v[o + i] = x
        return v
    return interpolate(keys, time, full, [0.0] * length)


def read_atlas(path):
    lines = [l.strip() for l in open(path) if l.strip()]
    page, regions, name = lines[0], {}, None
    for line in lines[1:]:
        if ":" not in line:
            name = line
        elif name is not None and line.startswith("bounds:"):
            regions[name] = [int(v) for v in line.split(":")[1].split(",")]
    return page, regions


def world_vertices(skel, animation, time, skin="default"):
    anim = skel["animations"][animation]
    bones, world = {}, []
    for bone in skel["bones"]:
        tl = anim.get("bones", {}).get(bone["name"], {})
        r = bone.get("rotation", 0.0) + keyed(tl.get("rotate"), time, ["value"])[0]
        tx, ty = keyed(tl.get("translate"), time, ["x", "y"])
        x, y = bone.get("x", 0.0) + tx, bone.get("y", 0.0) + ty
        c, s = math.cos(math.radians(r)), math.sin(math.radians(r))
        la, lb, lc, ld = c, -s, s, c
        if "parent" not in bone:
            m = (la, lb, lc, ld, x, y)
        else:
            pa, pb, pc, pd, px, py = bones[bone["parent"]]
            m = (pa * la + pb * lc, pa * lb + pb * ld, pc * la + pd * lc, pc * lb + pd * ld,
                 pa * x + pb * y + px, pc * x + pd * y + py)
        bones[bone["name"]] = m
        world.append(m)
    skins = {s["name"]: s["attachments"] for s in skel["skins"]}
    out = []
    for slot in skel["slots"]:
        att = slot["attachment"]
        # The active skin first, then the default skin; a slot in neither is not drawn.
        found = next((k for k in (skin, "default") if att in skins.get(k, {}).get(slot["name"], {})), None)
        if found is None:
            continue
        mesh = skins[found][slot["name"]][att]
        raw = mesh["vertices"]
        keys = anim.get("attachments", {}).get(found, {}).get(slot["name"], {}).get(att, {}).get("deform")
        n_weights = 0
        i = 0
        while i < len(raw):
            n_weights += int(raw[i]); i += 1 + 4 * int(raw[i])
        off = deform(keys, time, 2 * n_weights)
        pts, i, e = [], 0, 0
        while i < len(raw):
            n = int(raw[i]); i += 1
            px = py = 0.0
            for _ in range(n):
                a, b, c, d, wx, wy = world[int(raw[i])]
                vx, vy, w = raw[i + 1] + off[2 * e], raw[i + 2] + off[2 * e + 1], raw[i + 3]
                px += (a * vx + b * vy + wx) * w
                py += (c * vx + d * vy + wy) * w
                i += 4; e += 1
            pts.append((px, py))
        out.append((slot["name"], mesh, pts))
    return out


def render(skel, animation, time, page, regions, size, skin="default"):
    w, h = size
    img = np.zeros((h, w, 4), np.float64)
    tex = np.asarray(page, np.float64) / 255.0
    for name, mesh, pts in world_vertices(skel, animation, time, skin):
        rx, ry, rw, rh = regions[name]
        uv = np.array(mesh["uvs"]).reshape(-1, 2)
        # Spine space (origin bottom centre, y up) to frame pixels.
        p = np.array([(x + w / 2.0, h - y) for x, y in pts])
        for t in np.array(mesh["triangles"]).reshape(-1, 3):
            a, b, c = p[t]
            x0, y0 = np.floor(np.minimum(np.minimum(a, b), c)).astype(int)
            x1, y1 = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int)
            x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
            if x0 >= x1 or y0 >= y1:
                continue
            gx, gy = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
            det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1])
            if abs(det) < 1e-12:
                continue
            l0 = ((b[1] - c[1]) * (gx - c[0]) + (c[0] - b[0]) * (gy - c[1])) / det
            l1 = ((c[1] - a[1]) * (gx - c[0]) + (a[0] - c[0]) * (gy - c[1])) / det
            l2 = 1 - l0 - l1
            inside = (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
            if not inside.any():
                continue
            u = l0 * uv[t[0], 0] + l1 * uv[t[1], 0] + l2 * uv[t[2], 0]
            v = l0 * uv[t[0], 1] + l1 * uv[t[1], 1] + l2 * uv[t[2], 1]
            sx = np.clip((rx + u * rw).astype(int), 0, tex.shape[1] - 1)
            sy = np.clip((ry + v * rh).astype(int), 0, tex.shape[0] - 1)
            src = tex[sy, sx]
            dst = img[y0:y1, x0:x1]
            sa = src[..., 3:4] * inside[..., None]
            out_a = sa + dst[..., 3:4] * (1 - sa)
            rgb = np.where(out_a > 0, (src[..., :3] * sa + dst[..., :3] * dst[..., 3:4] * (1 - sa)) / np.maximum(out_a, 1e-12), 0)
            img[y0:y1, x0:x1] = np.concatenate([rgb, out_a], axis=-1)
    return (img * 255).round().clip(0, 255).astype(np.uint8)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("skeleton")
    ap.add_argument("animation")
    ap.add_argument("renders", nargs="+", help="puppet's PNG of each key, in order")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--fps", type=float, default=12.0)
    ap.add_argument("--skin", default="default", help="the skin to draw (default: the default skin)")
    args = ap.parse_args()
    skel = json.load(open(args.skeleton))
    atlas = os.path.splitext(args.skeleton)[0] + ".atlas"
    page_name, regions = read_atlas(atlas)
    page = Image.open(os.path.join(os.path.dirname(atlas), page_name)).convert("RGBA")
    ours = [np.asarray(Image.open(p).convert("RGBA")) for p in args.renders]
    h, w = ours[0].shape[:2]
    rows = [[], [], []]
    for k, theirs in enumerate(ours):
        spine = render(skel, args.animation, k / args.fps, page, regions, (w, h), args.skin)
        diff = np.abs(spine.astype(int) - theirs.astype(int))
        alpha_off = float(np.mean(diff[..., 3] > 127))
        print(f"key {k}: alpha differs on {100 * alpha_off:.2f} % of pixels, mean |ΔRGBA| {diff.mean():.2f}")
        rows[0].append(spine); rows[1].append(theirs)
        rows[2].append(np.concatenate([np.clip(diff[..., :3] * 4, 0, 255), np.full((h, w, 1), 255)], -1).astype(np.uint8))
    sheet = np.concatenate([np.concatenate(r, axis=1) for r in rows], axis=0)
    back = Image.new("RGBA", (sheet.shape[1], sheet.shape[0]), (255, 255, 255, 255))
    back.alpha_composite(Image.fromarray(sheet, "RGBA"))
    back.save(args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
