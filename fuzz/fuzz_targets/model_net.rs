//! A model folder's network files: its config (`net.json`, read as `Model::load` reads it) and
//! weights bytes loaded into a small network. Input: the first byte picks which; the rest is the
//! file. A config is bounded before any network is built from it.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use puppet::model::bundle::{load_weights, read_net_config};
use puppet::model::deformation::{DeformationNetConfig, MAX_PARAMETERS};

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    if which % 2 == 0 {
        if let Ok(config) = read_net_config(rest, Path::new("fuzz/net.json")) {
            assert!(config.parameter_count().is_some_and(|n| n <= MAX_PARAMETERS), "an accepted config is bounded");
        }
    } else {
        let device = puppet::backend::device();
        let config = DeformationNetConfig::new(3)
            .with_input_size(16)
            .with_channels([2, 2, 2])
            .with_encoder_hidden([4, 4])
            .with_latent(4)
            .with_decoder_hidden([4, 4]);
        let _ = load_weights(config.init(&device), rest.to_vec(), Path::new("fuzz/weights.bpk"));
    }
});
