#!/usr/bin/env bash
# Issue 57's suggest figure on drawn art (docs/results.md "Suggest"): which of the drawn frames
# a model did not train on would `puppet suggest` add, and how does that frame's gain rank among
# all of them?
#
# Per Kenney character: held out, as in every Kenney figure, walk0, walk4 and fall. Of the nine
# training frames of configs/kenney-*.toml, four form the pool (climb1, jump, walk2, walk6: a
# back view, the one airborne pose, two more walk phases); a base model trains on the other five
# (idle, walk1, walk3, walk5, walk7) with the Kenney settings. `puppet fit` gives each pool
# frame's pose, `puppet suggest --pool` ranks them (and `--by coverage`, `--by distance`). Then each pool frame in
# turn, and none (the control), is added and `puppet train --from base` continues for
# MORE_STEPS; `puppet eval` scores the held-out frames (default fit). A frame's gain is the
# control's L2 less its own.
#
#   bash bench/suggest_kenney.sh          # about 30 min on the 2-core machine, idle
#   python3 bench/suggest_kenney.py runs/suggest-kenney
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
OUT=${OUT:-runs/suggest-kenney}
BASE_STEPS=${BASE_STEPS:-1700}
MORE_STEPS=${MORE_STEPS:-400}
CHARACTERS=${CHARACTERS:-"robot male_adventurer female_adventurer"}
POOL="climb1 jump walk2 walk6"
BASE="idle walk1 walk3 walk5 walk7"
TEST="walk0 walk4 fall"

for c in $CHARACTERS; do
    d=$OUT/$c
    art=data/kenney/$c
    prefix=$(ls "$art/frames" | head -1 | sed 's/_.*//') # robot, maleAdventurer, …
    mkdir -p "$d/base-frames" "$d/pool-frames" "$d/test"
    for f in $BASE; do cp "$art/frames/${prefix}_$f.png" "$d/base-frames/"; done
    for f in $POOL; do cp "$art/frames/${prefix}_$f.png" "$d/pool-frames/"; done
    for f in $TEST; do cp "$art/frames/${prefix}_$f.png" "$d/test/"; done
    sed -e "s|^puppet = .*|puppet = \"$PWD/$art\"|" -e "s|^frames = .*|frames = \"base-frames\"|" \
        -e "s|^output = .*|output = \"base\"|" -e "s|^test_fraction = .*|test_fraction = 0.0|" \
        -e "s|^steps = .*|steps = $BASE_STEPS|" -e "s|^batch = .*|batch = 5|" "configs/kenney-$c.toml" >"$d/base.toml"
    [ -f "$d/base/done" ] || { "$P" -q train "$d/base.toml" --resume 2>/dev/null || "$P" -q train "$d/base.toml"; touch "$d/base/done"; }
    [ -d "$d/pool-fits" ] || "$P" -q fit --model "$d/base" "$d/pool-frames" -o "$d/pool-fits" >/dev/null
    mkdir -p "$d/pool-poses"
    for f in $POOL; do cp "$d/pool-fits/${prefix}_${f}_vertices.json" "$d/pool-poses/"; done
    "$P" -q suggest --model "$d/base" --pool "$d/pool-poses" -n 4 -o "$d/pick-misread" --separation 0
    "$P" -q suggest --model "$d/base" --pool "$d/pool-poses" -n 4 -o "$d/pick-distance" --separation 0 --by distance
    "$P" -q suggest --model "$d/base" --pool "$d/pool-poses" -n 4 -o "$d/pick-coverage" --separation 0 --by coverage
    for added in none $POOL; do
        v=$d/add-$added
        mkdir -p "$v-frames"
        cp "$d"/base-frames/*.png "$v-frames/"
        [ "$added" = none ] || cp "$art/frames/${prefix}_$added.png" "$v-frames/"
        [ -f "$v/done" ] || { "$P" -q train --from "$d/base" --frames "$v-frames" -o "$v" --steps "$MORE_STEPS" --resume 2>/dev/null ||
            "$P" -q train --from "$d/base" --frames "$v-frames" -o "$v" --steps "$MORE_STEPS"; touch "$v/done"; }
        [ -f "$v/eval.json" ] || "$P" -q eval --model "$v" "$d/test" --all -o "$v/eval.json" >/dev/null
    done
done
echo "reports in $OUT; python3 bench/suggest_kenney.py $OUT"
