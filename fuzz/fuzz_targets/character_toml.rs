//! `character.toml`: parsed and validated — as a character (an accepted file names a root body
//! layer) and as the overrides beside a layered file (an accepted one names no layer twice).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::puppet::character::{CharacterFile, LayeredOverrides};
use puppet::puppet::LayerKind;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(c) = CharacterFile::parse(text, Path::new("fuzz/character.toml")) {
        assert!(!c.layers.is_empty());
        assert_eq!(c.layers[c.root_index()].kind, LayerKind::Body);
    }
    if let Ok(Some(o)) = LayeredOverrides::parse(text, Path::new("fuzz/character.toml")) {
        let names: std::collections::HashSet<&str> = o.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names.len(), o.layers.len());
    }
});
