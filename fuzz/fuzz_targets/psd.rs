//! A Photoshop `.psd` file as raw bytes (header, layer records, raw/RLE channel data): an accepted
//! import keeps `common::check_artwork`. The reader is our own (`src/puppet/psd.rs`), so every
//! length it reads from the file is fuzzed here.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::progress::Silent;
use puppet::puppet::artwork::ImportOptions;
use puppet::puppet::psd;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Ok(art) = psd::from_bytes(data, Path::new("fuzz/robot.psd"), &ImportOptions::default(), &Silent) {
        common::check_artwork(&art);
    }
});
