//! A Middlebury `.flo` optical-flow file (`puppet parts --flows`), read for 6 × 5 poses; an
//! accepted one is carried onto a pose and lands on its foreground or nowhere.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::parts::flow::{parse_flo, Flow};
use puppet::parts::pose::SheetPose;
use puppet::picture::Picture;

fuzz_target!(|data: &[u8]| {
    let Ok(displacement) = parse_flo(data, Path::new("fuzz/flow.flo"), 6, 5) else { return };
    assert_eq!(displacement.len(), 30);
    let mut picture = Picture::filled(6, 5, [0.0; 4]);
    for k in [7, 8, 13, 22] {
        picture.pixels[k] = [1.0; 4];
    }
    let pose = SheetPose::new("p", picture);
    let flow = Flow::from_displacements(&displacement, &pose, &pose);
    for i in 0..30 {
        if let Some(q) = flow.at(i) {
            let (x, y) = (q[0].round(), q[1].round());
            assert!((0.0..6.0).contains(&x) && (0.0..5.0).contains(&y), "{q:?}");
            assert!(pose.mask[y as usize * 6 + x as usize], "{q:?} is off the character");
        }
    }
});
