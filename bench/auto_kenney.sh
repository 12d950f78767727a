#!/usr/bin/env bash
# Issue 56's `puppet auto` figure (docs/results.md "Back views set aside"): per Kenney character,
# `puppet auto` on all thirteen frames (1700 steps), then its artwork — the parts it found —
# trained with the hand-labelled puppet's own config (configs/kenney-*.toml: the same split,
# working size and settings), so the two puppets differ only in their parts; `puppet eval` of
# both on the held-out frames (default fit).
#
#   bash bench/auto_kenney.sh             # about 45 min on the 2-core machine, idle
#   python3 bench/auto_kenney.py runs/auto-kenney
#
# NET=DIR gives `puppet auto` that correspondence network instead of the built-in prior; a `%c`
# in it stands for the character (NET=runs/prior-without-%c: the leave-one-out priors of
# configs/prior-without-*.toml).
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
OUT=${OUT:-runs/auto-kenney}
CHARACTERS=${CHARACTERS:-"robot male_adventurer female_adventurer"}

for c in $CHARACTERS; do
    mkdir -p "$OUT/$c"
    net=${NET:+--net ${NET//%c/$c}}
    [ -f "$OUT/$c/auto/index.html" ] ||
        "$P" -q auto "data/kenney/$c/frames" $net -o "$OUT/$c/auto" --steps 1700 2>"$OUT/$c/auto.log"
    for run in hand auto-parts; do
        m=$OUT/$c/$run
        artwork=$([ "$run" = auto-parts ] && echo "--artwork $OUT/$c/auto/artwork" || true)
        if [ ! -f "$m/done" ]; then
            "$P" -q train "configs/kenney-$c.toml" $artwork -o "$m" --resume 2>/dev/null ||
                "$P" -q train "configs/kenney-$c.toml" $artwork -o "$m"
            touch "$m/done"
        fi
        [ -f "$m/default.json" ] || "$P" -q eval --model "$m" "data/kenney/$c/frames" -o "$m/default.json" >/dev/null
    done
    [ -f "$OUT/$c/auto/default.json" ] ||
        "$P" -q eval --model "$OUT/$c/auto/model" "data/kenney/$c/frames" -o "$OUT/$c/auto/default.json" >/dev/null
done
