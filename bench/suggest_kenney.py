#!/usr/bin/env python3
"""The table of bench/suggest_kenney.sh: per Kenney character, each pool frame's gain (the
control's held-out L2 less the model's with that frame added), the order `puppet suggest` ranks
the pool in (misread, and farthest first), and where suggest's first pick ranks by gain.

    python3 bench/suggest_kenney.py runs/suggest-kenney
"""
import json
import pathlib
import sys

POOL = ["climb1", "jump", "walk2", "walk6"]


def order(pick_dir):
    """The pool frames in the order suggest ranked them."""
    listing = json.load(open(pick_dir / "suggestions.json"))
    return [POOL[s["origin"]["index"]] for s in listing["suggestions"]]


def main(root):
    for d in sorted(pathlib.Path(root).iterdir()):
        if not (d / "add-none" / "eval.json").is_file():
            continue
        l2 = {a: json.load(open(d / f"add-{a}" / "eval.json"))["mean"]["l2"] for a in ["none"] + POOL if (d / f"add-{a}" / "eval.json").is_file()}
        if len(l2) < len(POOL) + 1:
            continue
        gains = {a: l2["none"] - l2[a] for a in POOL}
        by_gain = sorted(POOL, key=lambda a: -gains[a])
        misread, distance = order(d / "pick-misread"), order(d / "pick-distance")
        coverage = order(d / "pick-coverage")
        print(f"{d.name}: control L2 {l2['none']:.1f}")
        for a in by_gain:
            print(f"  + {a:<7} L2 {l2[a]:8.1f}  gain {gains[a]:+8.1f}")
        print(f"  suggest ranks {misread}: its pick {misread[0]} ranks {by_gain.index(misread[0]) + 1} of {len(POOL)} by gain")
        print(f"  suggest --by coverage ranks {coverage}: its pick {coverage[0]} ranks {by_gain.index(coverage[0]) + 1} of {len(POOL)}")
        print(f"  farthest first ranks {distance}: its pick {distance[0]} ranks {by_gain.index(distance[0]) + 1} of {len(POOL)}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/suggest-kenney")
