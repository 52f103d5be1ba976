#!/usr/bin/env bash
# relight.sh - issue 3 from the command line: relight computes no hemi-cube,
# bad arguments and bad variations files are refused before any work with
# one clear line, corrupted or truncated solutions are refused cleanly and
# never damage an existing output, the matrix-size check refuses with an
# estimate, and progressive previews appear.
set -u
BIN=${RADIOSITY_BIN:-build/release/radiosity}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
passed=0; failed=0
ok()   { passed=$((passed + 1)); echo "ok   $1"; }
bad()  { failed=$((failed + 1)); echo "FAIL $1"; }

# refuse NAME PATTERN ARGS...: exit 2, one stderr line matching PATTERN, and
# the pre-existing $dir/out.sol unchanged.
refuse() {
    local name=$1 pattern=$2; shift 2
    cp "$dir/keep.sol" "$dir/out.sol"
    "$BIN" "$@" > "$dir/stdout" 2> "$dir/stderr"
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l < "$dir/stderr")" -eq 1 ] &&
       grep -q '^radiosity: error: ' "$dir/stderr" && grep -Eiq "$pattern" "$dir/stderr" &&
       cmp -s "$dir/keep.sol" "$dir/out.sol" && [ -z "$(ls "$dir" | grep '\.tmp')" ]; then
        ok "$name: $(cat "$dir/stderr")"
    else
        bad "$name: exit $rc, stderr: $(cat "$dir/stderr") (wanted /$pattern/)"
    fi
}

"$BIN" solve models/cornell.rad -o "$dir/base.sol" --patch-size 0.12 > /dev/null 2>&1 || { echo "cannot solve the base scene"; exit 1; }
"$BIN" solve models/cornell.rad -o "$dir/keep.sol" --patch-size 0.2 > /dev/null 2>&1 || exit 1

# A relight computes no hemi-cube row, and the report says the form factors were reused.
if "$BIN" relight "$dir/base.sol" -o "$dir/twice.sol" --light light=2 > "$dir/stdout" 2>&1 &&
   grep -q ' 0 hemi-cube rows computed' "$dir/stdout" &&
   "$BIN" report "$dir/twice.sol" --json | grep -q '"rows_computed": 0' &&
   "$BIN" report "$dir/twice.sol" --json | grep -q '"form_factors": true'; then
    ok "relight computes 0 rows and reports the form factors reused"
else
    bad "relight row count / reuse: $(cat "$dir/stdout")"
fi
# The light scaled by 2 doubles the emitted power in the report.
e1=$("$BIN" report "$dir/base.sol" --json | grep -o '"total": {"emitted": \[[^,]*' | grep -o '[0-9.e+-]*$')
e2=$("$BIN" report "$dir/twice.sol" --json | grep -o '"total": {"emitted": \[[^,]*' | grep -o '[0-9.e+-]*$')
if awk -v a="$e1" -v b="$e2" 'BEGIN { exit !(a > 0 && (b / a - 2) < 1e-9 && (b / a - 2) > -1e-9) }'; then
    ok "light=2 doubles the emitted power ($e1 -> $e2)"
else
    bad "light=2 emitted power $e1 -> $e2"
fi

refuse "unknown name" "no object or material.*candidates" relight "$dir/base.sol" -o "$dir/out.sol" --light lamp=off
refuse "ambiguous prefix" "ambiguous.*candidates" relight "$dir/base.sol" -o "$dir/out.sol" --reflectance l=0.5
refuse "light on a non-emitter" "emits nothing" relight "$dir/base.sol" -o "$dir/out.sol" --light floor=off
refuse "malformed light value" "off, on or a non-negative scale" relight "$dir/base.sol" -o "$dir/out.sol" --light light=bright
refuse "missing =" "NAME=" relight "$dir/base.sol" -o "$dir/out.sol" --emission light
refuse "negative emission" "negative" relight "$dir/base.sol" -o "$dir/out.sol" --emission light=1,-2,3
refuse "reflectance 1" "outside \[0, 1\)" relight "$dir/base.sol" -o "$dir/out.sol" --reflectance floor=1
refuse "wrong band count" "values given.*3 bands" relight "$dir/base.sol" -o "$dir/out.sol" --reflectance floor=0.1,0.2
refuse "nothing to change" "nothing to change" relight "$dir/base.sol" -o "$dir/out.sol"

mkdir -p "$dir/var"
printf 'variant a\n  light light=0.5\nend\nvariant b\n  reflectance flor=0.2\nend\n' > "$dir/v1.txt"
refuse "variations: unknown name in variant b" "variant 'b'.*flor" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/v1.txt"
[ -z "$(ls "$dir/var")" ] && ok "variations: nothing written when one variant is bad" || bad "variations wrote files: $(ls "$dir/var")"
printf 'variant a\n  light light=0.5\n' > "$dir/v2.txt"
refuse "variations: missing end" "no 'end'" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/v2.txt"
printf 'variant a\n  colour light=0.5\nend\n' > "$dir/v3.txt"
refuse "variations: unknown statement" "line 2: unknown statement" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/v3.txt"

# A good variations file: one solution per variant, no hemi-cube rows.
printf '# two schemes\nvariant dim\n  light light=0.25\nend\nvariant red_floor\n  reflectance floor=0.6,0.1,0.1\nend\n' > "$dir/good.txt"
if "$BIN" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/good.txt" > "$dir/stdout" 2>&1 &&
   [ -s "$dir/var/dim.sol" ] && [ -s "$dir/var/red_floor.sol" ] &&
   [ "$(grep -c ' 0 hemi-cube rows computed' "$dir/stdout")" -eq 2 ]; then
    ok "variations: one solution per variant, 0 rows each"
else
    bad "variations run: $(cat "$dir/stdout")"
fi
if "$BIN" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/good.txt" --render --size 64x64 > /dev/null 2>&1 &&
   [ -s "$dir/var/dim.exr" ] && [ -s "$dir/var/red_floor.png" ]; then
    ok "variations --render writes one image per variant"
else
    bad "variations --render"
fi

# Truncated and corrupted solutions: refused with exit 2, never a crash, the
# existing output untouched.  The flipped bytes are relit with --resolve,
# which reads every section: a relight by superposition reads no byte of F
# (parts.sh shows it relights a damaged F, and --reflectance refusing it).
size=$(stat -c %s "$dir/base.sol")
for cut in 0 1 7 8 31 32 33 100 1000 $((size / 3)) $((size / 2)) $((size - 1)); do
    head -c "$cut" "$dir/base.sol" > "$dir/cut.sol"
    refuse "truncated at $cut of $size bytes" "truncated|not a radiosity|corrupt|checksum" relight "$dir/cut.sol" -o "$dir/out.sol" --light light=2
done
for at in 0 9 20 40 200 $((size / 2)) $((size - 1)); do
    cp "$dir/base.sol" "$dir/flip.sol"
    printf "$(printf '\\x%02x' $(( ( $(od -An -tu1 -j "$at" -N1 "$dir/base.sol") ^ 255 ) )))" |
        dd of="$dir/flip.sol" bs=1 seek="$at" conv=notrunc 2> /dev/null
    refuse "byte $at flipped" "checksum|corrupt|not a radiosity|version|reserved|truncated" relight "$dir/flip.sol" -o "$dir/out.sol" --light light=2 --resolve
done

# Memory honesty: a limit below the matrix's estimate is refused with the estimate.
refuse "matrix over --max-memory" "need about [0-9.]+ (KiB|MiB).*1.0 MiB allowed.*--patch-size [0-9.]+" solve models/cornell.rad -o "$dir/out.sol" --patch-size 0.05 --max-memory 1M

# Progressive previews appear every K shots.
mkdir -p "$dir/prev"
if "$BIN" solve models/cornell.rad -o "$dir/prev/p.sol" --patch-size 0.12 --solver progressive \
      --preview-every 20 --preview-dir "$dir/prev" > /dev/null 2>&1 &&
   [ -s "$dir/prev/preview-000020.png" ] && [ -s "$dir/prev/preview-000040.exr" ]; then
    ok "progressive previews every 20 shots ($(ls "$dir/prev" | grep -c png) PNGs)"
else
    bad "progressive previews: $(ls "$dir/prev")"
fi

echo "relight.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
