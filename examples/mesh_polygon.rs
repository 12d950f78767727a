//! Meshes a polygon file with `puppet::puppet::mesh::mesh_polygons` and prints one JSON line:
//! vertex and triangle counts, smallest angle, largest area and the median time over `--runs`.
//! Used by `bench/triangle_compare.py` to compare with Shewchuk's Triangle on the same polygon.
//!
//! ```text
//! cargo run --release --example mesh_polygon -- benches/data/robot4x.json --max-area 120 --min-angle 30 --runs 20
//! ```
//! The polygon file is JSON `{"rings": [[[x, y], ...], ...]}` (pixels, even-odd rule).

use std::time::Instant;

use puppet::puppet::mesh::{mesh_polygons, MeshOptions};

#[derive(serde::Deserialize)]
struct PolygonFile {
    rings: Vec<Vec<[f32; 2]>>,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let path = args
        .first()
        .ok_or_else(|| anyhow::anyhow!("usage: mesh_polygon FILE [--max-area A] [--min-angle D] [--runs N]"))?;
    let mut opts = MeshOptions::default();
    if let Some(a) = flag("--max-area") {
        opts.max_area = a.parse()?;
    }
    if let Some(d) = flag("--min-angle") {
        opts.min_angle = d.parse()?;
    }
    let runs: usize = flag("--runs").map(|r| r.parse()).transpose()?.unwrap_or(20).max(1);
    let file: PolygonFile = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    // One untimed run first: a fresh process pays page faults and allocator growth once.
    mesh_polygons(&file.rings, &[], &opts)?;
    let mut times = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        let mesh = mesh_polygons(&file.rings, &[], &opts)?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        last = Some(mesh);
    }
    let all: Vec<String> = times.iter().map(|t| format!("{t:.4}")).collect();
    times.sort_by(f64::total_cmp);
    let mesh = last.expect("runs >= 1").mesh;
    mesh.check_invariants().map_err(anyhow::Error::msg)?;
    let max_area = mesh.triangles.iter().map(|&t| mesh.signed_area(t)).fold(0.0f32, f32::max);
    println!(
        "{{\"tool\": \"puppet (spade)\", \"vertices\": {}, \"triangles\": {}, \"min_angle\": {:.3}, \"max_area\": {:.3}, \"median_ms\": {:.4}, \"min_ms\": {:.4}, \"runs\": {runs}, \"times_ms\": [{}]}}",
        mesh.vertices.len(),
        mesh.triangles.len(),
        mesh.min_angle_degrees(),
        max_area,
        times[runs / 2],
        times[0],
        all.join(", ")
    );
    Ok(())
}
