//! A layer or frame image (PNG, or GIF: whatever the `image` build reads), decoded within a 1 Mpx
//! limit (the default 16 Mpx would make each large input slow, not different).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::picture::{ImageLimits, Picture};

fuzz_target!(|data: &[u8]| {
    let limits = ImageLimits { max_pixels: 1 << 20 };
    if let Ok(p) = Picture::decode_within(data, Path::new("fuzz/layer.png"), &limits) {
        assert_eq!(p.pixels.len(), p.width as usize * p.height as usize);
        assert!(u64::from(p.width) * u64::from(p.height) <= limits.max_pixels);
        assert!(p.pixels.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
    }
});
