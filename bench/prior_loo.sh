#!/usr/bin/env bash
# Issue 56's leave-one-out priors on the Kenney characters (docs/results.md "Leaving one Kenney
# character out"): per character, the prior taught the other two (configs/prior-without-*.toml)
# against the shipped prior (data/prior/, no Kenney character) on what the character's figures
# measure: correspondences on its posed template (PCK), the zero-shot fit of its held-out frames
# (walk0, walk4, fall) and the parts found on its sprite sheet (bench/parts_kenney.sh); DIS flow
# and the parts network (data/parts-net/) beside them. The zero-shot fits' DIS figure is
# bench/guide_kenney.sh's (flow warping the idle frame).
#
#   for c in robot male_adventurer female_adventurer; do
#       puppet prior train configs/prior-without-$c.toml; done      # 6–9 min each
#   bash bench/prior_loo.sh [CHARACTER…]                           # runs/prior-loo; ~2 min
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -gt 0 ] || set -- robot male_adventurer female_adventurer
P=${PUPPET:-target/release/puppet} OUT=${OUT:-runs/prior-loo}

for c in "$@"; do
    d=$OUT/$c
    mkdir -p "$d/held-out"
    prefix=$(basename "$(ls data/kenney/$c/frames/*_idle.png)" _idle.png)
    cp "data/kenney/$c/frames/${prefix}_"{walk0,walk4,fall}.png "$d/held-out/"
    "$P" -q prior data "data/kenney/$c" -o "$d/posed" --poses 16 --seed 1
    echo "== $c, DIS flow"
    python3 bench/flow_dis.py posed "$d/posed/$c" | tee "$d/pck-dis.txt"
    echo "== $c, parts: DIS flow, then the parts network"
    OUT=$d/parts-dis METHOD=dis PUPPET=$P bash bench/parts_kenney.sh "$c" | tee "$d/parts-dis.txt"
    OUT=$d/parts-network PUPPET=$P bash bench/parts_kenney.sh "$c" | tee "$d/parts-network.txt"
    for net in shipped:data/prior without:runs/prior-without-$c; do
        name=${net%%:*} dir=${net#*:}
        echo "== $c, $name prior ($dir)"
        "$P" prior eval "$d/posed/$c" --net "$dir" | tee "$d/pck-$name.txt"
        "$P" -q eval --puppet "data/kenney/$c" "$d/held-out" --prior-net "$dir" -o "$d/zero-shot-$name.json" |
            grep -i "mean" || true
        OUT=$d/parts-$name NET=$dir PUPPET=$P bash bench/parts_kenney.sh "$c" | tee "$d/parts-$name.txt"
    done
done
