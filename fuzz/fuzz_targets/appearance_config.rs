//! An appearance-stage config TOML: parsed and validated; an accepted one passes `validate` again
//! and builds network configs for any working size.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::appearance::AppearanceConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(config) = AppearanceConfig::parse(text, Path::new("fuzz/appearance.toml")) {
        config.validate().expect("a parsed config is valid");
        assert_eq!(config.net(128).depth(), 7);
    }
});
