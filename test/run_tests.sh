#!/usr/bin/env bash
# run_tests.sh - runs every test binary of both flavours, the command-line
# tests, the structure check and the fuzz smoke runs, and prints one closing
# line "N passed, N failed" (the sum over everything).
#
# Jobs run TEST_JOBS at a time (default: the processor count), each into a
# log of its own; the results are tallied afterwards in a fixed order, so the
# output reads the same whatever finished first.  Every test makes its own
# temporary files (mkdtemp, mktemp -d or the process id), so jobs never share
# a path.  The fuzz run, the longest job, starts first.
set -u
cd "$(dirname "$0")/.."
passed=0; failed=0
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/test/lsan.supp:print_suppressions=0"
jobs_max=${TEST_JOBS:-$(nproc 2>/dev/null || echo 2)}
case "$jobs_max" in '' | *[!0-9]* | 0) jobs_max=2 ;; esac

tally() { # name, log file, exit status
    local line p f
    line=$(grep -E '^[^ ]+: [0-9]+ passed, [0-9]+ failed$' "$2" | tail -n 1)
    if [ -n "$line" ]; then
        p=$(sed -E 's/.*: ([0-9]+) passed.*/\1/' <<<"$line")
        f=$(sed -E 's/.*passed, ([0-9]+) failed/\1/' <<<"$line")
    else
        p=0; f=1
    fi
    if [ "$3" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi  # a crash after the summary still fails
    passed=$((passed + p)); failed=$((failed + f))
    if [ "$f" -ne 0 ]; then
        echo "---- $1 FAILED (exit $3); its output:"; cat "$2"
    else
        echo "$1: $p passed"
    fi
}

logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
names=(); cmds=()
add() { names+=("$1"); cmds+=("$2"); }

if [ -f test/fuzz/run_fuzz.sh ]; then
    add fuzz "FUZZ_SEED=${FUZZ_SEED:-1} bash test/fuzz/run_fuzz.sh ${FUZZ_SECONDS:-30}"
fi
for flavour in asan release; do
    for t in build/$flavour/test/test_*; do
        [ -x "$t" ] || continue
        add "$flavour/$(basename "$t")" "RADIOSITY_BIN=build/$flavour/radiosity $t"
    done
done
for s in test/cli/*.sh; do
    [ -f "$s" ] || continue
    add "cli/$(basename "$s")" "RADIOSITY_BIN=build/release/radiosity bash $s"
done
# The tree's shape (issue 35, tools/check-structure.sh): no circle among the
# release objects, no two source files of one name, few long functions.
add structure "bash tools/check-structure.sh"

# Start job k in the background; its exit status lands in $logs/k.rc.
start() {
    ( eval "${cmds[$1]}" > "$logs/$1.log" 2>&1; echo $? > "$logs/$1.rc" ) &
}
running=0
for k in "${!cmds[@]}"; do
    if [ "$running" -ge "$jobs_max" ]; then wait -n; running=$((running - 1)); fi
    start "$k"; running=$((running + 1))
done
wait

# Tallied in a fixed order: release, asan, command line, structure, fuzz.
order=()
for prefix in release/ asan/ cli/ structure fuzz; do
    for k in "${!names[@]}"; do
        case "${names[$k]}" in "$prefix"*) order+=("$k") ;; esac
    done
done
for k in "${order[@]}"; do
    rc=1; [ -f "$logs/$k.rc" ] && rc=$(cat "$logs/$k.rc")
    tally "${names[$k]}" "$logs/$k.log" "$rc"
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
