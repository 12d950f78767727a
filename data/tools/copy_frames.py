"""Copy the Kenney character frames out of the `arcade` wheel as straight-alpha RGBA PNGs.

Usage:
    pip download arcade==3.3.3 --no-deps -d /tmp/arcade
    cd /tmp/arcade && unzip -q arcade-3.3.3-py3-none-any.whl -d ex
    python3 data/tools/copy_frames.py /tmp/arcade/ex data

Only `robot`, `male_adventurer` and `female_adventurer` are copied. The source files are
palette (mode "P") PNGs with a transparency entry; Pillow's P -> RGBA conversion looks up each
index in the palette and its tRNS alpha, which is exactly straight (non-premultiplied) alpha.
Original file names are kept (e.g. robot_walk3.png).
"""

import sys
from pathlib import Path

from PIL import Image

CHARACTERS = ["robot", "male_adventurer", "female_adventurer"]
SUBDIR = "arcade/resources/assets/images/animated_characters"


def main() -> None:
    src_root = Path(sys.argv[1]) / SUBDIR
    out_root = Path(sys.argv[2]) / "kenney"
    for character in CHARACTERS:
        src = src_root / character
        dst = out_root / character / "frames"
        dst.mkdir(parents=True, exist_ok=True)
        files = sorted(src.glob("*.png"))
        if len(files) != 13:
            raise SystemExit(f"{src}: expected 13 frames, found {len(files)}")
        for f in files:
            im = Image.open(f)
            if im.size != (96, 128):
                raise SystemExit(f"{f}: size {im.size}, expected (96, 128)")
            rgba = im.convert("RGBA")
            rgba.save(dst / f.name, optimize=True)
            print(f"{f.name}: mode {im.mode} -> RGBA {rgba.size}")


if __name__ == "__main__":
    main()
