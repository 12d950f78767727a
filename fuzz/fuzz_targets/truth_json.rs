//! A synthetic sequence's `truth.json`: an accepted one has the version this build reads and one
//! placement per part in every frame.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::synth::truth::{Truth, TRUTH_VERSION};

fuzz_target!(|data: &[u8]| {
    if let Ok(truth) = Truth::parse(data, Path::new("fuzz/truth.json")) {
        assert_eq!(truth.version, TRUTH_VERSION);
        assert!(truth.frames.iter().all(|f| f.parts.len() == truth.parts.len()));
    }
});
