//! Part label maps (issue 4 item 4): one flat, well-separated colour per part name on a
//! transparent background — the label-map form DESIGN.md describes for artwork.

use super::character::Character;
use super::draw::{Drawing, BACKGROUND};
use crate::picture::Picture;

/// Label colours by part name, every part the generator makes a colour of its own (so a label
/// map read back names each accessory, not just "an accessory"); unknown names get grey.
const COLORS: [(&str, [u8; 3]); 21] = [
    ("torso", [230, 25, 75]),
    ("head", [60, 180, 75]),
    ("arm_back_upper", [255, 225, 25]),
    ("arm_back_lower", [0, 130, 200]),
    ("arm_front_upper", [245, 130, 48]),
    ("arm_front_lower", [145, 30, 180]),
    ("leg_back_upper", [70, 240, 240]),
    ("leg_back_lower", [240, 50, 230]),
    ("leg_front_upper", [210, 245, 60]),
    ("leg_front_lower", [250, 190, 212]),
    ("tail", [0, 128, 128]),
    ("ear_back", [170, 110, 40]),
    ("ear_front", [128, 0, 0]),
    ("vest", [230, 190, 255]),
    ("trim", [255, 250, 200]),
    ("hair_back", [0, 0, 128]),
    ("freckles", [255, 215, 180]),
    ("glasses", [128, 128, 0]),
    ("hat", [170, 255, 195]),
    ("bracelet", [255, 255, 255]),
    ("sleeve", [64, 64, 64]),
];

/// The label colour of part `name`.
pub fn label_rgb(name: &str) -> [u8; 3] {
    COLORS.iter().find(|(n, _)| *n == name).map(|&(_, c)| c).unwrap_or([128, 128, 128])
}

/// The label colour of part `name` as `"#rrggbb"`.
pub fn label_hex(name: &str) -> String {
    let [r, g, b] = label_rgb(name);
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// The label map of a drawing as a picture: each part's colour, opaque; background transparent.
pub fn label_picture(character: &Character, drawing: &Drawing) -> Picture {
    let (w, h) = (drawing.image.width, drawing.image.height);
    let colors: Vec<[f32; 4]> = character
        .parts
        .iter()
        .map(|p| {
            let [r, g, b] = label_rgb(&p.name);
            [r as f32 / 255.0, g as f32 / 255.0, b as f32 / 255.0, 1.0]
        })
        .collect();
    let pixels = drawing
        .labels
        .iter()
        .map(|&l| if l == BACKGROUND { [0.0; 4] } else { colors[l as usize] })
        .collect();
    Picture {
        width: w,
        height: h,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn label_colours_are_distinct() {
        let set: HashSet<[u8; 3]> = COLORS.iter().map(|c| c.1).chain([[128, 128, 128]]).collect();
        assert_eq!(
            set.len(),
            COLORS.len() + 1,
            "a part shares a colour with another or with unknown parts"
        );
        assert_eq!(label_hex("torso"), "#e6194b");
    }
}
