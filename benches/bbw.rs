//! Criterion benchmarks of `puppet::geom::bbw` (bounded biharmonic weights, rows normalised) on
//! the meshes of benches/data: the ~1k- and ~5k-vertex characters with their 12 landmark handles
//! (written by `bench/arap_libigl.py --write-data`) and a hair strand shape pinned along its scalp
//! by 103 handles (written by `bench/bbw_libigl.py --write-data`).
//!
//! Ids: `bbw/solve/vertices=N/handles=H`, all threads. Results: benches/README.md "bbw".

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use puppet::geom::{bbw, BbwOptions};

/// Reads the `V F H` / vertices / triangles / `handle x y` text format of bench/arap_libigl.py
/// (the handle positions are not used).
fn load(name: &str) -> (Vec<[f64; 2]>, Vec<[u32; 3]>, Vec<u32>) {
    let path = format!("{}/benches/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines().map(|l| l.split_whitespace().collect::<Vec<_>>());
    let head = lines.next().expect("header");
    let [v, f, h] = [0, 1, 2].map(|k| head[k].parse::<usize>().expect("count"));
    let positions = (0..v)
        .map(|_| lines.next().map(|l| [l[0].parse().unwrap(), l[1].parse().unwrap()]).unwrap())
        .collect();
    let triangles = (0..f)
        .map(|_| lines.next().map(|l| [0, 1, 2].map(|k| l[k].parse().unwrap())).unwrap())
        .collect();
    let handles = (0..h).map(|_| lines.next().expect("handle line")[0].parse().unwrap()).collect();
    (positions, triangles, handles)
}

fn bench_bbw(c: &mut Criterion) {
    let mut group = c.benchmark_group("bbw");
    group.sample_size(10);
    for name in ["character_1k.txt", "character_5k.txt", "hair_2k.txt"] {
        let (positions, triangles, handles) = load(name);
        let id = format!("vertices={}/handles={}", positions.len(), handles.len());
        group.bench_function(BenchmarkId::new("solve", id), |b| {
            b.iter(|| bbw(black_box(&positions), &triangles, &handles, &BbwOptions::default()).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_bbw);
criterion_main!(benches);
