#!/usr/bin/env bash
# Writes data/kenney/robot/robot.ora with real editors: GIMP assembles the robot's parts (cut
# from the idle frame by its label map, each running 2 px under the parts in front of it) as named layers and saves a .psd, and Krita exports that
# as OpenRaster. (GIMP 2.10 in Debian 12 has no OpenRaster exporter — it was a Python 2 plug-in —
# and Krita 5.1 cannot read GIMP 2.10's .xcf, hence the .psd in between.)
# Needs: apt-get install gimp krita xvfb xauth; python3 with Pillow.
set -euo pipefail
here="$(cd "$(dirname "$0")/../kenney/robot" && pwd)"
work="$(mktemp -d)"
python3 - "$here" "$work" <<'PY'
import sys, tomllib
from pathlib import Path
from PIL import Image
here, work = Path(sys.argv[1]), Path(sys.argv[2])
character = tomllib.loads((here / "character.toml").read_text())
image = Image.open(here / character["labels"]["image"]).convert("RGBA")
labels = Image.open(here / character["labels"]["map"]).convert("RGBA")
names = [layer["name"] for layer in character["layer"]]
colours = {tuple(int(l["color"][i:i + 2], 16) for i in (1, 3, 5)): k for k, l in enumerate(character["layer"])}
label = {(x, y): colours.get(labels.getpixel((x, y))[:3]) if labels.getpixel((x, y))[3] else None
         for y in range(image.height) for x in range(image.width)}
order = []
for k, name in enumerate(names):
    # As an artist draws layers: each part runs 2 px on under the parts in front of it.
    own = {q: image.getpixel(q) for q, l in label.items() if l == k}
    for _ in range(2):
        grown = {}
        for (x, y), c in own.items():
            for q in ((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)):
                if q not in own and q not in grown and label.get(q) is not None and label[q] > k:
                    grown[q] = c[:3] + (255,)
        own.update(grown)
    part = Image.new("RGBA", image.size, (0, 0, 0, 0))
    for q, c in own.items():
        part.putpixel(q, c)
    part.save(work / f"{name}.png")
    order.append(name)
(work / "order.txt").write_text(" ".join(order))
PY
# Script-Fu: one layer per part, inserted in back → front order (each new layer goes on top).
loads=""
for name in $(cat "$work/order.txt"); do
  loads+="(let ((layer (car (gimp-file-load-layer RUN-NONINTERACTIVE image \"$work/$name.png\")))) (gimp-item-set-name layer \"$name\") (gimp-image-insert-layer image layer 0 0))"
done
gimp -i -b "(let* ((image (car (gimp-image-new 96 128 RGB)))) $loads (file-psd-save RUN-NONINTERACTIVE image (car (gimp-image-get-active-drawable image)) \"$work/robot.psd\" \"$work/robot.psd\" 0 0) (gimp-quit 0))"
xvfb-run -a -s "-screen 0 640x480x24" krita "$work/robot.psd" --export --export-filename "$here/robot.ora"
unzip -l "$here/robot.ora"
unzip -p "$here/robot.ora" stack.xml
rm -rf "$work"
