//! The label-map form with the robot's `character.toml` (nine parts): the input is turned into a
//! label map and a reference image (so that every input reaches the cutting, not just the PNG
//! decoder, which the `png` target fuzzes) and both go through `label_map_layers` as PNG bytes.
//!
//! Input: byte 0 gives the width (1–32, low 5 bits) and the label overlap (high 3 bits); each
//! further byte is one pixel: `b % 11` is 0 for transparent, 1–9 for a part's colour, 10 for a
//! colour not in the legend; the reference image's pixel is opaque where `b ≥ 128`.
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use puppet::picture::Picture;
use puppet::puppet::artwork::{label_map_layers, ImportOptions};
use puppet::puppet::character::{parse_color, CharacterFile};

#[path = "common.rs"]
mod common;

fn character() -> &'static CharacterFile {
    static CHARACTER: OnceLock<CharacterFile> = OnceLock::new();
    CHARACTER.get_or_init(|| {
        let text = include_str!("../../data/kenney/robot/character.toml");
        CharacterFile::parse(text, Path::new("robot/character.toml")).expect("the robot's character.toml is valid")
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&head, pixels)) = data.split_first() else { return };
    let width = 1 + u32::from(head & 31);
    let height = pixels.len() as u32 / width;
    if height == 0 {
        return;
    }
    let character = character();
    let legend: Vec<[u8; 3]> = character
        .layers
        .iter()
        .map(|l| parse_color(l.color.as_deref().expect("label-map form")).expect("valid"))
        .collect();
    let mut map = Picture::filled(width, height, [0.0; 4]);
    let mut image = Picture::filled(width, height, [0.0; 4]);
    for (i, &b) in pixels.iter().take((width * height) as usize).enumerate() {
        let label = usize::from(b % 11);
        map.pixels[i] = match label {
            0 => [0.0; 4],
            10 => [0.5, 0.5, 0.5, 1.0],
            k => {
                let [r, g, b] = legend[(k - 1) % legend.len()].map(|v| f32::from(v) / 255.0);
                [r, g, b, 1.0]
            }
        };
        if b >= 128 {
            image.pixels[i] = [f32::from(b) / 255.0, 0.2, 0.4, 1.0];
        }
    }
    let png = |p: &Picture| p.png_bytes(Path::new("fuzz")).expect("encodes");
    let opts = ImportOptions {
        label_overlap: u32::from(head >> 5),
        ..ImportOptions::default()
    };
    let (map_path, image_path) = (Path::new("fuzz/labels.png"), Path::new("fuzz/image.png"));
    if let Ok(layers) = label_map_layers(character, &png(&map), map_path, &png(&image), image_path, &opts) {
        assert_eq!(layers.len(), character.layers.len());
        common::check_layers(&layers);
        assert!(layers.iter().all(|l| (l.picture.width, l.picture.height) == (width, height)));
    }
});
