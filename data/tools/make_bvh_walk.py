#!/usr/bin/env python3
"""Writes data/motion/walk.bvh: a simple humanoid walk cycle on the spot, our own (CC0).

A BVH skeleton in the usual convention (y up, facing +z, centimetres, rotation channels
Zrotation Xrotation Yrotation) with the joint names of Mixamo and the CMU conversions (Hips,
Spine, LeftUpLeg, LeftLeg, LeftArm, LeftForeArm, ...), arms hanging at rest. One cycle of
36 frames at 30 frames a second, so the file loops: frame k is at phase 2*pi*k/36.

The curves are sines, shaped after the textbook gait (thigh +-25 degrees, the knee bending in
the swing, arms swinging against the legs, the hips bobbing twice a cycle). Python's standard
library only:

    python3 data/tools/make_bvh_walk.py data/motion/walk.bvh
"""

import math
import sys

FRAMES = 36
FRAME_TIME = 1.0 / 30.0

# (name, parent, offset, channel count): parents before children; "End" rows are end sites.
SKELETON = [
    ("Hips", None, (0.0, 0.0, 0.0), 6),
    ("Spine", "Hips", (0.0, 10.0, 0.0), 3),
    ("Chest", "Spine", (0.0, 15.0, 0.0), 3),
    ("Neck", "Chest", (0.0, 20.0, 0.0), 3),
    ("Head", "Neck", (0.0, 10.0, 0.0), 3),
    ("End", "Head", (0.0, 18.0, 0.0), 0),
]
for side, sign in (("Left", 1.0), ("Right", -1.0)):
    SKELETON += [
        (f"{side}Shoulder", "Chest", (3.0 * sign, 17.0, 0.0), 3),
        (f"{side}Arm", f"{side}Shoulder", (14.0 * sign, 0.0, 0.0), 3),
        (f"{side}ForeArm", f"{side}Arm", (0.0, -28.0, 0.0), 3),
        (f"{side}Hand", f"{side}ForeArm", (0.0, -26.0, 0.0), 3),
        ("End", f"{side}Hand", (0.0, -16.0, 0.0), 0),
        (f"{side}UpLeg", "Hips", (9.0 * sign, -3.0, 0.0), 3),
        (f"{side}Leg", f"{side}UpLeg", (0.0, -42.0, 0.0), 3),
        (f"{side}Foot", f"{side}Leg", (0.0, -42.0, 0.0), 3),
        (f"{side}ToeBase", f"{side}Foot", (0.0, -6.0, 14.0), 3),
        ("End", f"{side}ToeBase", (0.0, 0.0, 6.0), 0),
    ]


def pose(k):
    """The channel values of every joint at frame k, as {name: [values]} (degrees, cm)."""
    phi = 2.0 * math.pi * k / FRAMES
    values = {
        # On the spot: a bob (lowest at each contact, twice a cycle) and a sway to the standing leg.
        "Hips": [1.5 * math.sin(phi), 95.0 + 1.5 * math.cos(2.0 * phi), 0.0, 3.0 * math.sin(phi), 0.0, 5.0 * math.sin(phi)],
        "Spine": [-1.5 * math.sin(phi), 2.0, -3.0 * math.sin(phi)],
        "Chest": [0.0, 1.0, -2.0 * math.sin(phi)],
        "Neck": [0.0, 0.0, 0.0],
        "Head": [-1.0 * math.sin(phi), -3.0 + 2.0 * math.cos(2.0 * phi), 0.0],
    }
    for side, sign, shift in (("Left", 1.0, 0.0), ("Right", -1.0, math.pi)):
        p = phi + shift
        forward = 25.0 * math.sin(p)  # thigh forwards, degrees
        knee = 5.0 + 40.0 * max(0.0, math.cos(p - 0.3)) ** 2  # bends in the swing
        arm = -20.0 * math.sin(p)  # against the leg of its side
        # A rotation about x by -a swings a bone hanging down forwards (towards +z) by a.
        values[f"{side}UpLeg"] = [1.5 * sign * math.sin(phi), -forward, 0.0]
        values[f"{side}Leg"] = [0.0, knee, 0.0]
        values[f"{side}Foot"] = [0.0, -0.5 * knee + 0.3 * forward, 0.0]
        values[f"{side}ToeBase"] = [0.0, 0.0, 0.0]
        values[f"{side}Shoulder"] = [0.0, 0.0, 0.0]
        # Arms a little away from the body (about z), swinging against the legs (about x).
        values[f"{side}Arm"] = [sign * (8.0 + 2.0 * math.sin(p)), -arm, 0.0]
        values[f"{side}ForeArm"] = [0.0, -(15.0 + 10.0 * max(0.0, -math.sin(p))), 0.0]
        values[f"{side}Hand"] = [0.0, -5.0, 0.0]
    return values


def hierarchy():
    """The HIERARCHY lines and the joints in the order their channels are listed (depth first)."""
    children = {}
    for name, parent, offset, n in SKELETON:
        children.setdefault(parent, []).append((name, offset, n))
    lines = ["HIERARCHY"]
    order = []

    def joint(name, offset, n, depth, keyword):
        pad = "  " * depth
        order.append(name)
        lines.append(f"{pad}{keyword} {name}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {offset[0]:.2f} {offset[1]:.2f} {offset[2]:.2f}")
        rotations = "Zrotation Xrotation Yrotation"
        channels = f"Xposition Yposition Zposition {rotations}" if n == 6 else rotations
        lines.append(f"{pad}  CHANNELS {n} {channels}")
        for child, child_offset, child_n in children.get(name, []):
            if child == "End":
                lines.append(f"{pad}  End Site")
                lines.append(pad + "  {")
                lines.append(f"{pad}    OFFSET {child_offset[0]:.2f} {child_offset[1]:.2f} {child_offset[2]:.2f}")
                lines.append(pad + "  }")
            else:
                joint(child, child_offset, child_n, depth + 1, "JOINT")
        lines.append(pad + "}")

    root = children[None][0]
    joint(root[0], root[1], root[2], 0, "ROOT")
    return lines, order


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "data/motion/walk.bvh"
    lines, order = hierarchy()
    lines += ["MOTION", f"Frames: {FRAMES}", f"Frame Time: {FRAME_TIME:.6f}"]
    for k in range(FRAMES):
        values = pose(k)
        lines.append(" ".join(f"{v:.4f}" for name in order for v in values[name]))
    with open(out, "w", encoding="ascii") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
