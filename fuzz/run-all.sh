#!/usr/bin/env bash
# Runs every cargo-fuzz target for SECONDS each (default 120), one after the other, niced (10, or
# $FUZZ_NICE), with AddressSanitizer (cargo-fuzz's default), a 10 s per-input timeout and a 2 GB
# memory limit (the issue's hang and out-of-memory bounds), seeded from the regression corpus. Writes
# fuzz/logs/TARGET.log and prints one summary line per target (executions, time, edges, crashes).
#   cd fuzz && ./run-all.sh 300            # or: ./run-all.sh 60 obj vol
set -u
cd "$(dirname "$0")"
seconds=${1:-120}
shift || true
targets=${*:-obj vol cache env scene_strings render_argv}
mkdir -p logs
for t in $targets; do
    mkdir -p "corpus/$t" "artifacts/$t"
    # One thread for the bake and solver inside a target: the machine is shared.
    RAYON_NUM_THREADS=1 nice -n ${FUZZ_NICE:-10} cargo +nightly fuzz run -O "$t" "corpus/$t" "../tests/fuzz-corpus/$t" -- \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        >"logs/$t.log" 2>&1
    rc=$?
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$')
    secs=$(grep -o 'Done [0-9]* runs in [0-9]* second' "logs/$t.log" | grep -o 'in [0-9]*' | grep -o '[0-9]*')
    cov=$(grep -o 'cov: [0-9]*' "logs/$t.log" | tail -1 | grep -o '[0-9]*')
    ft=$(grep -o 'ft: [0-9]*' "logs/$t.log" | tail -1 | grep -o '[0-9]*')
    crashes=$(find "artifacts/$t" -type f | wc -l)
    echo "$t: exit $rc, ${runs:-?} executions in ${secs:-?} s, cov ${cov:-?} edges, ft ${ft:-?}, artifacts $crashes"
done
