#!/usr/bin/env bash
# Regenerates the pictures of README.md and docs/ into docs/img/.
#
#   cargo build --release && docs/pictures.sh
#
# Run from the repository root. The puppet binary is ${PUPPET:-target/release/puppet}. Everything
# is made in a temporary folder (removed at the end) and only the chosen files are copied into
# docs/img/. It runs the demo twice (the male adventurer and the robot, short runs of 300 steps),
# so it takes several minutes on two cores.
#
# The editor's screenshots (docs/img/editor.png, editor_suggest.png) also need node, Debian's
# chromium and the npm packages of bench/browser/ (`cd bench/browser && npm ci`). Without them
# the script says so and leaves the existing screenshots as they are.
set -euo pipefail

PUPPET=${PUPPET:-target/release/puppet}
PORT=${PORT:-8765}
if [ ! -f Cargo.toml ] || [ ! -d docs ]; then
  echo "pictures.sh: run me from the repository root" >&2
  exit 2
fi
if [ ! -x "$PUPPET" ]; then
  echo "pictures.sh: no puppet binary at $PUPPET (cargo build --release, or set PUPPET)" >&2
  exit 2
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/puppet-pictures.XXXXXX")
server=""
cleanup() {
  if [ -n "$server" ]; then kill "$server" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT

img=docs/img
mkdir -p "$img"
F=data/kenney/robot/frames

echo "== the demo on the male adventurer (in-between GIF, re-dressed walk)"
"$PUPPET" -q demo -o "$tmp/demo"
cp "$tmp/demo/inbetween_walk.gif" "$img/inbetween.gif"
cp "$tmp/demo/inbetween_walk_dressed.gif" "$img/dressed.gif"

echo "== what to draw next, for the demo's model"
"$PUPPET" -q suggest --model "$tmp/demo/model" -o "$tmp/next"
cp "$tmp/next/sheet.png" "$img/suggest.png"

echo "== step 2: the robot's puppet built from its PSD, and the adventurer's rig"
"$PUPPET" -q build data/psd/robot_krita.psd -o "$tmp/robot-puppet"
cp "$tmp/robot-puppet/preview.png" "$img/build_preview.png"
"$PUPPET" -q rig data/kenney/male_adventurer -o "$tmp/rig.png"
cp "$tmp/rig.png" "$img/rig.png"

echo "== step 3: a short training run on the robot (the demo's)"
"$PUPPET" -q demo --character data/kenney/robot -o "$tmp/robot"
cp "$tmp/robot/model/loss.png" "$img/loss.png"

echo "== step 4: fits, an in-between and a drag with the robot's model"
"$PUPPET" -q fit --model "$tmp/robot/model" "$F" -o "$tmp/fit"
cp "$tmp/fit/sheet.png" "$img/fit_sheet.png"
"$PUPPET" -q inbetween --model "$tmp/robot/model" "$F/robot_walk0.png" "$F/robot_walk4.png" \
  --steps 8 -o "$tmp/walk"
cp "$tmp/walk/sheet.png" "$img/inbetween_sheet.png"
"$PUPPET" -q pose --model "$tmp/robot/model" "$F/robot_idle.png" --pin 70,75:80,55 -o "$tmp/drag/drag.png"
cp "$tmp/drag/drag_sheet.png" "$img/drag_sheet.png"

echo "== parts found from a generated sprite sheet"
"$PUPPET" -q synth --sprite-sheet --frames 8 --size 128x128 --seed 7 -o "$tmp/sheet"
"$PUPPET" -q parts "$tmp/sheet/sheet.png" -o "$tmp/parts"
cp "$tmp/parts/parts.png" "$img/parts.png"

echo "== a character nobody trained, fitted from the prior"
mkdir -p "$tmp/unseen"
for f in walk0 walk4 fall; do cp "data/kenney/male_adventurer/frames/maleAdventurer_$f.png" "$tmp/unseen/"; done
"$PUPPET" -q fit --puppet data/kenney/male_adventurer "$tmp/unseen" -o "$tmp/zero-shot"
cp "$tmp/zero-shot/sheet.png" "$img/zero_shot.png"

echo "== the web editor on the demo's model"
tour=bench/browser/editor_tour.mjs
if command -v node >/dev/null && command -v chromium >/dev/null && [ -d bench/browser/node_modules/playwright-core ]; then
  "$PUPPET" -q serve --model "$tmp/demo/model" --port "$PORT" >"$tmp/serve.log" 2>&1 &
  server=$!
  for _ in $(seq 1 240); do
    if (exec 3<>"/dev/tcp/127.0.0.1/$PORT") 2>/dev/null; then break; fi
    if ! kill -0 "$server" 2>/dev/null; then
      echo "pictures.sh: puppet serve stopped:" >&2
      cat "$tmp/serve.log" >&2
      exit 1
    fi
    sleep 0.5
  done
  node "$tour" "http://127.0.0.1:$PORT/" "$tmp/screens"
  cp "$tmp/screens/editor_dragged.png" "$img/editor.png"
  cp "$tmp/screens/editor_suggest.png" "$img/editor_suggest.png"
  kill "$server" 2>/dev/null || true
  wait "$server" 2>/dev/null || true
  server=""
else
  echo "pictures.sh: node, chromium or bench/browser/node_modules missing: $img/editor*.png left as they are" >&2
fi

echo "== written:"
ls -l "$img"
