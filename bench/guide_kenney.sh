#!/usr/bin/env bash
# Issue 56's "trained from the prior" figure (docs/results.md "Training from the prior"): per
# Kenney character, the Kenney config (configs/kenney-*.toml: 1700 steps, the split holding out
# climb0, fall, walk0 and walk4) trained from scratch and with `--prior` (the training frames'
# poses pulled toward the built-in prior's fits for the first fifth of the run), each for the
# full steps and for a third of them; then `puppet eval` on the held-out frames, default fit and
# one pass, beside DIS flow warping the idle frame (bench/flow_dis.py); the table scores walk0,
# walk4 and fall. The built-in prior never trained on a Kenney character (configs/prior.toml).
#
#   bash bench/guide_kenney.sh            # about 40 min on the 2-core machine, idle
#   python3 bench/guide_kenney.py runs/guide-kenney
#
# PRIOR_NET=DIR guides with that prior instead (`train --prior-net`); a `%c` in it stands for the
# character (PRIOR_NET=runs/prior-without-%c: the leave-one-out priors). RUNS="prior-1700 …"
# trains only those runs. SEEDS="1 2 3" trains each run with each training seed (seed 1 is the
# config's; seed N writes RUN-sN from a copy of the config with `seed = N` and `split_seed = 1`,
# so every seed holds out the same frames).
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
OUT=${OUT:-runs/guide-kenney}
CHARACTERS=${CHARACTERS:-"robot male_adventurer female_adventurer"}
FULL=${FULL:-1700}
THIRD=$((FULL / 3))

for c in $CHARACTERS; do
    mkdir -p "$OUT/$c"
    prefix=$(ls "data/kenney/$c/frames" | head -1 | sed 's/_.*//') # robot, maleAdventurer, …
    [ -f "$OUT/$c/dis.txt" ] || python3 bench/flow_dis.py warp --reference "data/kenney/$c/frames/${prefix}_idle.png" \
        "data/kenney/$c/frames/${prefix}_"{walk0,walk4,fall}.png >"$OUT/$c/dis.txt"
    for seed in ${SEEDS:-1}; do
        for run in ${RUNS:-scratch-$FULL prior-$FULL scratch-$THIRD prior-$THIRD}; do
            config=configs/kenney-$c.toml
            m=$OUT/$c/$run
            if [ "$seed" != 1 ]; then
                config=$OUT/$c/kenney-$c-s$seed.toml
                m=$OUT/$c/$run-s$seed
                # The config's paths are relative to its folder: made absolute for the copy, which
                # is made again each time so that it follows the config.
                sed -e "s|\"\.\./|\"$PWD/|" -e "s/^seed = .*/seed = $seed\nsplit_seed = 1/" \
                    "configs/kenney-$c.toml" >"$config"
            fi
            steps=${run#*-}
            flag=$([ "${run%-*}" = prior ] && echo "--prior ${PRIOR_NET:+--prior-net ${PRIOR_NET//%c/$c}}" || true)
            if [ ! -f "$m/done" ]; then
                "$P" -q train "$config" $flag --steps "$steps" -o "$m" --resume 2>/dev/null ||
                    "$P" -q train "$config" $flag --steps "$steps" -o "$m"
                touch "$m/done"
            fi
            [ -f "$m/default.json" ] || "$P" -q eval --model "$m" "data/kenney/$c/frames" -o "$m/default.json" >/dev/null
            [ -f "$m/one-pass.json" ] || "$P" -q eval --model "$m" "data/kenney/$c/frames" --one-pass -o "$m/one-pass.json" >/dev/null
        done
    done
done
