//! Criterion benchmarks of `puppet::geom` ARAP: precomputation, 10 local/global iterations with
//! 12 handles on the character meshes of benches/data (written by `bench/arap_libigl.py
//! --write-data`), and the batched f32 energy + gradient the training loss calls.
//!
//! Ids: `arap/precompute/vertices=N`, `arap/solve10/vertices=N`, `arap/energy_grad/batch=B`
//! (on the ~1k-vertex mesh), each on all threads. Results: benches/README.md.

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use puppet::geom::{ArapEnergy, ArapSolver};

struct Problem {
    rest: Vec<[f64; 2]>,
    tris: Vec<[u32; 3]>,
    handles: Vec<u32>,
    targets: Vec<[f64; 2]>,
}

/// Reads the `V F H` / vertices / triangles / `handle x y` text format of bench/arap_libigl.py.
fn load(name: &str) -> Problem {
    let path = format!("{}/benches/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines().map(|l| l.split_whitespace().collect::<Vec<_>>());
    let head = lines.next().expect("header");
    let [v, f, h] = [0, 1, 2].map(|k| head[k].parse::<usize>().expect("count"));
    let rest = (0..v)
        .map(|_| lines.next().map(|l| [l[0].parse().unwrap(), l[1].parse().unwrap()]).unwrap())
        .collect();
    let tris = (0..f)
        .map(|_| lines.next().map(|l| [0, 1, 2].map(|k| l[k].parse().unwrap())).unwrap())
        .collect();
    let (mut handles, mut targets) = (Vec::new(), Vec::new());
    for _ in 0..h {
        let l = lines.next().expect("handle line");
        handles.push(l[0].parse().unwrap());
        targets.push([l[1].parse().unwrap(), l[2].parse().unwrap()]);
    }
    Problem {
        rest,
        tris,
        handles,
        targets,
    }
}

fn bench_solver(c: &mut Criterion) {
    let mut group = c.benchmark_group("arap");
    group.sample_size(30);
    for name in ["character_1k.txt", "character_5k.txt"] {
        let p = load(name);
        let n = p.rest.len();
        group.bench_function(BenchmarkId::new("precompute", format!("vertices={n}")), |b| {
            b.iter(|| ArapSolver::new(black_box(&p.rest), &p.tris, &p.handles).unwrap())
        });
        let mut solver = ArapSolver::new(&p.rest, &p.tris, &p.handles).unwrap();
        let mut initial = p.rest.clone();
        for (&h, t) in p.handles.iter().zip(&p.targets) {
            initial[h as usize] = *t;
        }
        group.bench_function(BenchmarkId::new("solve10", format!("vertices={n}")), |b| {
            b.iter(|| solver.solve(black_box(&p.targets), 10, &initial))
        });
    }
    group.finish();
}

fn bench_energy(c: &mut Criterion) {
    let p = load("character_1k.txt");
    let rest32: Vec<[f32; 2]> = p.rest.iter().map(|v| [v[0] as f32, v[1] as f32]).collect();
    let energy = ArapEnergy::new(&rest32, &p.tris).unwrap();
    let mut group = c.benchmark_group("arap");
    for batch in [1usize, 16] {
        // A smooth non-rigid deformation of every item (a shear that grows with the index).
        let deformed: Vec<f32> = (0..batch)
            .flat_map(|b| {
                rest32
                    .iter()
                    .flat_map(move |v| [v[0] + 0.01 * (b as f32 + 1.0) * v[1], v[1] + 0.1 * (v[0] * 0.05).sin()])
            })
            .collect();
        let mut grad = vec![0.0f32; deformed.len()];
        group.throughput(Throughput::Elements((batch * rest32.len()) as u64));
        group.bench_function(BenchmarkId::new("energy_grad", format!("batch={batch}")), |b| {
            b.iter(|| energy.energy_and_gradient(black_box(&deformed), &mut grad).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_solver, bench_energy);
criterion_main!(benches);
