# Sourced by bench/suggest_gain.sh and bench/suggest_oracle.sh (P, MORE_STEPS set by them).
#
# continue_and_score RUN OUT FRAMES [CONFIG]: continues RUN's base model on the frames in FRAMES
# for MORE_STEPS steps into OUT (`puppet train --from`, with CONFIG's settings if given; resumed
# if a run was killed), then scores the run's test motion with `puppet eval`: default fit into
# OUT/eval.json and, unless ONE_PASS=0, one pass into OUT/eval-one-pass.json. A finished
# continuation's checkpoints go (~185 MB each: weights and Adam's two moments; only a killed run
# needs them), its weights stay.
continue_and_score() {
    local r=$1 v=$2 frames=$3 config=${4:-} test
    test=$(dirname "$r")/test
    [ -f "$v/done" ] || { "$P" -q train $config --from "$r/base" --frames "$frames" -o "$v" --steps "$MORE_STEPS" --resume 2>/dev/null ||
        "$P" -q train $config --from "$r/base" --frames "$frames" -o "$v" --steps "$MORE_STEPS"; touch "$v/done"; rm -rf "$v/checkpoints"; }
    [ -f "$v/eval.json" ] || "$P" -q eval --model "$v" "$test" --all -o "$v/eval.json" >/dev/null
    [ "${ONE_PASS:-1}" = 0 ] || [ -f "$v/eval-one-pass.json" ] ||
        "$P" -q eval --model "$v" "$test" --all --one-pass -o "$v/eval-one-pass.json" >/dev/null
}
