//! An OpenRaster `.ora` file as raw bytes (zip, then `stack.xml`, then layer PNGs): an accepted
//! import keeps `common::check_artwork`. Zip CRCs make most mutations fail early; `ora_stack`
//! fuzzes `stack.xml` behind a valid zip.
#![no_main]

use std::io::Cursor;
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::puppet::artwork::ImportOptions;
use puppet::puppet::ora;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    if let Ok(art) = ora::from_reader(Cursor::new(data), Path::new("fuzz/robot.ora"), &ImportOptions::default(), &puppet::progress::Silent) {
        common::check_artwork(&art);
    }
});
