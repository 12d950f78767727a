#!/usr/bin/env python3
"""What every pool frame taught, set against each criterion's ranking (bench/suggest_oracle.sh).

Per run: the gain of each of the 32 pool frames (the control's default-fit error less the model's
after that frame was added), then how each criterion ranks the pool against it: Spearman's rank
correlation, the gain of the criterion's top pick, and where that pick's gain ranks. The best
frame's gain is the ceiling a perfect criterion would reach; the pool's mean gain is what a
random pick gets on average. Where the continuations ran again with other seeds (again-seed-S/),
the gains per seed, how much of a frame's gain is the frame (the share of the variance that lies
between frames, the intraclass correlation), and each criterion's rank correlation with the
frames' gains averaged over the seeds.

    python3 bench/suggest_oracle.py runs/suggest-gain-5/char-31/seed-1 [more runs]
"""
import json
import math
import pathlib
import sys

CRITERIA = {"misread": "misread_px", "coverage": "coverage_px", "distance": "distance_degrees"}


def ranks(xs):
    order = sorted(range(len(xs)), key=lambda i: xs[i])
    r = [0.0] * len(xs)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and xs[order[j + 1]] == xs[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2
        i = j + 1
    return r


def spearman(xs, ys):
    rx, ry = ranks(xs), ranks(ys)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    cov = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    return cov / math.sqrt(sum((a - mx) ** 2 for a in rx) * sum((b - my) ** 2 for b in ry))


def angles(truth):
    """Each frame's part angles (radians) from the generator's world transforms."""
    return [[math.atan2(p["world"]["b"], p["world"]["a"]) for p in f["parts"]] for f in truth["frames"]]


def turn_distance(a, b):
    d = [math.remainder(x - y, math.tau) for x, y in zip(a, b)]
    return math.degrees(math.sqrt(sum(x * x for x in d) / len(d)))


def main(runs):
    for run in map(pathlib.Path, runs):
        root = run.parent
        control = json.load(open(run / "none" / "eval.json"))["mean"]
        gains = {}
        for k in range(32):
            path = run / f"pool-{k}" / "eval.json"
            if path.is_file():
                mean = json.load(open(path))["mean"]
                gains[k] = {m: control[m] - mean[m] for m in ["vertex_error", "l2"]}
        if len(gains) < 4:
            print(f"{run}: {len(gains)} pool frames scored, too few")
            continue
        scores = {}
        for name, key in CRITERIA.items():
            ranked = json.load(open(run / f"rank-{name}" / "suggestions.json"))["suggestions"]
            scores[name] = {s["origin"]["index"]: s[key] for s in ranked}
        pool, train = angles(json.load(open(root / "pool" / "truth.json"))), angles(json.load(open(root / "train" / "truth.json")))
        # Poses near many others in the pool are typical of the motion the test is drawn from.
        sigma = 20.0
        scores["typical (pool density)"] = {
            k: sum(math.exp(-0.5 * (turn_distance(pool[k], q) / sigma) ** 2) for q in pool) for k in range(len(pool))
        }
        scores["distance (true angles)"] = {k: min(turn_distance(pool[k], t) for t in train) for k in range(len(pool))}
        scores["density x distance"] = {k: scores["typical (pool density)"][k] * scores["distance (true angles)"][k] for k in range(len(pool))}
        ks = sorted(gains)
        for metric in ["vertex_error", "l2"]:
            g = [gains[k][metric] for k in ks]
            best = max(g)
            print(f"{run} ({len(ks)} of 32 pool frames), default-fit {metric} gain: "
                  f"mean {sum(g) / len(g):.3f}, best {best:.3f}, worst {min(g):.3f}")
            for name, by in scores.items():
                s = [by[k] for k in ks]
                top = max(ks, key=lambda k: by[k])
                place = 1 + sum(gains[k][metric] > gains[top][metric] for k in ks)
                print(f"  {name:24} rho {spearman(s, g):+.2f}   top pick {top:2d}: gain {gains[top][metric]:+.3f} (rank {place} of {len(ks)})")
        seeds(run, gains, scores)


def variance_split(runs):
    """One-way analysis of variance of gains measured under several training seeds. `runs` is a
    list of runs, each a list of groups (a frame or a selector), each group its gains under the
    same n seeds, with each seed's mean over the run's groups already taken out (a seed can move
    every group alike; paired comparisons cancel that). Returns the variance of one measurement
    around its group's mean (within), the variance of the groups' own gains (between), and the
    intraclass correlation: the share of one measurement's variance that is its group."""
    n = len(runs[0][0])
    between_sum = within_sum = 0.0
    between_df = within_df = 0
    for groups in runs:
        means = [sum(g) / n for g in groups]
        grand = sum(means) / len(means)
        between_sum += n * sum((m - grand) ** 2 for m in means)
        between_df += len(means) - 1
        within_sum += sum((x - sum(g) / n) ** 2 for g in groups for x in g)
        within_df += len(groups) * (n - 1)
    between, within = between_sum / between_df, within_sum / within_df
    icc = (between - within) / (between + (n - 1) * within)
    return within, max(0.0, (between - within) / n), icc


def seeds(run, gains, scores):
    """The gains of the frames continued again with other seeds, and the variance between frames."""
    again = sorted(
        (p for p in run.glob("again-seed-*") if (p / "none" / "eval.json").is_file()),
        key=lambda p: int(p.name.rsplit("-", 1)[1]),
    )
    if not again:
        return
    by_frame = {k: [g["vertex_error"]] for k, g in gains.items()}
    for path in again:
        control_s = json.load(open(path / "none" / "eval.json"))["mean"]["vertex_error"]
        for k in list(by_frame):
            report = path / str(k) / "eval.json"
            if report.is_file():
                by_frame[k].append(control_s - json.load(open(report))["mean"]["vertex_error"])
    n = 1 + len(again)
    full = {k: g for k, g in by_frame.items() if len(g) == n}
    if len(full) < 2:
        return
    print(f"  default-fit vertex_error gain by training seed (1, then {', '.join(p.name for p in again)}):")
    for k, g in sorted(full.items(), key=lambda kg: sum(kg[1])):
        print(f"    pool frame {k:2d}: " + "  ".join(f"{x:+.3f}" for x in g) + f"   mean {sum(g) / n:+.3f}")
    # A seed can move every frame's gain alike; a run's selectors share their seed, so that part
    # cancels in the paired comparison, and what matters is the frames' order within a seed.
    seed_mean = [sum(g[i] for g in full.values()) / len(full) for i in range(n)]
    print("    mean over these frames by seed: " + "  ".join(f"{m:+.3f}" for m in seed_mean))
    full = {k: [x - m for x, m in zip(g, seed_mean)] for k, g in full.items()}
    within, between, icc = variance_split([list(full.values())])
    print(f"    mean gain over these frames and seeds {sum(seed_mean) / n:+.3f}; sd of the frames' own gains {between ** 0.5:.3f}")
    ks = sorted(full)
    for name, by in scores.items():
        print(f"    {name:24} rho against the frames' mean gains {spearman([by[k] for k in ks], [sum(full[k]) / n for k in ks]):+.2f}")
    print(f"    within a seed: seed-to-seed sd of one frame's gain {within ** 0.5:.3f}; "
          f"share of the variance that is the frame (ICC) {icc:+.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
