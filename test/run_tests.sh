#!/usr/bin/env bash
# run_tests.sh - runs every test binary of both flavours, the command-line
# tests and the fuzz smoke runs, and prints one closing line
# "N passed, N failed" (the sum over everything).
set -u
cd "$(dirname "$0")/.."
passed=0; failed=0
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/test/lsan.supp:print_suppressions=0"

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
for flavour in release asan; do
    for t in build/$flavour/test/test_*; do
        [ -x "$t" ] || continue
        name="$flavour/$(basename "$t")"
        RADIOSITY_BIN=build/$flavour/radiosity "$t" > "$logs/log" 2>&1
        tally "$name" "$logs/log" $?
    done
done
for s in test/cli/*.sh; do
    [ -f "$s" ] || continue
    RADIOSITY_BIN=build/release/radiosity bash "$s" > "$logs/log" 2>&1
    tally "cli/$(basename "$s")" "$logs/log" $?
done
if [ -f test/fuzz/run_fuzz.sh ]; then
    bash test/fuzz/run_fuzz.sh "${FUZZ_SECONDS:-30}" > "$logs/log" 2>&1
    tally "fuzz" "$logs/log" $?
fi
rm -rf "$logs"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
