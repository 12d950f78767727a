//! `rig_truth.json`: only "no panic" (any map of names is a valid truth).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::eval::rig::RigTruth;

fuzz_target!(|data: &[u8]| {
    let _ = RigTruth::parse(data, Path::new("fuzz/rig_truth.json"));
});
