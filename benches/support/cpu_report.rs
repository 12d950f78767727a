//! Wall and CPU time of a benchmark's step, for the `cpu-report` lines of benches that run on a
//! shared machine: wall-clock figures include waiting for a core, CPU time per step does not.

/// CPU time (user + system) of this process so far, in seconds, from /proc/self/stat (Linux;
/// 0 elsewhere).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest.split_whitespace().skip(11).take(2).filter_map(|x| x.parse().ok()).collect();
    f.iter().sum::<f64>() / 100.0 // USER_HZ is 100 on Linux
}

/// Wall and CPU seconds per call of `run`, averaged over `n` calls after `warmup` calls.
pub fn measure(n: usize, warmup: usize, mut run: impl FnMut()) -> (f64, f64) {
    for _ in 0..warmup {
        run();
    }
    let (wall, cpu) = (std::time::Instant::now(), cpu_seconds());
    for _ in 0..n {
        run();
    }
    (wall.elapsed().as_secs_f64() / n as f64, (cpu_seconds() - cpu) / n as f64)
}
