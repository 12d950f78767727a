//! A pose file (`vertices.json`) checked against a three-vertex puppet: an accepted pose has
//! one finite position per vertex.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::picture::Picture;
use puppet::puppet::pose_file::PoseFile;
use puppet::puppet::{Layer, LayerKind, Mesh, Puppet};

fuzz_target!(|data: &[u8]| {
    let puppet = Puppet {
        width: 2,
        height: 2,
        layers: vec![Layer {
            name: "torso".into(),
            kind: LayerKind::Body,
            mesh: Mesh {
                vertices: vec![[0.0, 0.0], [0.0, 2.0], [2.0, 0.0]],
                triangles: vec![[0, 1, 2]],
            },
            uvs: vec![[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
            texture: Picture::filled(2, 2, [1.0; 4]),
        }],
        root: 0,
        joints: Vec::new(),
        rig: None,
    };
    if let Ok(pose) = PoseFile::parse(data, Path::new("fuzz/vertices.json"), &puppet) {
        assert_eq!(pose.vertices.len(), 3);
        assert!(pose.vertices.iter().flatten().all(|c| c.is_finite()));
    }
});
