//! Times `puppet::geom::bbw` on a mesh/handles file, for the side-by-side comparison with libigl
//! in bench/bbw_libigl.py (which reads what this prints and writes).
//!
//! Usage: `cargo run --release --example bbw_time -- <problem.txt> <weights.txt> [repeats] [voronoi]`
//!
//! Input: the format of benches/data (bench/arap_libigl.py): a line `V F H`, V lines `x y`, F lines
//! `a b c`, H lines `handle x y` (the position is not used). `voronoi` selects libigl's mass matrix
//! ([`MassMatrix::Voronoi`]) instead of the default barycentric one.
//! Output: `<weights.txt>` with V lines of H bounded weights *before* normalisation (the normalised
//! weights times the row sums, what libigl's `bbw` returns), and on stdout `median_ms=… min_ms=…
//! iterations=… max_row_sum_deviation=… normalised_row_error=…` (timing over `repeats` runs,
//! default 5, after one warm-up run; the last two: largest |Σ_k w − 1| before and after the rows
//! were normalised).

// A measuring tool: its output is what it prints.
#![allow(clippy::print_stdout)]

use std::fmt::Write as _;
use std::time::Instant;

use puppet::geom::{bbw, BbwOptions, MassMatrix};

type Problem = (Vec<[f64; 2]>, Vec<[u32; 3]>, Vec<u32>);

fn read_problem(path: &str) -> Result<Problem, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(n, l)| (n + 1, l.split_whitespace().collect::<Vec<_>>()));
    let mut next = |what: &str| lines.next().ok_or_else(|| format!("{path}: ends before {what}"));
    fn num<T: std::str::FromStr>(path: &str, line: usize, fields: &[&str], k: usize) -> Result<T, String> {
        let field = fields
            .get(k)
            .ok_or_else(|| format!("{path}: line {line}: expected {} fields", k + 1))?;
        field.parse().map_err(|_| format!("{path}: line {line}: {field:?} is not a number"))
    }
    let (n, head) = next("the header")?;
    let [v, f, h] = [0, 1, 2].map(|k| num::<usize>(path, n, &head, k));
    let (v, f, h) = (v?, f?, h?);
    let mut positions = Vec::with_capacity(v);
    for _ in 0..v {
        let (n, l) = next("a vertex")?;
        positions.push([num(path, n, &l, 0)?, num(path, n, &l, 1)?]);
    }
    let mut triangles = Vec::with_capacity(f);
    for _ in 0..f {
        let (n, l) = next("a triangle")?;
        triangles.push([num(path, n, &l, 0)?, num(path, n, &l, 1)?, num(path, n, &l, 2)?]);
    }
    let mut handles = Vec::with_capacity(h);
    for _ in 0..h {
        let (n, l) = next("a handle")?;
        handles.push(num(path, n, &l, 0)?);
    }
    Ok((positions, triangles, handles))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: bbw_time <problem.txt> <weights.txt> [repeats] [voronoi]".into());
    }
    let repeats: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(5).max(1);
    let mass = match args.get(4).map(String::as_str) {
        None | Some("barycentric") => MassMatrix::Barycentric,
        Some("voronoi") => MassMatrix::Voronoi,
        Some(other) => return Err(format!("mass {other:?}: expected barycentric or voronoi").into()),
    };
    let (positions, triangles, handles) = read_problem(&args[1])?;
    let options = BbwOptions::default().with_mass(mass);
    let mut weights = bbw(&positions, &triangles, &handles, &options)?;
    let mut times = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let start = Instant::now();
        weights = bbw(&positions, &triangles, &handles, &options)?;
        times.push(1e3 * start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let mut out = String::new();
    for (v, sum) in weights.row_sums.iter().enumerate() {
        let row: Vec<String> = weights.row(v).iter().map(|w| format!("{:.12e}", w * sum)).collect();
        writeln!(out, "{}", row.join(" "))?;
    }
    std::fs::write(&args[2], out).map_err(|e| format!("{}: {e}", args[2]))?;
    let normalised_row_error = (0..weights.vertices())
        .map(|v| (weights.row(v).iter().sum::<f64>() - 1.0).abs())
        .fold(0.0, f64::max);
    println!(
        "median_ms={:.3} min_ms={:.3} iterations={} max_row_sum_deviation={:.4} normalised_row_error={:.1e}",
        times[times.len() / 2],
        times[0],
        weights.iterations,
        weights.max_row_sum_deviation(),
        normalised_row_error
    );
    Ok(())
}
