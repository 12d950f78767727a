#!/usr/bin/env bash
# Issue 16 on real drawn poses: each Kenney character's frames without the climb frames (back
# views) as the poses, parts found by `puppet parts` (the built-in correspondence network, or
# METHOD=dis: OpenCV DIS flow through bench/parts_flow.py), and the found label map of the idle
# pose scored against the character's hand-painted label map (data/kenney/*/labels.png, drawn on
# the idle frame; coarser than APES parts, so the merged score counts most).
#   bench/parts_kenney.sh [CHARACTER…]        default: robot male_adventurer female_adventurer
# NET=DIR uses a network trained by `puppet train-parts`; RIGID_CHECK=PX sets `--rigid-check`;
# OUT=DIR keeps the outputs there.
set -euo pipefail
puppet=${PUPPET:-target/release/puppet}
characters=("$@")
[ ${#characters[@]} -eq 0 ] && characters=(robot male_adventurer female_adventurer)
work=${OUT:-$(mktemp -d)}
for c in "${characters[@]}"; do
  d=$work/$c
  rm -rf "$d" && mkdir -p "$d/poses" "$d/truth" "$d/found"
  for f in data/kenney/$c/frames/*.png; do
    case $f in *climb*) ;; *) cp "$f" "$d/poses/" ;; esac
  done
  if [ "${METHOD:-net}" = dis ]; then
    python3 bench/parts_flow.py dis "$d/poses" "$d/flows"
    $puppet -q parts "$d/poses" --flows "$d/flows" ${RIGID_CHECK:+--rigid-check $RIGID_CHECK} -o "$d/parts"
  else
    $puppet -q parts "$d/poses" ${NET:+--net "$NET"} -o "$d/parts"
  fi
  # The idle pose's label map: pose_labels/ holds one per pose in the poses' order.
  idle=$(ls "$d/poses" | grep -n idle | cut -d: -f1)
  # eval-parts scores two or more poses: the idle pose twice scores as the idle pose once.
  for k in a b; do
    cp "$(ls "$d"/parts/pose_labels/*.png | sed -n "${idle}p")" "$d/found/idle_$k.png"
    cp "data/kenney/$c/labels.png" "$d/truth/idle_$k.png"
  done
  parts=$(grep -c '^\[\[layer\]\]' "$d/parts/character.toml")
  echo "$c: $parts parts; $($puppet -q eval-parts --truth "$d/truth" "$d/found" | grep '^part IoU')"
done
