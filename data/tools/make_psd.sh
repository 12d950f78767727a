#!/usr/bin/env bash
# Writes data/psd/: the Kenney robot's parts as Photoshop files from two real writers, the same
# parts as a PNG-layer folder they must import to, and tiny bad documents for the import's errors.
#
# The parts are the layers of data/kenney/robot/robot.ora (GIMP + Krita, see make_ora.sh), placed
# on the 96×128 canvas, plus one accessory of our own drawing (CC0 like the rest): a small yellow
# star "étoile" on the chest, in a group named "accessories" (its non-ASCII name checks that the
# Unicode layer names are read). Writers:
# - Krita (Debian's package, headless under xvfb) converts an .ora holding those layers to
#   robot_krita.psd;
# - psd-tools (PyPI) builds robot_psd_tools.psd from the PNGs, with one hidden layer ("sketch")
#   that the import must skip;
# - psd-tools also writes bad/: 16- and 32-bit, CMYK and grayscale documents, one with no layers,
#   one whose layer extends past the canvas.
# It also writes the PSD fuzz seeds (fuzz/seeds/psd/).
# Needs: apt-get install krita xvfb xauth; pip install psd-tools (with Pillow).
set -euo pipefail
data="$(cd "$(dirname "$0")/.." && pwd)"
out="$data/psd"
work="$(mktemp -d)"
mkdir -p "$out/robot_layers" "$out/bad"
python3 - "$data" "$out" "$work" <<'PY'
import sys, zipfile, xml.etree.ElementTree as ET
from io import BytesIO
from pathlib import Path
from PIL import Image, ImageDraw
data, out, work = map(Path, sys.argv[1:])
ora = zipfile.ZipFile(data / "kenney/robot/robot.ora")
stack = ET.fromstring(ora.read("stack.xml"))
size = (int(stack.get("w")), int(stack.get("h")))
layers = []  # back → front
for element in reversed(stack.findall(".//layer")):
    part = Image.new("RGBA", size, (0, 0, 0, 0))
    part.paste(Image.open(BytesIO(ora.read(element.get("src")))).convert("RGBA"), (int(element.get("x")), int(element.get("y"))))
    layers.append((element.get("name"), part, "body"))
star = Image.new("RGBA", size, (0, 0, 0, 0))
ImageDraw.Draw(star).polygon([(48, 80), (50, 85), (55, 85), (51, 88), (53, 93), (48, 90), (43, 93), (45, 88), (41, 85), (46, 85)], fill=(255, 215, 0, 255))
layers.append(("étoile", star, "accessory"))
toml = ['# The robot of data/kenney/robot/robot.ora as PNG layers, plus an accessory star; written by\n',
        '# data/tools/make_psd.sh. The .psd files beside this folder must import to the same puppet;\n',
        '# a layered file\'s root is its body layer with the most opaque pixels, here the head.\n',
        'name = "robot"\nroot = "head"\n']
for name, image, kind in layers:
    image.save(out / "robot_layers" / f"{'etoile' if kind == 'accessory' else name}.png")
    toml.append(f'\n[[layer]]\nname = "{name}"\nkind = "{kind}"\nfile = "{"etoile" if kind == "accessory" else name}.png"\n')
(out / "robot_layers/character.toml").write_text("".join(toml))
# The .ora Krita converts: parts top first, the star in a stack named "accessories".
z = zipfile.ZipFile(work / "robot.ora", "w")
z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
xml = [f'<image w="{size[0]}" h="{size[1]}"><stack>']
for i, (name, image, kind) in reversed(list(enumerate(layers))):
    buf = BytesIO()
    image.save(buf, "PNG")
    z.writestr(f"data/{i}.png", buf.getvalue())
    layer = f'<layer name="{name}" src="data/{i}.png" x="0" y="0" opacity="1" visibility="visible"/>'
    xml.append(f'<stack name="accessories">{layer}</stack>' if kind == "accessory" else layer)
xml.append("</stack></image>")
z.writestr("stack.xml", "".join(xml))
z.close()
PY
xvfb-run -a -s "-screen 0 640x480x24" krita "$work/robot.ora" --export --export-filename "$out/robot_krita.psd"
python3 - "$out" <<'PY'
import sys
from pathlib import Path
from PIL import Image
from psd_tools import PSDImage
from psd_tools.constants import Compression
out = Path(sys.argv[1])
text = (out / "robot_layers/character.toml").read_text()
names = [line.split('"')[1] for line in text.splitlines() if line.startswith("name = ") and "robot" not in line]
files = [line.split('"')[1] for line in text.splitlines() if line.startswith("file = ")]
psd = PSDImage.new("RGBA", (96, 128), color=(0, 0, 0, 0))
for name, file in zip(names, files):
    image = Image.open(out / "robot_layers" / file).convert("RGBA")
    box = image.getbbox()  # layers stored at their opaque bounds, as editors do
    parent = psd.create_group(name="accessories") if file == "etoile.png" else psd
    parent.create_pixel_layer(image.crop(box), name=name, left=box[0], top=box[1])
sketch = psd.create_pixel_layer(Image.new("RGBA", (20, 20), (255, 0, 0, 255)), name="sketch", left=2, top=2)
sketch.visible = False
# RLE for the merged image too (psd-tools stores a new document's raw): 70 KB → 34 KB.
psd._record.image_data.compression = Compression.RLE
psd.save(out / "robot_psd_tools.psd")
# Tiny bad documents: each is otherwise a valid file with one 2×2 layer.
def doc(mode, depth=8, size=(4, 4), layer=True, left=0):
    psd = PSDImage.new(mode, size, depth=depth)
    if layer:
        psd.create_pixel_layer(Image.new(psd.pil_mode if depth == 8 else mode, (2, 2), 255), name="part", left=left)
    return psd
doc("RGB", depth=16).save(out / "bad/depth16.psd")
doc("RGB", depth=32).save(out / "bad/depth32.psd")
doc("CMYK").save(out / "bad/cmyk.psd")
doc("L").save(out / "bad/grayscale.psd")
doc("RGBA", layer=False).save(out / "bad/no_layers.psd")
doc("RGBA", left=3).save(out / "bad/past_canvas.psd")
PY
# Fuzz seeds (fuzz/seeds/psd/): the files above, and one small character (12×10: a torso, an arm
# at half opacity, a star in "accessories"; psd-tools adds a multiply layer and a hidden one and
# stores one layer raw) from each writer.
seeds="$data/../fuzz/seeds/psd"
mkdir -p "$seeds"
cp "$out"/robot_*.psd "$out"/bad/*.psd "$seeds/"
python3 - "$seeds" "$work" <<'PY'
import sys, zipfile, io
from PIL import Image
from psd_tools import PSDImage
from psd_tools.constants import BlendMode, Compression
seeds, work = sys.argv[1:]
torso, arm, star = Image.new("RGBA", (8, 8), (40, 120, 200, 255)), Image.new("RGBA", (4, 3), (200, 50, 50, 255)), Image.new("RGBA", (3, 2), (250, 220, 0, 255))
psd = PSDImage.new("RGBA", (12, 10), color=(0, 0, 0, 0))
psd.create_pixel_layer(torso, name="torso", left=2, top=1)
psd.create_pixel_layer(arm, name="arm", left=7, top=4, compression=Compression.RAW, opacity=128)
psd.create_group(name="accessories").create_pixel_layer(star, name="étoile", left=4, top=0)
psd.create_pixel_layer(Image.new("RGBA", (2, 2), (0, 0, 0, 128)), name="shade", left=3, top=3, blend_mode=BlendMode.MULTIPLY)
psd.create_pixel_layer(Image.new("RGBA", (2, 2), (9, 9, 9, 255)), name="sketch").visible = False
psd._record.image_data.compression = Compression.RLE
psd.save(f"{seeds}/psd_tools_small.psd")
z = zipfile.ZipFile(f"{work}/small.ora", "w")
z.writestr(zipfile.ZipInfo("mimetype"), "image/openraster")
for i, image in enumerate([torso, arm, star]):
    buf = io.BytesIO()
    image.save(buf, "PNG")
    z.writestr(f"data/{i}.png", buf.getvalue())
z.writestr("stack.xml", '<image w="12" h="10"><stack><stack name="accessories"><layer name="étoile" src="data/2.png" x="4" y="0"/></stack>'
           '<layer name="arm" src="data/1.png" x="7" y="4" opacity="0.5"/><layer name="torso" src="data/0.png" x="2" y="1"/></stack></image>')
z.close()
PY
xvfb-run -a -s "-screen 0 640x480x24" krita "$work/small.ora" --export --export-filename "$seeds/krita_small.psd"
rm -rf "$work"
ls -l "$out" "$out/bad" "$seeds"
