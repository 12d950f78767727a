//! Criterion benchmarks of accessory rigs (`puppet::rig`): building a rig on a built puppet (the
//! layer DAG, pins, the accessories meshed again and their bounded biharmonic weights), carrying
//! one body pose to the accessories (`RigMap::apply`, once per frame of anything posed), and
//! putting another outfit on a body (`rig::outfit::dress`, what `--dress` costs).
//!
//! Characters: the Kenney male adventurer (96×128, his hair), his cap-and-scarf outfit (three
//! accessories), and the 640² DiceBear character of benches/data when present.
//!
//! Ids: `rig/build/<character>`, `rig/propagate/<character>`, `rig/dress/<outfit>`. Results:
//! benches/README.md "rig".

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{criterion_group, criterion_main, Criterion};
use puppet::progress::Silent;
use puppet::puppet::artwork::{self, Artwork};
use puppet::puppet::build::{build, BuildOptions};
use puppet::puppet::Puppet;
use puppet::rig::deform::RigMap;
use puppet::rig::outfit::{dress, undress};
use puppet::rig::{rig_puppet, RigOptions};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

fn artwork(path: &Path) -> Artwork {
    artwork::load(path, &artwork::ImportOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The characters: name and artwork folder.
fn characters() -> Vec<(&'static str, PathBuf)> {
    let mut list = vec![
        ("male_adventurer", root().join("data/kenney/male_adventurer")),
        ("cap_scarf", root().join("data/kenney/male_adventurer/outfits/cap_scarf")),
    ];
    let dicebear = root().join("benches/data/dicebear-640");
    if dicebear.join("character.toml").is_file() {
        list.push(("dicebear-640", dicebear));
    }
    list
}

fn bench_rig(c: &mut Criterion) {
    let mut group = c.benchmark_group("rig");
    group.sample_size(10);
    for (name, dir) in characters() {
        let art = artwork(&dir);
        let options = BuildOptions::default();
        let (built, _) = build(&art, &options, &Silent).unwrap();
        let mesh = options.mesh_options(built.width, built.height);
        group.bench_function(format!("build/{name}"), |b| {
            b.iter(|| rig_puppet(black_box(&built), &art.rig, &mesh, &RigOptions::default(), &Silent).unwrap())
        });
        let rigged = rig_puppet(&built, &art.rig, &mesh, &RigOptions::default(), &Silent).unwrap();
        let map = RigMap::new(&rigged, rigged.rig.as_ref().unwrap());
        let mut pose = turned(&rigged);
        group.bench_function(format!("propagate/{name}"), |b| b.iter(|| map.apply(black_box(&mut pose))));
    }
    // The outfit on the male adventurer's body without his own accessories.
    let body_art = artwork(&root().join("data/kenney/male_adventurer"));
    let options = BuildOptions::default();
    let (body, _) = build(&body_art, &options, &Silent).unwrap();
    let mesh = options.mesh_options(body.width, body.height);
    let body = rig_puppet(&body, &body_art.rig, &mesh, &RigOptions::default(), &Silent).unwrap();
    let bare = undress(&body, &["hair".to_string()], &Silent).unwrap();
    let outfit = artwork(&root().join("data/kenney/male_adventurer/outfits/cap_scarf"));
    group.bench_function("dress/cap_scarf", |b| {
        b.iter(|| dress(black_box(&bare), &outfit, &options, &RigOptions::default(), &Silent).unwrap())
    });
    group.finish();
}

/// The rest pose turned by 0.1 rad about the canvas centre: every accessory vertex moves.
fn turned(puppet: &Puppet) -> Vec<[f32; 2]> {
    let (cx, cy) = (puppet.width as f32 / 2.0, puppet.height as f32 / 2.0);
    let (s, c) = 0.1f32.sin_cos();
    puppet
        .rest_vertices()
        .iter()
        .map(|p| [cx + c * (p[0] - cx) - s * (p[1] - cy), cy + s * (p[0] - cx) + c * (p[1] - cy)])
        .collect()
}

criterion_group!(benches, bench_rig);
criterion_main!(benches);
