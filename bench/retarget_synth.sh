#!/usr/bin/env bash
# Issue 57's retarget figure on generator characters (docs/results.md "Retargeting"): pairs of
# characters drawn by `puppet synth` with one motion seed walk alike, so B's own frames are the
# answer for A's motion played on B. For each pair A:B in PAIRS, both characters get a model
# (configs/synth-walk.toml on their 48 frames, STEPS steps), then A's true poses are
# played on B's model and B's on A's by examples/retarget_synth.rs, which prints the default
# (manifold), the rigid turns and the nearest training frame against the held-out true frames.
#
#   bash bench/retarget_synth.sh                         # PAIRS="3:5 11:13", STEPS=800
#   STEPS=1600 OUT=runs/retarget-synth-1600 bash bench/retarget_synth.sh
#   cat runs/retarget-synth/report-*.txt
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
EXAMPLE=${EXAMPLE:-target/release/examples/retarget_synth}
STEPS=${STEPS:-800}
PAIRS=${PAIRS:-"3:5 11:13"}
MOTION_SEED=${MOTION_SEED:-7}
OUT=${OUT:-runs/retarget-synth}

model() { # CHARACTER_SEED
    local d=$OUT/char-$1
    [ -f "$d/truth.json" ] || "$P" -q synth -o "$d" --seed "$1" --motion-seed "$MOTION_SEED" --frames 48 --size 128x128
    # configs/synth-walk.toml with this character's frames, its own output and STEPS steps
    sed -e "s|^puppet = .*|puppet = \"char-$1/template\"|" -e "s|^frames = .*|frames = \"char-$1\"|" \
        -e "s|^output = .*|output = \"model-$1\"|" -e "s|^steps = .*|steps = $STEPS|" configs/synth-walk.toml >"$d.toml"
    [ -f "$OUT/model-$1/done" ] || { "$P" -q train "$d.toml" --resume 2>/dev/null || "$P" -q train "$d.toml"; touch "$OUT/model-$1/done"; }
}

for pair in $PAIRS; do
    a=${pair%:*} b=${pair#*:}
    model "$a"
    model "$b"
    for way in "$a $b" "$b $a"; do
        set -- $way
        "$EXAMPLE" "$OUT/char-$1" "$OUT/char-$2" "$OUT/model-$2" | tee "$OUT/report-$1-on-$2.txt"
    done
done
