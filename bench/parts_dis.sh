#!/usr/bin/env bash
# The classical baseline of issue 16 beside the oracle, on held-out synthetic sprite sheets:
# for each seed, a sheet of 6–10 poses (as `puppet eval-parts --synthetic` draws them), DIS
# optical flow between every pair (bench/parts_flow.py), the same part finder on it
# (`puppet parts --flows --keep-all`: every pose kept, as eval-parts keeps them), scored by
# `puppet eval-parts` against the true label maps.
#   bench/parts_dis.sh FIRST END [SIZE]      e.g. bench/parts_dis.sh 9000 9024 128
# FLOW_CHECK=PX, SUPERPIXELS=N, RIGID_CHECK=PX, SELECT=synchronised|cover and COVER_SCORE=rigid|arap
# set `puppet parts --flow-check`, `--superpixels`, `--rigid-check`, `--select` and `--cover-score`.
set -euo pipefail
first=$1 end=$2 size=${3:-128}
puppet=${PUPPET:-target/release/puppet}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for ((seed = first; seed < end; seed++)); do
  poses=$((6 + seed % 5))
  d=$work/$seed
  $puppet -q synth --sprite-sheet --frames $poses --size ${size}x$size --seed $seed -o $d/sheet
  python3 bench/parts_flow.py cells $d/sheet $d
  python3 bench/parts_flow.py dis $d/poses $d/flows
  $puppet -q parts $d/poses --flows $d/flows --keep-all --flow-check ${FLOW_CHECK:-2} --superpixels ${SUPERPIXELS:-100} ${RIGID_CHECK:+--rigid-check $RIGID_CHECK} \
    --select ${SELECT:-synchronised} --cover-score ${COVER_SCORE:-rigid} -o $d/parts
  line=$($puppet -q eval-parts --truth $d/labels $d/parts/pose_labels | grep '^part IoU')
  echo "$seed $poses $line"
done
