//! Speed of the part finder (issue 16, `puppet parts`): SLIC superpixels of one 128² pose
//! (`parts/slic/128`, the kernel `bench/slic_skimage.py` compares with scikit-image's SLIC on
//! the same poses), the generator's exact correspondences between every ordered pair of a
//! 10-pose sheet (`parts/true_flows/10x128`), and the whole finder on that sheet — superpixels
//! of every pose, merging, refinement, labelling every pose, hinges and order
//! (`parts/find/10x128`). The sheet is synthetic seed 9000's generator at 10 poses. Results:
//! benches/README.md "parts".
//!
//! ```sh
//! cargo bench --bench parts
//! ```

// Criterion's macros write undocumented functions.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion};
use puppet::parts::superpixels::slic;
use puppet::parts::{find_parts, PartsOptions};
use puppet::synth::sheet_flow::{true_correspondences, GeneratedSheet};

// The binary's allocator and its setting (src/allocator.rs), so a call costs what it costs in
// `puppet parts`.
#[path = "../src/allocator.rs"]
mod allocator;

fn parts(c: &mut Criterion) {
    allocator::keep_freed_memory();
    let sheet = GeneratedSheet::new(9000, 10, 128).expect("the generator runs");
    let (poses, labels, truth) = (&sheet.poses, &sheet.labels, &sheet.sequence.truth);
    let options = PartsOptions::default();
    c.bench_function("parts/slic/128", |b| {
        b.iter(|| slic(&poses[0], options.superpixels, options.compactness))
    });
    c.bench_function("parts/true_flows/10x128", |b| {
        b.iter(|| true_correspondences(truth, labels).expect("flows"))
    });
    let flows = true_correspondences(truth, labels).expect("flows");
    c.bench_function("parts/find/10x128", |b| {
        b.iter(|| find_parts(poses.clone(), &flows, &options).expect("parts"))
    });
}

criterion_group!(benches, parts);
criterion_main!(benches);
