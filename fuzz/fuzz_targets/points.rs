//! A points file (`puppet correspond --points`): accepted points are finite and not too many.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::edit::correspond::{parse_points, MAX_POINTS};

fuzz_target!(|data: &[u8]| {
    if let Ok(points) = parse_points(data, Path::new("fuzz/points.json")) {
        assert!(points.len() <= MAX_POINTS);
        assert!(points.iter().flatten().all(|c| c.is_finite()));
    }
});
