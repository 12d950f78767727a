//! The `[retarget]` map of `puppet retarget --map` (a TOML file) and the first bytes a motion
//! file is told by (`Head::of`): neither panics, and an accepted map keeps the file's name.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::edit::retarget::{Head, RetargetMap};

fuzz_target!(|data: &[u8]| {
    let _ = Head::of(data);
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(map) = RetargetMap::parse(text, Path::new("fuzz/map.toml")) {
        assert_eq!(map.path, Path::new("fuzz/map.toml"));
    }
});
