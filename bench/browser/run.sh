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
node "$here/check.mjs" "$out" "$here/screens"
