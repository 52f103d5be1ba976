#!/usr/bin/env bash
# run_fuzz.sh [SECONDS] - builds the libFuzzer targets and runs each one.
#
# Targets: polyfile (polygon-file parser + validation + mesher), gltf (glTF
# front end, C++ bridge included), solution (solution-file reader).  Each is
# built with clang -fsanitize=fuzzer,address,undefined against the library
# sources compiled the same way into build/fuzz, and run for SECONDS
# (default 30) on a scratch copy of its seed corpus (test/fuzz/corpus/NAME,
# never grown in place).  Before fuzzing, every file in
# test/fuzz/regressions/NAME/ is replayed once: inputs that once crashed
# must stay fixed.  A crash, leak, timeout, out-of-memory or sanitizer report
# fails the target; its input is kept under build/fuzz/artifacts/.
# The per-input timeout (TIMEOUT, seconds) catches hangs: it was 25 s until
# a mutated Cornell box that the mesher cuts into 77,000 patches before the
# harness's 20,000-patch cap refuses it took 58 s under this build's
# instrumentation (0.19 s in the release build).
#
# Prints per target the executions done, and last a line exactly
# "fuzz: N passed, M failed" (N targets clean); exits non-zero if any failed.
set -u
cd "$(dirname "$0")/../.."

SECONDS_EACH=${1:-30}
TIMEOUT=120
case "$SECONDS_EACH" in '' | *[!0-9]*) echo "usage: run_fuzz.sh [SECONDS]" >&2; exit 2 ;; esac
OUT=build/fuzz
CC=${FUZZ_CC:-clang}
CXX=${FUZZ_CXX:-clang++}
TARGETS="polyfile gltf solution"

for tool in "$CC" "$CXX"; do
    if ! command -v "$tool" > /dev/null; then
        echo "run_fuzz: $tool not found (tools/install-deps.sh installs clang)"
        echo "fuzz: 0 passed, 3 failed"
        exit 1
    fi
done

CPPFLAGS="-D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L -I/usr/include/OpenEXR -I/usr/include/Imath"
SAN="-fsanitize=address,undefined -fno-sanitize-recover=all"
# The library gets coverage instrumentation without libFuzzer's main; the
# targets get both.  No -Werror: clang's warnings are not the project's gate.
LIBFLAGS="-g -O1 -fno-omit-frame-pointer $SAN -fsanitize=fuzzer-no-link"
CFLAGS_LIB="-std=c11 $LIBFLAGS"
CXXFLAGS_LIB="-std=c++17 $LIBFLAGS"
TARGET_FLAGS="-std=c11 -g -O1 -fno-omit-frame-pointer $SAN -fsanitize=fuzzer"
LDLIBS="-lOpenEXRCore-3_1 -lpng -lm -lpthread"

mkdir -p "$OUT/obj" "$OUT/artifacts"

# ---------------------------------------------------------------- build
# A library object is rebuilt when its source or any header of the tree is
# newer than it (headers are few; tracking them exactly is not worth it).
newest_header=$(ls -t radiosity/*/*.h hemicube/*.h solver/*.h render/*.h 2>/dev/null | head -n 1)
lib_src=$(ls radiosity/*/*.c radiosity/*/*.cpp hemicube/*.c solver/*.c render/*.c 2>/dev/null |
          grep -v -E '^radiosity/cli/|^hemicube/mpi_ranks\.c$')  # MPI: radiosity-mpi only
build_failed=0
objs=()
for src in $lib_src; do
    obj="$OUT/obj/$(echo "${src%.*}" | tr / _).o"
    objs+=("$obj")
    if [ -f "$obj" ] && [ "$obj" -nt "$src" ] && { [ -z "$newest_header" ] || [ "$obj" -nt "$newest_header" ]; }; then
        continue
    fi
    case "$src" in
        *.cpp) cmd="$CXX $CPPFLAGS $CXXFLAGS_LIB -c $src -o $obj" ;;
        *)     cmd="$CC $CPPFLAGS $CFLAGS_LIB -c $src -o $obj" ;;
    esac
    if ! $cmd 2> "$OUT/obj/build.log"; then
        echo "run_fuzz: compiling $src failed:"; cat "$OUT/obj/build.log"
        rm -f "$obj"
        build_failed=1
    fi
done
if [ "$build_failed" -eq 0 ]; then
    rm -f "$OUT/libradiosity_fuzz.a"
    ar rcs "$OUT/libradiosity_fuzz.a" "${objs[@]}" || build_failed=1
fi

passed=0; failed=0
summary=()
for t in $TARGETS; do
    bin="$OUT/fuzz_$t"
    log="$OUT/fuzz_$t.log"
    if [ "$build_failed" -ne 0 ] ||
       ! $CXX $CPPFLAGS $TARGET_FLAGS -x c "test/fuzz/fuzz_$t.c" -x none \
             "$OUT/libradiosity_fuzz.a" $LDLIBS -o "$bin" 2> "$OUT/fuzz_$t.build.log"; then
        [ -f "$OUT/fuzz_$t.build.log" ] && cat "$OUT/fuzz_$t.build.log"
        summary+=("fuzz_$t: not built")
        failed=$((failed + 1))
        continue
    fi

    ok=1
    # Inputs that once failed: replayed as plain runs, one process for all.
    replays=0
    reg="test/fuzz/regressions/$t"
    if [ -d "$reg" ] && [ -n "$(ls -A "$reg" 2> /dev/null)" ]; then
        replays=$(ls -A "$reg" | wc -l)
        if ! "$bin" -rss_limit_mb=2048 -timeout=$TIMEOUT "$reg"/* > "$OUT/fuzz_$t.replay.log" 2>&1; then
            echo "---- fuzz_$t: a regression input fails again:"
            tail -n 40 "$OUT/fuzz_$t.replay.log"
            ok=0
        fi
    fi

    # Fuzzing on a scratch copy of the seeds.
    work=$(mktemp -d)
    if [ -d "test/fuzz/corpus/$t" ]; then
        cp -r "test/fuzz/corpus/$t/." "$work/"
    fi
    case "$t" in
        polyfile) max_len=8192 ;;
        gltf)     max_len=16384 ;;
        *)        max_len=65536 ;;
    esac
    dict=()
    [ -f "test/fuzz/$t.dict" ] && dict=("-dict=test/fuzz/$t.dict")
    # FUZZ_SEED fixes libFuzzer's random seed and the number of inputs
    # (about what SECONDS seconds run here), so that make test, which sets
    # it, tries the same inputs on every machine (a gate should not fail at
    # random; a slow machine stops at twice SECONDS, on a prefix of them);
    # make fuzz leaves it unset and explores anew for SECONDS every run.
    limit=("-max_total_time=$SECONDS_EACH")
    if [ -n "${FUZZ_SEED:-}" ]; then
        case "$t" in
            polyfile) runs=$((13000 * SECONDS_EACH)) ;;
            gltf)     runs=$((1500 * SECONDS_EACH)) ;;
            *)        runs=$((1000 * SECONDS_EACH)) ;;
        esac
        limit=("-seed=$FUZZ_SEED" "-runs=$runs" "-max_total_time=$((2 * SECONDS_EACH))")
    fi
    "$bin" "$work" "${dict[@]}" "${limit[@]}" -rss_limit_mb=2048 \
        -max_len="$max_len" -timeout=$TIMEOUT -print_final_stats=1 \
        -artifact_prefix="$OUT/artifacts/${t}-" > "$log" 2>&1
    status=$?
    rm -rf "$work"
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    execs=${execs:-0}
    if [ "$status" -ne 0 ]; then
        echo "---- fuzz_$t FAILED (exit $status); the end of its log ($log):"
        tail -n 60 "$log"
        ok=0
    fi
    if [ "$ok" -eq 1 ]; then
        passed=$((passed + 1))
        summary+=("fuzz_$t: $execs executions in ${SECONDS_EACH} s, $replays regression inputs replayed, clean")
    else
        failed=$((failed + 1))
        summary+=("fuzz_$t: $execs executions in ${SECONDS_EACH} s, $replays regression inputs replayed, FAILED")
    fi
done

printf '%s\n' "${summary[@]}"
echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
