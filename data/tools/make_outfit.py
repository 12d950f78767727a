"""Draws other outfits for the Kenney male adventurer over the same body.

    python3 data/tools/make_outfit.py data/kenney/male_adventurer

writes <character>/outfits/cap_scarf/ (a cap and a scarf) and outfits/crown_cape/ (a crown and
a cape behind him): one full-canvas PNG per layer (the body parts and the hair cut from the idle
frame by the label map, as `puppet build` cuts them, plus the accessories drawn here) and a
character.toml in the layer-PNG form. `puppet inbetween --dress` and the demo put them on a model
trained on the character. Needs Pillow.
"""

import sys
from pathlib import Path

from PIL import Image, ImageDraw

# The character's label colours (its character.toml), back → front.
PARTS = [
    ("leg_l", "#911eb4", "body"),
    ("leg_r", "#bfef45", "body"),
    ("torso", "#3cb44b", "body"),
    ("arm_l", "#4363d8", "body"),
    ("arm_r", "#f58231", "body"),
    ("head", "#e6194b", "body"),
    ("hair", "#800000", "accessory"),
]

CAP = (200, 40, 40, 255)
CAP_SHADE = (150, 25, 30, 255)
SCARF = (40, 90, 200, 255)
SCARF_SHADE = (25, 60, 150, 255)
GOLD = (235, 190, 40, 255)
GOLD_SHADE = (190, 140, 20, 255)
CAPE = (130, 30, 120, 255)


def rgb(hex_colour):
    return tuple(int(hex_colour[i : i + 2], 16) for i in (1, 3, 5))


def cut(image, labels, colour):
    """The pixels of `image` whose label is `colour`, on a transparent canvas."""
    out = Image.new("RGBA", image.size, (0, 0, 0, 0))
    for y in range(image.height):
        for x in range(image.width):
            label = labels.getpixel((x, y))
            if label[3] > 0 and label[:3] == colour:
                out.putpixel((x, y), image.getpixel((x, y)))
    return out


def cap(size):
    """A cap over the top of the head and the hair: a dome and a brim to the viewer's right."""
    layer = Image.new("RGBA", size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.ellipse((22, 20, 74, 60), fill=CAP)
    draw.rectangle((18, 40, 80, 62), fill=(0, 0, 0, 0))
    draw.rectangle((22, 38, 74, 44), fill=CAP_SHADE)
    draw.polygon([(60, 40), (84, 42), (84, 46), (60, 46)], fill=CAP_SHADE)
    draw.ellipse((45, 17, 51, 23), fill=CAP_SHADE)
    return layer


def scarf(size):
    """A scarf round the neck with one end hanging over the chest."""
    layer = Image.new("RGBA", size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.rounded_rectangle((31, 80, 65, 88), radius=4, fill=SCARF)
    draw.line((33, 84, 63, 84), fill=SCARF_SHADE, width=1)
    draw.rectangle((52, 86, 59, 100), fill=SCARF)
    draw.rectangle((52, 97, 59, 100), fill=SCARF_SHADE)
    return layer


def crown(size):
    """A crown sitting on the hair: a band and three points."""
    layer = Image.new("RGBA", size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.rectangle((31, 33, 61, 40), fill=GOLD)
    for x in (31, 43, 55):
        draw.polygon([(x, 34), (x + 3, 22), (x + 6, 34)], fill=GOLD)
    draw.rectangle((31, 38, 61, 40), fill=GOLD_SHADE)
    draw.ellipse((44, 35, 48, 39), fill=(200, 40, 40, 255))
    return layer


def cape(size):
    """A cape hanging from the shoulders behind the body, wider at the bottom."""
    layer = Image.new("RGBA", size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.polygon([(26, 82), (70, 82), (82, 114), (14, 114)], fill=CAPE)
    return layer


# Outfit name → accessories: (name, drawing, in front of the body (True) or behind it).
OUTFITS = {
    "cap_scarf": [("scarf", scarf, True), ("cap", cap, True)],
    "crown_cape": [("cape", cape, False), ("crown", crown, True)],
}


def main(character):
    character = Path(character)
    for outfit, accessories in OUTFITS.items():
        write_outfit(character, outfit, accessories)


def write_outfit(character, outfit, accessories):
    image = Image.open(character / "frames" / "maleAdventurer_idle.png").convert("RGBA")
    labels = Image.open(character / "labels.png").convert("RGBA")
    out = character / "outfits" / outfit
    out.mkdir(parents=True, exist_ok=True)
    body = [(name, cut(image, labels, rgb(colour)), kind) for name, colour, kind in PARTS]
    behind = [(name, draw(image.size), "accessory") for name, draw, front in accessories if not front]
    ahead = [(name, draw(image.size), "accessory") for name, draw, front in accessories if front]
    layers = behind + body + ahead
    names = ", ".join(name for name, _, _ in accessories)
    toml = [
        "# Another outfit for the male adventurer, drawn by data/tools/make_outfit.py: the same body",
        f"# (cut from the idle frame by the label map), his hair, and {names}. Back → front.",
        f'name = "male_adventurer_{outfit}"',
        'root = "torso"',
        "# The body's hinges come from the model it dresses.",
        "joints = []",
        "",
    ]
    for name, picture, kind in layers:
        picture.save(out / f"{name}.png")
        toml += ["[[layer]]", f'name = "{name}"', f'file = "{name}.png"']
        if kind != "body":
            toml.append(f'kind = "{kind}"')
        toml.append("")
    (out / "character.toml").write_text("\n".join(toml))
    preview = Image.new("RGBA", image.size, (255, 255, 255, 255))
    for _, picture, _ in layers:
        preview.alpha_composite(picture)
    preview.resize((image.width * 4, image.height * 4), Image.NEAREST).save(f"/tmp/outfit_{outfit}.png")
    print(f"wrote {out} ({len(layers)} layers); preview /tmp/outfit_{outfit}.png")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "data/kenney/male_adventurer")
