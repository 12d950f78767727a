#!/usr/bin/env python3
"""The table of bench/suggest_gain.sh: per selector, the held-out error after the added frame and
its gain over the control (the same continuation on the training frames alone), mean over every
character and seed; then suggest's gain as a multiple of random's and farthest-first's. Where a
run's continuations were repeated with other training seeds (bench/suggest_gain.sh's
AGAIN_SEEDS), each variant's error in that run is the mean over those seeds.

    python3 bench/suggest_gain.py runs/suggest-gain
"""
import json
import pathlib
import sys

from suggest_oracle import variance_split

VARIANTS = ["none", "misread", "coverage", "typical", "distance", "random"]
# The suggest criteria: a run may lack any of them (bench/suggest_gain.sh's VARIANTS), never the
# control and the two baselines.
CRITERIA = ["misread", "coverage", "typical"]
NAMES = {
    "none": "control (the training frames alone)",
    "misread": "suggest (misread)",
    "coverage": "suggest (coverage)",
    "typical": "suggest (typical)",
    "distance": "farthest first",
    "random": "random",
}


def mean(xs):
    return sum(xs) / len(xs) if xs else float("nan")


def standard_error(xs):
    if len(xs) < 2:
        return float("nan")
    m = mean(xs)
    return (sum((x - m) ** 2 for x in xs) / (len(xs) - 1) / len(xs)) ** 0.5


def main(root):
    runs = sorted(p for p in pathlib.Path(root).glob("char-*/seed-*") if (p / "none" / "eval.json").is_file())
    if not runs:
        sys.exit(f"{root}: no finished runs")
    rows = {}  # (fit, metric) -> variant -> [value per run]
    by_seed = {}  # fit -> per run with training seeds repeated: variant -> [vertex error per seed]
    same = {}  # criterion -> runs where it picked farthest-first's frame
    for run in runs:
        reports = {}
        for v in VARIANTS:
            reports[v] = {
                fit: json.load(open(run / v / f"eval{suffix}.json"))["mean"]
                for fit, suffix in [("default", ""), ("one-pass", "-one-pass")]
                if (run / v / f"eval{suffix}.json").is_file()
            }
        if any(len(reports[v]) < 2 for v in VARIANTS if v not in CRITERIA):
            continue
        for v in CRITERIA:
            if len(reports[v]) < 2:
                del reports[v]
        picks = {v: (run / f"{v}-frames.index").read_text().strip() for v in reports if v != "none"}
        # Every criterion's pick, continued or not (the pick-* folders of bench/suggest_gain.sh).
        all_picks = {
            p.name[len("pick-"):]: json.load(open(p / "suggestions.json"))["suggestions"][0]["origin"]["index"]
            for p in sorted(run.glob("pick-*"))
            if (p / "suggestions.json").is_file()
        }
        for v in reports:
            if v in CRITERIA:
                same[v] = same.get(v, 0) + (picks[v] == picks["distance"])
        # The continuations again with other training seeds (AGAIN_SEEDS), where every variant has
        # both reports: each variant's error is then the mean over the seeds.
        again = [
            d
            for d in run.glob("again-seed-*")
            if all((d / v / f"eval{suffix}.json").is_file() for v in reports for suffix in ["", "-one-pass"])
        ]
        print(f"{run.parent.name}/{run.name}: continued {picks}, every pick {all_picks}, training seeds {1 + len(again)}")
        for fit, suffix in [("default", ""), ("one-pass", "-one-pass")]:
            for metric in ["vertex_error", "l2"]:
                per_seed = {}
                for v in reports:
                    values = [reports[v][fit][metric]]
                    values += [json.load(open(d / v / f"eval{suffix}.json"))["mean"][metric] for d in again]
                    rows.setdefault((fit, metric), {}).setdefault(v, []).append(mean(values))
                    per_seed[v] = values
                if metric == "vertex_error" and again:
                    by_seed.setdefault(fit, []).append(per_seed)
    n = len(rows[("default", "l2")]["none"])
    # A criterion continued in only some runs cannot be paired run by run with the others.
    for by in rows.values():
        for v in [v for v in by if len(by[v]) != n]:
            print(f"{NAMES[v]}: continued in {len(by[v])} of {n} runs, left out", file=sys.stderr)
            del by[v]
    same_text = ", ".join(f"{v} in {k}" for v, k in same.items())
    print(f"\n{n} runs; the criteria picked farthest-first's frame: {same_text}\n")
    for (fit, metric), by in rows.items():
        unit = "px" if metric == "vertex_error" else "L2"
        print(f"{fit} fit, {metric} ({unit}):")
        gains = {v: [c - x for c, x in zip(by["none"], by[v])] for v in by if v != "none"}
        for v in (v for v in VARIANTS if v in by):
            g = (
                f"  gain {mean(gains[v]):+.3f} ± {standard_error(gains[v]):.3f}  (better than control in {sum(x > 0 for x in gains[v])}/{n})"
                if v in gains
                else ""
            )
            print(f"  {NAMES[v]:<20} {mean(by[v]):10.3f}{g}")
        ratio = lambda a, b: mean(gains[a]) / mean(gains[b]) if mean(gains[b]) > 0 else float("nan")
        for v in (v for v in CRITERIA if v in gains):
            print(f"  {NAMES[v]}'s gain / random's: {ratio(v, 'random'):.2f}   / farthest-first's: {ratio(v, 'distance'):.2f}")
            # Paired: the same run's base model and control, so the spread between runs cancels.
            for other in ["random", "distance"]:
                d = [a - b for a, b in zip(gains[v], gains[other])]
                print(f"    {NAMES[v]} less {NAMES[other]}, paired: {mean(d):+.3f} ± {standard_error(d):.3f} (ahead in {sum(x > 0 for x in d)}/{n})")
        print()
    seed_noise(by_seed)


def seed_noise(by_seed):
    """How much of one continuation's measured gain is its pick and how much its training seed,
    per fit, over the runs whose continuations ran with every seed."""
    for fit, runs in by_seed.items():
        n = min(len(r["none"]) for r in runs)
        split = []
        for r in runs:
            gains = [[c - x for c, x in zip(r["none"][:n], r[v][:n])] for v in r if v != "none"]
            seed_mean = [mean([g[i] for g in gains]) for i in range(n)]
            split.append([[x - m for x, m in zip(g, seed_mean)] for g in gains])
        within, between, icc = variance_split(split)
        control_sd = mean([standard_error(r["none"][:n]) * n**0.5 for r in runs])
        print(f"{fit} fit, vertex error, {len(runs)} runs × {n} training seeds: a pick's gain varies {within**0.5:.3f} px "
              f"from seed to seed, the picks' own gains {between**0.5:.3f} px; share that is the pick (ICC) {icc:+.2f}; "
              f"the control's sd over seeds {control_sd:.3f} px")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/suggest-gain")
