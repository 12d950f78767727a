#!/usr/bin/env bash
# Writes data/kenney/robot/robot.ora with real editors: GIMP assembles the robot's parts (cut
# from the idle frame by its label map) as named layers in an .xcf, and Krita exports that as
# OpenRaster (GIMP 2.10 in Debian has no OpenRaster exporter: it was a Python 2 plug-in).
# Needs: apt-get install gimp krita; python3 with Pillow.
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
order = []
for layer in character["layer"]:
    rgb = tuple(int(layer["color"][i:i + 2], 16) for i in (1, 3, 5))
    part = Image.new("RGBA", image.size, (0, 0, 0, 0))
    for y in range(image.height):
        for x in range(image.width):
            if labels.getpixel((x, y)) == rgb + (255,):
                part.putpixel((x, y), image.getpixel((x, y)))
    part.save(work / f"{layer['name']}.png")
    order.append(layer["name"])
(work / "order.txt").write_text(" ".join(order))
PY
# Script-Fu: one layer per part, inserted in back → front order (each new layer goes on top).
loads=""
for name in $(cat "$work/order.txt"); do
  loads+="(let ((layer (car (gimp-file-load-layer RUN-NONINTERACTIVE image \"$work/$name.png\")))) (gimp-item-set-name layer \"$name\") (gimp-image-insert-layer image layer 0 0))"
done
gimp -i -b "(let* ((image (car (gimp-image-new 96 128 RGB)))) $loads (gimp-xcf-save RUN-NONINTERACTIVE image (car (gimp-image-get-active-drawable image)) \"$work/robot.xcf\" \"$work/robot.xcf\") (gimp-quit 0))"
QT_QPA_PLATFORM=offscreen krita "$work/robot.xcf" --export --export-filename "$here/robot.ora"
unzip -l "$here/robot.ora"
unzip -p "$here/robot.ora" stack.xml
rm -rf "$work"
