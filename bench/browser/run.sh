#!/usr/bin/env bash
# Opens puppet's sprite-sheet atlas (PixiJS) and its APNG/GIF animations (over a checkerboard) in
# Debian's headless Chromium, takes screenshots into bench/browser/screens/ and prints the checks.
#
#   bench/browser/run.sh [OUTPUT_DIR]
#
# Without OUTPUT_DIR it runs `cargo run --release -- demo` into a temporary folder first. Needs
# node + npm (the page's PixiJS and the Playwright driver come from npm, pinned by
# package-lock.json) and Debian's `chromium` (installed here with apt-get when running as root).
# Exits non-zero if a check fails.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)

if ! command -v chromium >/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium
  else
    echo "run.sh: needs Debian's chromium (apt-get install -y chromium)" >&2
    exit 2
  fi
fi
if [ ! -d "$here/node_modules/pixi.js" ] || [ ! -d "$here/node_modules/playwright-core" ]; then
  (cd "$here" && npm ci --no-audit --no-fund)
fi

if [ $# -ge 1 ]; then
  out=$(cd "$1" && pwd)
else
  out=${TMPDIR:-/tmp}/puppet-browser-demo
  (cd "$repo" && cargo run --release -- demo --quiet -o "$out")
fi

cd "$repo"
status=0
echo "== the demo: sprite sheet in PixiJS, APNG/GIF over a checkerboard (screenshots: bench/browser/screens/)"
node "$here/check.mjs" "$out" "$here/screens" || status=1

# A sheet of two pages: 302 in-betweens of the demo's model (96×128 frames: 256 a page).
if [ -d "$out/model" ]; then
  long=${TMPDIR:-/tmp}/puppet-browser-long
  frames="$repo/data/kenney/male_adventurer/frames"
  cargo run --release --quiet -- inbetween --quiet --force --model "$out/model" \
    "$frames/maleAdventurer_walk0.png" "$frames/maleAdventurer_walk4.png" \
    --steps 300 --latent-steps 0 --delay 40 -o "$long"
  echo "== a two-page sheet ($long/sprites.json + sprites_2.json), started at entry 250 (screenshots: $long/screens/)"
  ATLAS=sprites.json ANIMATIONS= START=250 node "$here/check.mjs" "$long" "$long/screens" || status=1
fi
exit $status
