#!/usr/bin/env bash
# What every pool frame would have taught (docs/results.md "Suggest"): for runs of
# bench/suggest_gain.sh, continue the base model with each of the 32 pool frames in turn (as the
# selectors' picks were continued) and score the test motion's default fit, so that each
# criterion's ranking of the pool can be set against the gain each frame actually gives.
# Frames a selector already picked reuse that selector's continuation.
#
# FRAMES limits the pool frames continued to those listed (default: all 32).
#
# How much of a frame's gain is the frame and how much the training's seed: for the control and
# each pool frame in AGAIN, the continuation runs again with each seed in AGAIN_SEEDS (the base
# model stays the one of seed 1), in again-seed-S/.
#
#   RUNS="runs/suggest-gain-5/char-31/seed-1" bash bench/suggest_oracle.sh
#   RUNS=… AGAIN="27 15 17" AGAIN_SEEDS="2 3" bash bench/suggest_oracle.sh
#   python3 bench/suggest_oracle.py runs/suggest-gain-5/char-31/seed-1
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
MORE_STEPS=${MORE_STEPS:-400}
POOL=32
AGAIN=${AGAIN:-}
AGAIN_SEEDS=${AGAIN_SEEDS:-}
FRAMES=${FRAMES:-$(seq 0 $((POOL - 1)))}

source bench/continue.sh

continue_with() { # RUN DIR ADDED_POOL_INDEX_OR_none [CONFIG]
    local r=$1 v=$2 k=$3 d
    d=$(dirname "$r")
    [ -f "$v/eval.json" ] && return
    mkdir -p "$v-frames"
    cp "$d"/train/frames/*.png "$v-frames/"
    [ "$k" = none ] || cp "$(ls "$d"/pool/frames/*.png | sort -V | sed -n "$((k + 1))p")" "$v-frames/added.png"
    ONE_PASS=0 continue_and_score "$r" "$v" "$v-frames" "${4:-}"
    rm -rf "$v-frames"
}

for r in $RUNS; do
    d=$(dirname "$r")
    for criterion in misread coverage distance; do
        [ -f "$r/rank-$criterion/suggestions.json" ] ||
            "$P" -q suggest --model "$r/base" -n $POOL --separation 0 --pool "$d/pool" --by $criterion -o "$r/rank-$criterion" >/dev/null
    done
    for k in $FRAMES; do
        v=$r/pool-$k
        [ -f "$v/eval.json" ] && continue
        for picked in "$r"/*-frames.index; do
            if [ "$(cat "$picked")" = "$k" ]; then
                mkdir -p "$v" && cp "${picked%-frames.index}/eval.json" "$v/eval.json"
                continue 2
            fi
        done
        continue_with "$r" "$v" "$k"
    done
    for s in $AGAIN_SEEDS; do
        mkdir -p "$r/again-seed-$s"
        sed "s/^seed = .*/seed = $s/" "$r/none/train.toml" >"$r/again-seed-$s/train.toml"
        for k in none $AGAIN; do
            continue_with "$r" "$r/again-seed-$s/$k" "$k" "$r/again-seed-$s/train.toml"
        done
    done
done
