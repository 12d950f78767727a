//! The prior's training config TOML: parsed and validated; an accepted one passes `validate`
//! again.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::prior::PriorConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(config) = PriorConfig::parse(text, Path::new("fuzz/prior.toml")) {
        config.validate().expect("a parsed config is valid");
    }
});
