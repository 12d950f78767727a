//! The correspondence network's files: a training config TOML (`puppet train-parts`), and a
//! network folder's shape (`net.json`) with weights bytes (`puppet parts --net`). Input: the
//! first byte picks which; the rest is the file (for the network, the shape and the weights
//! split at the first NUL). A shape is bounded before any network is built from it.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::parts::learn::{LearnConfig, TrainedNet};

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    if which % 2 == 0 {
        let Ok(text) = std::str::from_utf8(rest) else { return };
        if let Ok(config) = LearnConfig::parse(text, Path::new("fuzz/parts-net.toml")) {
            config.validate().expect("a parsed config is valid");
        }
    } else {
        let split = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
        let (shape, weights) = rest.split_at(split);
        let device = puppet::backend::device();
        let _ = TrainedNet::from_bytes(shape, weights.get(1..).unwrap_or_default().to_vec(), Path::new("fuzz/net"), &device);
    }
});
