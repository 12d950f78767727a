//! Layer meshing benches (criterion): `mesh_polygons` on the robot polygon of
//! `bench/triangle_compare.py` at the area bounds for which Triangle gives ~1,000 and ~5,000
//! vertices, and the whole `mesh_alpha` pipeline on an anti-aliased 256×256 disc with a hole.
//! Results and machine: benches/README.md (section `mesh`).

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use puppet::puppet::mesh::{mesh_alpha, mesh_polygons, MeshOptions};

#[derive(serde::Deserialize)]
struct PolygonFile {
    rings: Vec<Vec<[f32; 2]>>,
}

/// Area bounds (px²) for which Triangle `pq30a<area>` gives ~1,000 and ~5,000 vertices on the
/// robot polygon (found by bisection in bench/triangle_compare.py).
const ROBOT_AREAS: [(usize, f32); 2] = [(1000, 137.286), (5000, 11.118)];

fn robot(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/data/robot4x.json");
    let text = std::fs::read_to_string(path).expect("benches/data/robot4x.json is committed");
    let file: PolygonFile = serde_json::from_str(&text).expect("polygon file is valid JSON");
    let mut group = c.benchmark_group("mesh/robot4x");
    for (vertices, max_area) in ROBOT_AREAS {
        let opts = MeshOptions {
            max_area,
            min_angle: 30.0,
            ..MeshOptions::default()
        };
        group.bench_function(format!("vertices={vertices}"), |b| {
            b.iter(|| mesh_polygons(black_box(&file.rings), &[], &opts).expect("robot polygon meshes"))
        });
    }
    group.finish();
}

fn alpha(c: &mut Criterion) {
    let size = 256u32;
    let alpha: Vec<f32> = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f32 + 0.5 - 128.0, (i / size) as f32 + 0.5 - 128.0);
            let r = (x * x + y * y).sqrt();
            (0.5 + (100.0 - r).min(r - 30.0)).clamp(0.0, 1.0)
        })
        .collect();
    let opts = MeshOptions {
        max_area: 64.0,
        ..MeshOptions::default()
    };
    c.bench_function("mesh/alpha/annulus256/max_area=64", |b| {
        b.iter(|| mesh_alpha(black_box(&alpha), size, size, &[[128.0, 40.0]], &opts).expect("annulus meshes"))
    });
}

criterion_group!(benches, robot, alpha);
criterion_main!(benches);
