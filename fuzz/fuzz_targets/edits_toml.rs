//! An eval-rig edits file (`[[edit]]` tables): an accepted one has at least one edit.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::eval::rig::EditsFile;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(edits) = EditsFile::parse(text, Path::new("fuzz/edits.toml")) {
        assert!(!edits.is_empty());
    }
});
