//! Soft rasterizer benchmarks (issue 3): forward + backward of a batch of 16 poses at 128×128 of
//! a puppet with ~1,000 faces in 11 layers, against a crisp forward-only render of the same batch,
//! on 1 thread and on all threads. `fwd_bwd` is what training does: `forward_saving`, then
//! `backward_saved` from its records; `bwd` is the latter alone. Ids: `render/<what>/faces=F/px=128/batch=16/threads=T`.
//! bench/softras_torch.py runs the dense PyTorch peer on the same sizes beside this.

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

#[path = "support/cpu_report.rs"]
mod cpu_report;
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use puppet::picture::Picture;
use puppet::puppet::{Layer, LayerKind, Mesh, Puppet};
use puppet::render::{Background, Params, SoftRasterizer};

const SIZE: u32 = 128;
const BATCH: usize = 16;

fn stripes(base: [f32; 3], period: f32) -> impl Fn(f32, f32) -> [f32; 3] {
    move |x, y| {
        let s = 0.5 + 0.5 * ((x + 0.7 * y) * std::f32::consts::TAU / period).sin();
        let t = 0.5 + 0.5 * ((y - 0.3 * x) * std::f32::consts::TAU / (1.7 * period)).cos();
        [
            base[0] * (0.4 + 0.6 * s),
            base[1] * (0.5 + 0.5 * t),
            (base[2] + 0.3 * s * t).min(1.0),
        ]
    }
}

fn layer(name: &str, mesh: Mesh, inside: impl Fn(f32, f32) -> bool, colour: impl Fn(f32, f32) -> [f32; 3]) -> Layer {
    let mut texture = Picture::filled(SIZE, SIZE, [0.0; 4]);
    for (i, p) in texture.pixels.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % SIZE) as f32 + 0.5, (i as u32 / SIZE) as f32 + 0.5);
        let [r, g, b] = colour(x, y);
        *p = [r, g, b, if inside(x, y) { 1.0 } else { 0.0 }];
    }
    let uvs = mesh.vertices.iter().map(|v| [v[0] / SIZE as f32, v[1] / SIZE as f32]).collect();
    Layer {
        name: name.into(),
        kind: LayerKind::Body,
        mesh,
        uvs,
        texture,
    }
}

fn rect(name: &str, r: [f32; 4], nx: usize, ny: usize, base: [f32; 3]) -> Layer {
    let [x0, y0, x1, y1] = r;
    let mut mesh = Mesh::default();
    for j in 0..=ny {
        for i in 0..=nx {
            mesh.vertices
                .push([x0 + (x1 - x0) * i as f32 / nx as f32, y0 + (y1 - y0) * j as f32 / ny as f32]);
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            mesh.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            mesh.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    layer(name, mesh, |x, y| x >= x0 && x <= x1 && y >= y0 && y <= y1, stripes(base, 11.0))
}

/// A disc: a fan of `n` triangles around the centre, then `rings − 1` rings of `n` quads split
/// in two (well-shaped triangles, as a mesher would give): `n·(2·rings − 1)` faces.
fn disc(name: &str, c: [f32; 2], radius: f32, n: usize, rings: usize, base: [f32; 3]) -> Layer {
    let mut mesh = Mesh {
        vertices: vec![c],
        triangles: Vec::new(),
    };
    for r in 1..=rings {
        for k in 0..n {
            let th = std::f32::consts::TAU * k as f32 / n as f32;
            let rad = radius * r as f32 / rings as f32;
            mesh.vertices.push([c[0] + rad * th.cos(), c[1] + rad * th.sin()]);
        }
    }
    let id = |r: usize, k: usize| (1 + (r - 1) * n + k % n) as u32;
    for k in 0..n {
        mesh.triangles.push([0, id(1, k), id(1, k + 1)]);
    }
    for r in 1..rings {
        for k in 0..n {
            mesh.triangles.push([id(r, k), id(r + 1, k), id(r + 1, k + 1)]);
            mesh.triangles.push([id(r, k), id(r + 1, k + 1), id(r, k + 1)]);
        }
    }
    layer(name, mesh, |x, y| (x - c[0]).hypot(y - c[1]) <= radius, stripes(base, 9.0))
}

/// A 128×128 character: 11 overlapping layers, 996 faces (bench/softras_torch.py builds the
/// same geometry).
fn character() -> Puppet {
    let layers = vec![
        rect("arm_back", [20.0, 40.0, 64.0, 52.0], 12, 4, [0.2, 0.5, 0.9]),
        rect("leg_back", [50.0, 84.0, 62.0, 124.0], 4, 12, [0.3, 0.3, 0.8]),
        rect("torso", [40.0, 36.0, 88.0, 90.0], 8, 6, [0.9, 0.6, 0.2]),
        rect("leg_front", [66.0, 84.0, 78.0, 124.0], 4, 12, [0.4, 0.3, 0.9]),
        rect("neck", [56.0, 24.0, 72.0, 40.0], 4, 12, [0.9, 0.8, 0.6]),
        disc("head", [64.0, 22.0], 18.0, 20, 3, [0.3, 0.8, 0.3]),
        disc("hair", [64.0, 12.0], 12.0, 20, 3, [0.5, 0.3, 0.1]),
        rect("arm_front", [64.0, 44.0, 112.0, 56.0], 12, 4, [0.8, 0.2, 0.5]),
        disc("hand", [112.0, 50.0], 7.0, 12, 3, [0.9, 0.7, 0.6]),
        rect("belt", [40.0, 70.0, 88.0, 78.0], 12, 4, [0.1, 0.1, 0.1]),
        rect("scarf", [48.0, 34.0, 80.0, 42.0], 8, 4, [0.9, 0.1, 0.1]),
    ];
    Puppet {
        width: SIZE,
        height: SIZE,
        layers,
        root: 2,
        joints: vec![],
        rig: None,
    }
}

/// 16 poses: the rest pose shifted and wobbled a little, deterministically.
fn poses(p: &Puppet) -> Vec<f32> {
    let rest = p.rest_vertices();
    (0..BATCH)
        .flat_map(|b| {
            rest.iter()
                .enumerate()
                .flat_map(move |(i, v)| {
                    let w = ((i * 7 + b * 13) % 17) as f32 / 17.0 - 0.5;
                    [v[0] + 0.3 * b as f32 + 0.8 * w, v[1] - 0.2 * b as f32 + 0.6 * w]
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Prints wall and CPU milliseconds per call of `run`, averaged over `n` calls.
fn report_cpu(name: &str, n: usize, run: impl FnMut()) {
    let (wall, cpu) = cpu_report::measure(n, 1, run);
    println!(
        "cpu-report {name}: wall {:.1} ms, cpu {:.1} ms per batch of {BATCH} ({:.2} ms cpu per image)",
        wall * 1e3,
        cpu * 1e3,
        cpu * 1e3 / BATCH as f64
    );
}

fn bench(c: &mut Criterion) {
    let puppet = character();
    let raster = SoftRasterizer::new(&puppet).expect("the benchmark puppet is valid");
    let verts = poses(&puppet);
    let (w, h) = (SIZE as usize, SIZE as usize);
    let soft = Params {
        sigma: 0.5,
        ..Params::default()
    };
    let crisp = Params::crisp(Background::Transparent);
    let d_image: Vec<f32> = (0..BATCH * w * h * 4).map(|i| ((i * 31 % 97) as f32 / 97.0) - 0.5).collect();
    let d_mask: Vec<f32> = (0..BATCH * w * h).map(|i| ((i * 17 % 89) as f32 / 89.0) - 0.5).collect();
    let faces = raster.face_count();
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut group = c.benchmark_group("render");
    group.sample_size(10).throughput(Throughput::Elements(BATCH as u64));
    for threads in [1, all] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
        let id = |what: &str| format!("{what}/faces={faces}/px={SIZE}/batch={BATCH}/threads={threads}");
        if std::env::var_os("RENDER_CPU_REPORT").is_some() {
            report_cpu(&id("fwd_bwd"), 20, || {
                pool.install(|| {
                    let (f, saved) = raster.forward_saving(&verts, BATCH, w, h, &soft).expect("valid input");
                    let g = raster.backward_saved(&saved, Some(&d_image), Some(&d_mask)).expect("valid input");
                    black_box((f, g));
                })
            });
            report_cpu(&id("fwd_saving"), 20, || {
                pool.install(|| black_box(raster.forward_saving(&verts, BATCH, w, h, &soft).expect("valid input")));
            });
            let (_, saved) = raster.forward_saving(&verts, BATCH, w, h, &soft).expect("valid input");
            report_cpu(&id("bwd"), 20, || {
                pool.install(|| black_box(raster.backward_saved(&saved, Some(&d_image), Some(&d_mask)).expect("valid input")));
            });
            report_cpu(&id("crisp_fwd"), 20, || {
                pool.install(|| black_box(raster.forward(&verts, BATCH, w, h, &crisp).expect("valid input")));
            });
        }
        group.bench_function(id("fwd_bwd"), |b| {
            b.iter(|| {
                pool.install(|| {
                    let (f, saved) = raster.forward_saving(black_box(&verts), BATCH, w, h, &soft).expect("valid input");
                    let g = raster.backward_saved(&saved, Some(&d_image), Some(&d_mask)).expect("valid input");
                    black_box((f, g))
                })
            })
        });
        group.bench_function(id("soft_fwd"), |b| {
            b.iter(|| pool.install(|| black_box(raster.forward(black_box(&verts), BATCH, w, h, &soft).expect("valid input"))))
        });
        let (_, saved) = pool.install(|| raster.forward_saving(&verts, BATCH, w, h, &soft).expect("valid input"));
        group.bench_function(id("bwd"), |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        raster
                            .backward_saved(black_box(&saved), Some(&d_image), Some(&d_mask))
                            .expect("valid input"),
                    )
                })
            })
        });
        group.bench_function(id("crisp_fwd"), |b| {
            b.iter(|| pool.install(|| black_box(raster.forward(black_box(&verts), BATCH, w, h, &crisp).expect("valid input"))))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
