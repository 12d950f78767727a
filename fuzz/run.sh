#!/usr/bin/env bash
# Runs every fuzz target (or the ones named) for SECONDS each, one after another, and prints one
# summary line per target: executions, new corpus size, crashes. Usage: fuzz/run.sh 60 [target…]
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`). The corpus grows in
# fuzz/corpus/<target> (seeded from fuzz/seeds/<target>); crashing inputs land in
# fuzz/artifacts/<target>; each run's libFuzzer output is kept in fuzz/logs/<target>.log.
set -euo pipefail
cd "$(dirname "$0")"
mkdir -p logs
seconds=${1:?usage: fuzz/run.sh SECONDS [target…]}
shift
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(cargo +nightly fuzz list)
fi
# No sanitizer: the library forbids unsafe code, so AddressSanitizer finds nothing that a panic
# would not, and it would make every run several times slower. Overflow checks stay on.
cargo +nightly fuzz build -s none >logs/build.log 2>&1 || { cat logs/build.log; exit 1; }
# Built once, run directly: a source edit during the runs does not change what is fuzzed.
bin=target/$(rustc +nightly -vV | sed -n 's/^host: //p')/release

printf '%-16s %8s %12s %8s %8s  %s\n' target seconds execs corpus crashes artifact
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    before=$(find "artifacts/$t" -type f | wc -l)
    # Exit status is non-zero on a crash; the summary below reports it.
    "$bin/$t" "corpus/$t" "seeds/$t" -artifact_prefix="artifacts/$t/" \
        -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
        >"logs/$t.log" 2>&1 || true
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$' || echo '?')
    corpus=$(find "corpus/$t" -type f | wc -l)
    after=$(find "artifacts/$t" -type f | wc -l)
    newest=$(ls -t "artifacts/$t" 2>/dev/null | head -1)
    artifact=$([ "$after" -gt "$before" ] && echo "artifacts/$t/$newest" || echo -)
    printf '%-16s %8s %12s %8s %8s  %s\n' "$t" "$seconds" "$execs" "$corpus" "$((after - before))" "$artifact"
done
