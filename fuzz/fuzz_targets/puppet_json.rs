//! `puppet.json` (the JSON part: textures are given by the harness at the size the file
//! declares, up to 64×64, so the texture-size check is reached): an accepted puppet keeps every
//! invariant of `common::check_puppet`.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::picture::Picture;
use puppet::puppet::format;
use puppet::Error;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let size = |key: &str| {
        serde_json::from_slice::<serde_json::Value>(data)
            .ok()
            .and_then(|v| v.get(key)?.as_u64())
            .filter(|&n| (1..=64).contains(&n))
            .unwrap_or(1) as u32
    };
    let (w, h) = (size("width"), size("height"));
    let texture = |path: &Path| {
        // A texture whose file cannot be read: its error is reported, not a panic.
        if path.to_string_lossy().contains("missing") {
            return Err(Error::image(path, "cannot decode image"));
        }
        Ok(Picture::filled(w, h, [0.5, 0.5, 0.5, 1.0]))
    };
    if let Ok(p) = format::parse(data, Path::new("fuzz/puppet.json"), texture) {
        common::check_puppet(&p);
    }
});
