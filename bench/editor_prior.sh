#!/usr/bin/env bash
# The prior in the editor (docs/results.md "The prior in the editor"): per Kenney character,
# `puppet serve` on its trained model (configs/kenney-*.toml), each held-out frame (walk0, walk4,
# fall) uploaded as a page uploads a drawing, and a session opened on it; the session's answer
# says which start was kept and both starts' L2 (the network's latent fit, the prior's fit
# pulled onto the manifold). Then the same with `serve --no-prior`. Each session's starting pose
# is downloaded as OUT/<character>/<frame>.<prior|no-prior>.png. Models from
# bench/guide_kenney.sh (its scratch-1700 runs) or MODELS=dir holding <character>/scratch-1700.
#
#   bash bench/editor_prior.sh            # a few minutes once the models exist
set -euo pipefail
cd "$(dirname "$0")/.."
P=${PUPPET:-target/release/puppet}
MODELS=${MODELS:-runs/guide-kenney}
OUT=${OUT:-runs/editor-prior}
PORT=${PORT:-8391}
CHARACTERS=${CHARACTERS:-"robot male_adventurer female_adventurer"}
URL=http://127.0.0.1:$PORT

post() { curl -s -X POST -H 'content-type: application/json' -d "$2" "$URL$1"; }

for c in $CHARACTERS; do
    mkdir -p "$OUT/$c"
    for mode in prior no-prior; do
        flag=$([ $mode = no-prior ] && echo --no-prior || true)
        "$P" -q serve --model "$MODELS/$c/scratch-1700" --port "$PORT" $flag &
        server=$!
        trap 'kill $server 2>/dev/null' EXIT
        until curl -s "$URL/api/frames" >/dev/null; do sleep 0.5; done
        for f in data/kenney/$c/frames/*_{walk0,walk4,fall}.png; do
            name=$(basename "$f" .png)
            index=$(curl -s -X POST --data-binary @"$f" -H 'content-type: image/png' "$URL/api/upload?name=$name.png" |
                python3 -c 'import json,sys; print(json.load(sys.stdin)["index"])')
            start=$(date +%s.%N)
            answer=$(post /api/session "{\"frame\": $index}")
            seconds=$(echo "$(date +%s.%N) - $start" | bc)
            session=$(echo "$answer" | python3 -c 'import json,sys; print(json.load(sys.stdin)["session"])')
            echo "$c $name $mode $(echo "$answer" | python3 -c 'import json,sys; print(json.dumps(json.load(sys.stdin).get("start")))') ${seconds}s"
            post /api/export "{\"format\": \"png\", \"session\": \"$session\"}" >"$OUT/$c/$name.$mode.png"
        done
        kill $server
        wait $server 2>/dev/null || true
    done
done

# One picture: per character a row, per frame the drawing, the start without the prior, the
# start with it.
python3 - "$OUT" $CHARACTERS <<'PY'
import pathlib, sys
import cv2
import numpy as np
out, characters = pathlib.Path(sys.argv[1]), sys.argv[2:]
def flat(path):
    im = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    a = im[..., 3:4].astype(float) / 255
    return (im[..., :3] * a + 255 * (1 - a)).astype(np.uint8)
rows = []
for c in characters:
    frames = pathlib.Path("data/kenney", c, "frames")
    cells = []
    for shot in ("walk0", "walk4", "fall"):
        drawing = next(frames.glob(f"*_{shot}.png"))
        cells += [flat(drawing)] + [flat(out / c / f"{drawing.stem}.{m}.png") for m in ("no-prior", "prior")]
        cells.append(np.full((cells[0].shape[0], 8, 3), 128, np.uint8))
    rows.append(np.hstack(cells))
cv2.imwrite(str(out / "sheet.png"), np.vstack(rows))
PY
echo "$OUT/sheet.png"
