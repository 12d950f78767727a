//! Runs `puppet::geom::ArapSolver` on a mesh/handles/targets file written by
//! bench/arap_libigl.py, for the side-by-side comparison with libigl.
//!
//! Usage: `cargo run --release --example arap_solve -- <problem.txt> <result.txt> [repeats]`
//!
//! Input: a line `V F H`, then V lines `x y`, F lines `a b c`, H lines `handle x y` (target).
//! Output: `<result.txt>` with V lines `x y` (the solution after 10 iterations from the rest mesh
//! with its handles moved), and on stdout `precompute_ms=… solve10_ms=…`, medians over `repeats`.

use std::time::Instant;

use puppet::geom::ArapSolver;

type Problem = (Vec<[f64; 2]>, Vec<[u32; 3]>, Vec<u32>, Vec<[f64; 2]>);

fn read_problem(path: &str) -> Result<Problem, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text.lines().enumerate();
    let mut next = |what: &str| -> Result<Vec<String>, String> {
        let (n, line) = lines
            .next()
            .ok_or_else(|| format!("{path}: ends before {what}"))?;
        let fields: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
        if fields.is_empty() {
            return Err(format!("{path}: line {}: empty, expected {what}", n + 1));
        }
        Ok(fields)
    };
    fn num<T: std::str::FromStr>(path: &str, s: &str) -> Result<T, String> {
        s.parse()
            .map_err(|_| format!("{path}: {s:?} is not a number"))
    }
    let head = next("the header")?;
    let [v, f, h] = [0, 1, 2].map(|k| head.get(k).map(|s| num::<usize>(path, s)));
    let (v, f, h) = (
        v.ok_or("missing V")??,
        f.ok_or("missing F")??,
        h.ok_or("missing H")??,
    );
    let mut rest = Vec::with_capacity(v);
    for _ in 0..v {
        let l = next("a vertex")?;
        rest.push([
            num(path, &l[0])?,
            num(path, l.get(1).ok_or("short vertex line")?)?,
        ]);
    }
    let mut tris = Vec::with_capacity(f);
    for _ in 0..f {
        let l = next("a triangle")?;
        if l.len() != 3 {
            return Err(format!("{path}: triangle line {l:?} needs 3 indices"));
        }
        tris.push([num(path, &l[0])?, num(path, &l[1])?, num(path, &l[2])?]);
    }
    let (mut handles, mut targets) = (Vec::with_capacity(h), Vec::with_capacity(h));
    for _ in 0..h {
        let l = next("a handle")?;
        if l.len() != 3 {
            return Err(format!("{path}: handle line {l:?} needs `index x y`"));
        }
        handles.push(num(path, &l[0])?);
        targets.push([num(path, &l[1])?, num(path, &l[2])?]);
    }
    Ok((rest, tris, handles, targets))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: arap_solve <problem.txt> <result.txt> [repeats]".into());
    }
    let repeats: usize = args
        .get(3)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(20)
        .max(1);
    let (rest, tris, handles, targets) = read_problem(&args[1])?;
    let mut initial = rest.clone();
    for (&h, t) in handles.iter().zip(&targets) {
        initial[h as usize] = *t;
    }
    let (mut pre, mut sol) = (Vec::new(), Vec::new());
    let mut result = Vec::new();
    for _ in 0..repeats {
        let t0 = Instant::now();
        let mut solver = ArapSolver::new(&rest, &tris, &handles)?;
        let t1 = Instant::now();
        result = solver.solve(&targets, 10, &initial);
        let t2 = Instant::now();
        pre.push((t1 - t0).as_secs_f64() * 1e3);
        sol.push((t2 - t1).as_secs_f64() * 1e3);
    }
    let text: String = result
        .iter()
        .map(|p| format!("{:.17e} {:.17e}\n", p[0], p[1]))
        .collect();
    std::fs::write(&args[2], text)?;
    println!(
        "vertices={} precompute_ms={:.4} solve10_ms={:.4}",
        rest.len(),
        median(pre),
        median(sol)
    );
    Ok(())
}
