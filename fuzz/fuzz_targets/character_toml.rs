//! `character.toml`: parsed and validated; an accepted file names a root body layer.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::puppet::character::Character;
use puppet::puppet::LayerKind;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(c) = Character::parse(text, Path::new("fuzz/character.toml")) {
        assert!(!c.layers.is_empty());
        assert_eq!(c.layers[c.root_index()].kind, LayerKind::Body);
    }
});
