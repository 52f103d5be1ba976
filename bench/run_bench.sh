#!/usr/bin/env bash
# run_bench.sh - prints every benchmark table (make bench).  Speed is
# measured here, never asserted in tests.
set -eu
cd "$(dirname "$0")/.."
for b in build/release/bench/bench_*; do
    [ -x "$b" ] || continue
    echo "== $(basename "$b")"
    "$b"
    echo
done
