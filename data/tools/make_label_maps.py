"""Paint the label maps of the Kenney idle frames (data/kenney/<character>/labels.png).

Usage: python3 data/tools/make_label_maps.py data/kenney [--preview DIR]

A label map gives every pixel of the character (alpha > 0) one flat part colour and leaves the
background transparent; `character.toml` beside it names the parts. A user would paint it in an
image editor; here each part is "painted" by a rule in pixel coordinates of the 96×128 idle frame
(rectangles split by the part boundaries seen in the drawing, plus the drawing's own colours
where two parts meet along a colour edge — e.g. the robot's light claws against its blue
forearms). Every rule was checked on an 8× overlay (--preview writes them).
"""

import sys
from pathlib import Path

from PIL import Image

# Part colours (Sasha Trubetskoy's list): flat, far apart, easy to see in an editor.
COLOURS = {
    "handle": (0xA9, 0xA9, 0xA9),
    "head": (0xE6, 0x19, 0x4B),
    "hair": (0x80, 0x00, 0x00),
    "torso": (0x3C, 0xB4, 0x4B),
    "arm_l": (0x43, 0x63, 0xD8),
    "arm_r": (0xF5, 0x82, 0x31),
    "hand_l": (0x42, 0xD4, 0xF4),
    "hand_r": (0xF0, 0x32, 0xE6),
    "leg_l": (0x91, 0x1E, 0xB4),
    "leg_r": (0xBF, 0xEF, 0x45),
}


def light(p):
    """The pale grey-blue of the robot's handle and claws."""
    return p[0] > 150 and p[1] > 170


def dark(p):
    """The robot's dark navy plating."""
    return p[0] + p[1] + p[2] < 330


def robot(x, y, p):
    if y < 53:
        return "handle" if light(p) else "head"
    if y >= 104 and light(p) and (x < 34 or x > 62):
        return "hand_l" if x < 48 else "hand_r"
    if (y >= 108 and 31 <= x <= 65) or (y >= 118 and 27 <= x <= 69):
        return "leg_l" if x < 48 else "leg_r"
    if y < 84:
        # The dark shoulder plates run diagonally under the head's sides; the dark mouth grill
        # (x 40–57) belongs to the head.
        shoulder = dark(p) and y >= 70 and (x < 40 or x > 57)
        if 34 <= x <= 62:
            return "torso" if shoulder or y >= 82 else "head"
        return "torso" if shoulder or y >= 76 else "head"
    if x < 31:
        return "arm_l"
    if x > 65:
        return "arm_r"
    return "torso"


def brown(p):
    """Hair, eyebrows, straps and boots of the adventurers (skin has green above 150)."""
    return p[0] > p[1] + 40 and p[1] < 150


def skin(p):
    return p[0] > 200 and p[1] > 150 and p[2] > 110


def male_adventurer(x, y, p):
    if y < 55:
        return "head" if skin(p) else "hair"
    if y < 80:
        return "hair" if brown(p) and (x < 34 or x > 61) else "head"
    if y < 84 and skin(p) and 32 <= x <= 64:
        return "head"
    if (y >= 103 and 32 <= x <= 64) or (y >= 122 and 26 <= x <= 70):
        return "leg_l" if x < 48 else "leg_r"
    # Below the shirt the arms hang free: everything beside the legs is arm.
    if x < 29 or (y >= 100 and x < 32):
        return "arm_l"
    if x > 66 or (y >= 100 and x > 64):
        return "arm_r"
    return "torso"


def female_adventurer(x, y, p):
    if y < 80:
        return "head"
    if y < 90 and (skin(p) and 38 <= x <= 58 or brown(p) and (x < 34 or x > 60)):
        return "head"
    if (y >= 110 and 32 <= x <= 63) or (y >= 120 and 28 <= x <= 68):
        return "leg_l" if x < 48 else "leg_r"
    if x < 31 or (y >= 106 and x < 32):
        return "arm_l"
    if x > 64 or (y >= 106 and x > 63):
        return "arm_r"
    return "torso"


CHARACTERS = {
    "robot": ("robot_idle.png", robot),
    "male_adventurer": ("maleAdventurer_idle.png", male_adventurer),
    "female_adventurer": ("femaleAdventurer_idle.png", female_adventurer),
}


def paint(folder: Path, frame: str, rule) -> Image.Image:
    image = Image.open(folder / "frames" / frame).convert("RGBA")
    labels = Image.new("RGBA", image.size, (0, 0, 0, 0))
    for y in range(image.height):
        for x in range(image.width):
            p = image.getpixel((x, y))
            if p[3] > 0:
                labels.putpixel((x, y), COLOURS[rule(x, y, p)] + (255,))
    return labels


def overlay(image: Image.Image, labels: Image.Image, scale: int = 8) -> Image.Image:
    """The frame with the label colours blended over it, upscaled for inspection."""
    out = Image.new("RGBA", image.size, (255, 255, 255, 255))
    out.alpha_composite(image)
    tint = labels.copy()
    tint.putalpha(labels.getchannel("A").point(lambda a: 150 if a else 0))
    out.alpha_composite(tint)
    return out.resize((image.width * scale, image.height * scale), Image.NEAREST)


def main() -> None:
    root = Path(sys.argv[1])
    preview = Path(sys.argv[sys.argv.index("--preview") + 1]) if "--preview" in sys.argv else None
    for name, (frame, rule) in CHARACTERS.items():
        labels = paint(root / name, frame, rule)
        labels.save(root / name / "labels.png")
        if preview:
            preview.mkdir(parents=True, exist_ok=True)
            image = Image.open(root / name / "frames" / frame).convert("RGBA")
            overlay(image, labels).crop(image.getbbox() and tuple(8 * c for c in image.getbbox())).save(preview / f"{name}.png")
        used = sorted({labels.getpixel((x, y))[:3] for x in range(labels.width) for y in range(labels.height) if labels.getpixel((x, y))[3]})
        print(name, "parts:", [k for k, v in COLOURS.items() if v in used])


if __name__ == "__main__":
    main()
