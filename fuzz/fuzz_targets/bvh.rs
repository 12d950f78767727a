//! A BVH motion file (`puppet retarget`): an accepted file has a rooted skeleton within the
//! joint limit, one value per channel in every frame, finite values and a positive frame time,
//! and its joints place and point without panicking.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::edit::retarget::bvh::{Bvh, MAX_FRAMES, MAX_JOINTS};

fuzz_target!(|data: &[u8]| {
    if let Ok(bvh) = Bvh::parse(data, Path::new("fuzz/motion.bvh")) {
        assert!(!bvh.joints.is_empty() && bvh.joints.len() <= MAX_JOINTS);
        assert!(bvh.joints[0].parent.is_none());
        assert!(bvh.joints.iter().enumerate().skip(1).all(|(j, joint)| joint.parent.is_some_and(|p| p < j)));
        assert!(!bvh.frames.is_empty() && bvh.frames.len() <= MAX_FRAMES);
        let channels: usize = bvh.joints.iter().map(|j| j.channels.len()).sum();
        assert!(bvh.frames.iter().all(|f| f.len() == channels && f.iter().all(|v| v.is_finite())));
        assert!(bvh.frame_time > 0.0 && bvh.frame_time.is_finite());
        let _ = bvh.placed(Some(bvh.frames.len() - 1));
        let _ = bvh.bone_directions(None);
    }
});
