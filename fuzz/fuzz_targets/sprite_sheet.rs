//! A sprite sheet cut into poses (`parts::pose::split_sheet`, by alpha or by a grid), then the
//! one-character check and superpixels of every pose: the sheet is built from the bytes (two
//! size bytes, a layout byte and two grid bytes, then RGBA pixels), so every input is a sheet.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::parts::pose::{check_one_character, split_sheet, Layout, MAX_POSES};
use puppet::parts::superpixels::{slic, NONE};
use puppet::picture::Picture;

fuzz_target!(|data: &[u8]| {
    let [w, h, layout, columns, rows, pixels @ ..] = data else { return };
    let (w, h) = (u32::from(*w % 96) + 1, u32::from(*h % 96) + 1);
    let mut sheet = Picture::filled(w, h, [0.0; 4]);
    for (p, bytes) in sheet.pixels.iter_mut().zip(pixels.chunks_exact(4)) {
        *p = [0, 1, 2, 3].map(|k| f32::from(bytes[k]) / 255.0);
    }
    let layout = if layout % 2 == 0 {
        Layout::Alpha
    } else {
        Layout::Grid {
            columns: u32::from(*columns % 6),
            rows: u32::from(*rows % 6),
        }
    };
    let Ok(poses) = split_sheet(&sheet, Path::new("fuzz/sheet.png"), layout) else { return };
    assert!((2..=MAX_POSES).contains(&poses.len()));
    for pose in &poses {
        assert_eq!((pose.image.width, pose.image.height), (poses[0].image.width, poses[0].image.height));
        assert!(pose.area() > 0);
        let sp = slic(pose, 12, 10.0);
        for (&l, &m) in sp.labels.iter().zip(&pose.mask) {
            assert_eq!(l != NONE, m);
        }
    }
    let _ = check_one_character(&poses, Path::new("fuzz/sheet.png"));
});
