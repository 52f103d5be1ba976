#!/usr/bin/env bash
# egl.sh - `--gl osmesa|egl|auto` (issue 38) on the command line:
#   - solve --gl egl gives the solution --gl osmesa gives: the exported
#     patches.csv, F.mtx, elements.csv and elements-F.mtx are byte for byte
#     the same (models/cornell.rad, patch size 0.25; EGL held to Mesa's
#     surfaceless llvmpipe by RADIOSITY_EGL_PLATFORM, as OSMesa, even
#     beside a GPU);
#   - with RADIOSITY_EGL_LIBRARY naming a missing file (the test hook that
#     makes EGL fail to start), solve, ff, relight and validate --gl egl
#     each fail with one line naming the library, a status below 128 and no
#     output file; --gl auto says in one line that it takes OSMesa and
#     solves;
#   - an unknown --gl value is a usage error (status 2).
# Cost: about 3 s (three small solves, four refusals).
set -u
. "$(dirname "$0")/lib.bash"

model=models/cornell.rad
solve() { "$BIN" solve "$model" --patch-size 0.25 --resolution 64 "$@"; }

# EGL held to the surfaceless platform (llvmpipe, as OSMesa) beside a GPU too
export RADIOSITY_EGL_PLATFORM=surfaceless
for gl in osmesa egl; do
    mkdir -p "$dir/$gl"
    if solve --gl "$gl" -o "$dir/$gl.sol" > /dev/null 2> "$dir/err" &&
       "$BIN" export "$dir/$gl.sol" -o "$dir/$gl" > /dev/null 2>> "$dir/err"; then
        ok "solve --gl $gl and export"
    else
        bad "solve --gl $gl: $(cat "$dir/err")"
    fi
done
for f in patches.csv F.mtx elements.csv elements-F.mtx; do
    if [ -s "$dir/osmesa/$f" ] && cmp -s "$dir/osmesa/$f" "$dir/egl/$f"; then
        ok "$f: the same bytes through OSMesa and EGL"
    else
        bad "$f differs between OSMesa and EGL (or is missing)"
    fi
done

unset RADIOSITY_EGL_PLATFORM
export RADIOSITY_EGL_LIBRARY=$dir/no-such-libEGL.so.1
# refused NAME COMMAND...: one stderr line naming the missing library, a
# non-zero status below 128, nothing written to $dir/out.*
refused() {
    local name=$1; shift
    rm -f "$dir"/out.*
    "$@" > /dev/null 2> "$dir/err"
    local rc=$?
    if [ "$rc" -ne 0 ] && [ "$rc" -lt 128 ] && [ "$(wc -l < "$dir/err")" -eq 1 ] &&
       grep -q "^radiosity: error: --gl egl: hemi-cube: cannot load $RADIOSITY_EGL_LIBRARY" "$dir/err" &&
       ! ls "$dir"/out.* > /dev/null 2>&1; then
        ok "$name --gl egl without EGL: $(cat "$dir/err")"
    else
        bad "$name --gl egl without EGL: exit $rc, stderr: $(cat "$dir/err")"
    fi
}
refused solve solve --gl egl -o "$dir/out.sol"
refused ff "$BIN" ff "$model" --gl egl
refused relight "$BIN" relight "$dir/osmesa.sol" --gl egl -o "$dir/out.sol"
refused validate "$BIN" validate --quick --gl egl

if solve --gl auto -o "$dir/auto.sol" > /dev/null 2> "$dir/err" && [ "$(wc -l < "$dir/err")" -eq 1 ] &&
   grep -q "^radiosity: --gl auto: no GPU (.*$RADIOSITY_EGL_LIBRARY.*); drawing with OSMesa$" "$dir/err" &&
   [ -s "$dir/auto.sol" ]; then
    ok "auto without EGL: solved, one line: $(cat "$dir/err")"
else
    bad "auto without EGL: $(cat "$dir/err")"
fi
unset RADIOSITY_EGL_LIBRARY

solve --gl vulkan -o "$dir/out.sol" > /dev/null 2> "$dir/err"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "^radiosity: error: --gl: 'vulkan' is not osmesa, egl or auto" "$dir/err"; then
    ok "--gl vulkan: usage error"
else
    bad "--gl vulkan: exit $rc, stderr: $(cat "$dir/err")"
fi

echo "egl.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
