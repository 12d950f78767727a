#!/usr/bin/env python3
"""The table of bench/auto_kenney.sh: per Kenney character, the held-out L2 (default fit) of the
hand-labelled puppet and of the parts `puppet auto` found, both trained by the character's config
(same split, settings and steps), and the ratio; the frames auto set aside (from its warnings).

    python3 bench/auto_kenney.py runs/auto-kenney
"""
import json
import pathlib
import re
import sys


def l2s(path):
    """Each held-out frame's L2 from an `eval -o` report."""
    return {r["frame"]: r["l2"] for r in json.load(open(path))["frames"]}


def main(root):
    print("| character | held-out frames | hand-labelled L2 | auto's parts L2 | ratio | set aside |")
    print("|---|---|---|---|---|---|")
    for d in sorted(pathlib.Path(root).iterdir()):
        hand, auto = d / "hand" / "default.json", d / "auto-parts" / "default.json"
        if not (hand.is_file() and auto.is_file()):
            continue
        h, a = l2s(hand), l2s(auto)
        assert h.keys() == a.keys(), f"{d}: the two puppets held out different frames"
        mh, ma = sum(h.values()) / len(h), sum(a.values()) / len(a)
        log = (d / "auto.log").read_text() if (d / "auto.log").is_file() else ""
        aside = re.findall(r"warning: (\S+) set aside", log)
        frames = ", ".join(sorted(re.sub(r"^[^_]*_|\.png$", "", f) for f in h))
        print(f"| {d.name} | {frames} | {mh:.1f} | {ma:.1f} | {ma / mh:.2f} | {', '.join(aside) or 'none'} |")


if __name__ == "__main__":
    main(sys.argv[1])
