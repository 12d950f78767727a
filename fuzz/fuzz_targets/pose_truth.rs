//! A posed frame's truth (`pose_NNN.json` of `puppet prior data`) read for a three-vertex
//! puppet: an accepted one has one finite position and one flag per vertex.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::posing::write::PoseTruth;

fuzz_target!(|data: &[u8]| {
    if let Ok(truth) = PoseTruth::parse(data, Path::new("fuzz/pose_000.json"), 3) {
        assert_eq!((truth.vertices.len(), truth.visible.len()), (3, 3));
        assert!(truth.vertices.iter().flatten().all(|c| c.is_finite()));
    }
});
