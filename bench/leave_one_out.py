#!/usr/bin/env python3
"""Leave-one-out over a walk cycle (issue 19): for each frame of the cycle, a model trained on the
cycle's other frames with a config's settings, then that frame fitted and scored against DIS flow.

For each left-out frame F of the frames matching --cycle in the config's frames folder:
  1. OUT/F/frames/ holds copies of the other cycle frames, OUT/F/train.toml the config with
     `frames` and `output` pointed there, `test_fraction = 0` and `batch` at most their number;
  2. `puppet train` (resumed with --resume if a checkpoint exists, skipped if the model is done);
  3. `puppet eval --all` on OUT/F/test/ (F alone): one-pass and the default fit (--output JSON);
  4. DIS flow from the puppet's reference frame to F, as bench/flow_dis.py's warp does.
The table printed at the end (and OUT/summary.json) gives each fold's L2 and its ratio to DIS.

    python3 bench/leave_one_out.py configs/kenney-robot.toml --cycle walk --out runs/loo/robot

Needs a release build (target/release/puppet, or the binary $PUPPET names: a copy keeps a long run on
one build while the tree changes) and opencv-python-headless, numpy.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import flow_dis  # noqa: E402

PUPPET = os.environ.get("PUPPET") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "target", "release", "puppet")


def config_path(config_file, value):
    return os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(config_file)), value))


def reference_frame(puppet_dir):
    """The frame the puppet was cut from: its character.toml's [labels].image."""
    with open(os.path.join(puppet_dir, "character.toml"), "rb") as fh:
        character = tomllib.load(fh)
    return os.path.join(puppet_dir, character["labels"]["image"])


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def write_toml(path, table):
    """A config as TOML: top-level keys, then tables (nested one level, as configs/ are)."""
    lines = [f"{k} = {toml_value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for name, sub in table.items():
        if not isinstance(sub, dict):
            continue
        lines.append(f"\n[{name}]")
        lines += [f"{k} = {toml_value(v)}" for k, v in sub.items() if not isinstance(v, dict)]
        for inner, subsub in sub.items():
            if isinstance(subsub, dict):
                lines.append(f"\n[{name}.{inner}]")
                lines += [f"{k} = {toml_value(v)}" for k, v in subsub.items()]
    with open(path + ".tmp", "w") as fh:
        fh.write("\n".join(lines) + "\n")
    os.replace(path + ".tmp", path)


def run(cmd):
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)


def evaluate(model, test_dir, extra, out_json):
    if not os.path.exists(out_json):
        t = time.time()
        run([PUPPET, "eval", "--quiet", "--all", "--model", model, test_dir, "--output", out_json, *extra])
        seconds = time.time() - t
        with open(out_json) as fh:
            report = json.load(fh)
        report["wall_seconds"] = seconds
        with open(out_json, "w") as fh:
            json.dump(report, fh)
    with open(out_json) as fh:
        report = json.load(fh)
    return report["mean"]["l2"], report["wall_seconds"]


def dis_l2(reference, target):
    ref = flow_dis.load_rgba(reference)
    tgt = flow_dis.load_rgba(target)
    d = flow_dis.dis(flow_dis.cv2.DISOPTICAL_FLOW_PRESET_MEDIUM, True)
    warped = flow_dis.warp(ref, flow_dis.flow(d, flow_dis.grey(tgt), flow_dis.grey(ref)))
    return flow_dis.l2(flow_dis.on_white(warped), flow_dis.on_white(tgt))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config")
    ap.add_argument("--cycle", required=True, help="regex a cycle frame's file name matches (e.g. walk)")
    ap.add_argument("--out", required=True, help="folder for the folds (created; reused to resume)")
    args = ap.parse_args()

    with open(args.config, "rb") as fh:
        base = tomllib.load(fh)
    puppet_dir = config_path(args.config, base["puppet"])
    frames_dir = config_path(args.config, base["frames"])
    cycle = sorted(f for f in os.listdir(frames_dir) if re.search(args.cycle, f) and f.endswith(".png"))
    if len(cycle) < 3:
        sys.exit(f"leave_one_out.py: {len(cycle)} frames in {frames_dir} match {args.cycle!r}; need 3 or more")
    reference = reference_frame(puppet_dir)
    os.makedirs(args.out, exist_ok=True)

    rows = []
    for left_out in cycle:
        fold = os.path.abspath(os.path.join(args.out, os.path.splitext(left_out)[0]))
        train_dir, test_dir, model = (os.path.join(fold, d) for d in ("frames", "test", "model"))
        for folder, names in ((train_dir, [f for f in cycle if f != left_out]), (test_dir, [left_out])):
            os.makedirs(folder, exist_ok=True)
            for name in names:
                shutil.copyfile(os.path.join(frames_dir, name), os.path.join(folder, name))
        config = dict(base)
        config.update(puppet=puppet_dir, frames=train_dir, output=model, test_fraction=0.0)
        config["train"] = dict(base["train"], batch=min(base["train"]["batch"], len(cycle) - 1))
        write_toml(os.path.join(fold, "train.toml"), config)
        if not os.path.exists(os.path.join(model, "weights.bpk")):
            resume = ["--resume"] if os.path.isdir(os.path.join(model, "checkpoints")) else []
            t = time.time()
            run([PUPPET, "train", "--quiet", *resume, os.path.join(fold, "train.toml")])
            print(f"trained {left_out} in {time.time() - t:.0f} s", flush=True)
        one_pass, _ = evaluate(model, test_dir, ["--one-pass"], os.path.join(fold, "one-pass.json"))
        default, seconds = evaluate(model, test_dir, [], os.path.join(fold, "default.json"))
        dis = dis_l2(reference, os.path.join(test_dir, left_out))
        rows.append(dict(frame=left_out, one_pass=one_pass, default=default, dis=dis, default_seconds=seconds))

    print(f"\n{'left out':<28} {'one-pass':>9} {'default':>9} {'DIS':>9} {'1p/DIS':>7} {'def/DIS':>7}")
    for r in rows:
        print(f"{r['frame']:<28} {r['one_pass']:>9.1f} {r['default']:>9.1f} {r['dis']:>9.1f} "
              f"{r['one_pass'] / r['dis']:>7.3f} {r['default'] / r['dis']:>7.3f}")
    mean = {k: sum(r[k] for r in rows) / len(rows) for k in ("one_pass", "default", "dis")}
    print(f"{'mean':<28} {mean['one_pass']:>9.1f} {mean['default']:>9.1f} {mean['dis']:>9.1f} "
          f"{mean['one_pass'] / mean['dis']:>7.3f} {mean['default'] / mean['dis']:>7.3f}")
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(dict(config=os.path.abspath(args.config), folds=rows, mean=mean), fh, indent=1)


if __name__ == "__main__":
    main()
