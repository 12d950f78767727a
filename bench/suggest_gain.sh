#!/usr/bin/env bash
# Issue 57's suggest figure (docs/results.md "Suggest"): which tenth drawing teaches a model most?
#
# For each generator character (seeds CHARS) and training seed (SEEDS):
#   train/  TRAIN (9) drawn frames, independent random poses (APES §5.1 ranges);
#   pool/   32 more such frames: the drawings the artist could add, with their true poses;
#   test/   16 more: the fixed held-out motion.
# A base model trains on those frames (BASE_STEPS). One pool frame is added, chosen by each of
# `puppet suggest --by misread / coverage / typical / distance` (the last farthest pose first) and
# at random; `puppet train --from base` continues on the
# TRAIN + 1 frames for MORE_STEPS, and a control continues on the TRAIN alone for the same steps. Each model's test fit (default and one-pass) is
# scored by `puppet eval`; a selector's gain is the control's error less its own.
# bench/suggest_gain.py turns the reports into the table.
#
#   bash bench/suggest_gain.sh            # about 45 min on the 2-core machine, idle
#   TRAIN=5 OUT=runs/suggest-gain-5 bash bench/suggest_gain.sh   # one frame added to five
#   AGAIN_SEEDS="2 3 4 5" … bash bench/suggest_gain.sh    # each continuation with these seeds too, a run's own skipped (~3 h, ~12 GB)
#   VARIANTS="none typical distance random" … bash bench/suggest_gain.sh   # only these continuations
#   python3 bench/suggest_gain.py runs/suggest-gain
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
OUT=${OUT:-runs/suggest-gain}
BASE_STEPS=${BASE_STEPS:-1200}
MORE_STEPS=${MORE_STEPS:-400}
CHARS=${CHARS:-"31 32 33 34 35"}
SEEDS=${SEEDS:-"1 2"}
TRAIN=${TRAIN:-9}
AGAIN_SEEDS=${AGAIN_SEEDS:-}
CRITERIA=${CRITERIA:-"misread coverage typical distance"}   # suggest --by …: each one's pick is recorded
VARIANTS=${VARIANTS:-"none misread coverage typical distance random"}   # the continuations made
POOL=32
source bench/continue.sh

synth() { # OUT SEED MOTION_SEED FRAMES
    [ -f "$1/truth.json" ] || "$P" -q synth -o "$1" --seed "$2" --motion-seed "$3" --motion random --frames "$4" --size 128x128
}

for c in $CHARS; do
    d=$OUT/char-$c
    synth "$d/train" "$c" $((c * 10 + 1)) "$TRAIN"
    synth "$d/pool" "$c" $((c * 10 + 2)) $POOL
    synth "$d/test" "$c" $((c * 10 + 3)) 16
    for s in $SEEDS; do
        r=$d/seed-$s
        mkdir -p "$r"
        cat >"$r/base.toml" <<EOF
puppet = "../train/template"
frames = "../train/frames"
output = "base"
seed = $s
test_fraction = 0.0

[model]
input_size = 64

[train]
steps = $BASE_STEPS
batch = $TRAIN
learning_rate = 1e-4
learning_rate_end = 1e-5
sigma = [4.0, 0.5]
checkpoint_every = 100

[loss]
arap = 2500.0
joints = 1e4
EOF
        [ -f "$r/base/weights.bpk" ] && [ -f "$r/base/done" ] || { "$P" -q train "$r/base.toml" --resume 2>/dev/null || "$P" -q train "$r/base.toml"; touch "$r/base/done"; }
        declare -A chosen=([random]=$(python3 -c "import random; print(random.Random($c * 100 + $s).randrange($POOL))"))
        for by in $CRITERIA; do
            "$P" -q suggest --model "$r/base" -n 1 --pool "$d/pool" --by "$by" -o "$r/pick-$by"
            chosen[$by]=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['suggestions'][0]['origin']['index'])" "$r/pick-$by/suggestions.json")
        done
        for variant in $VARIANTS; do
            v=$r/$variant
            if [ "$variant" != none ]; then
                k=${chosen[$variant]}
                # A continuation is made once: a criterion that picks otherwise now (another
                # build) must not leave an older continuation filed under the new pick.
                if [ -f "$v-frames.index" ] && [ "$(cat "$v-frames.index")" != "$k" ]; then
                    echo "$v: $variant now picks pool frame $k, the continuation there was made with $(cat "$v-frames.index"); remove $v* to redo it" >&2
                    exit 1
                fi
            fi
            mkdir -p "$v-frames"
            cp "$d"/train/frames/*.png "$v-frames/"
            if [ "$variant" != none ]; then
                src=$(ls "$d"/pool/frames/*.png | sort -V | sed -n "$((k + 1))p")
                cp "$src" "$v-frames/added.png"
                echo "$k" >"$v-frames.index"
            fi
            continue_and_score "$r" "$v" "$v-frames"
        done
        # The same continuations with other training seeds: one run's gain is mostly the seed's luck
        # (docs/results.md "Suggest"), and bench/suggest_gain.py averages over the seeds.
        for again in $AGAIN_SEEDS; do
            # The run's own continuations train with its seed ($s): that seed again would repeat them.
            [ "$again" != "$s" ] || { echo "$r: training seed $again is the run's own, skipped" >&2; continue; }
            mkdir -p "$r/again-seed-$again"
            sed "s/^seed = .*/seed = $again/" "$r/none/train.toml" >"$r/again-seed-$again/train.toml"
            for variant in $VARIANTS; do
                continue_and_score "$r" "$r/again-seed-$again/$variant" "$r/$variant-frames" "$r/again-seed-$again/train.toml"
            done
        done
    done
done
echo "reports in $OUT; python3 bench/suggest_gain.py $OUT"
