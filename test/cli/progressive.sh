#!/usr/bin/env bash
# progressive.sh - issue 20 (and issue 15's items 1 and 6) from the command
# line: the shot-limit warning, previews every T seconds through a named
# camera at a given size, listed by report, a scene with a point light
# saved, the row store within --max-memory, options refused cleanly.
# Cost: about 5 s (small scenes, one worker each).
set -u
. "$(dirname "$0")/lib.bash"

# The shot limit before the tolerance: exit 0, the solution saved, exactly
# one warning line naming the limit and the unshot fraction; report says so.
if "$BIN" solve models/cornell.rad -o "$dir/limit.sol" --patch-size 0.2 --processes 1 \
      --solver progressive --max-iterations 10 > "$dir/out" 2> "$dir/err" &&
   [ "$(wc -l < "$dir/err")" -eq 1 ] &&
   grep -Eq '^radiosity: warning: models/cornell.rad: solve: progressive: the shot limit \(10\) stopped it with [0-9.e-]+ of the emitted power unshot' "$dir/err" &&
   "$BIN" report "$dir/limit.sol" | grep -q 'stopped by the shot limit'; then
    ok "shot limit: $(cat "$dir/err")"
else
    bad "shot limit: $(cat "$dir/err" "$dir/out")"
fi

# A converged solve warns nothing.
if "$BIN" solve models/cornell.rad -o "$dir/conv.sol" --patch-size 0.2 --processes 1 \
      --solver progressive > "$dir/out" 2> "$dir/err" && [ ! -s "$dir/err" ] &&
   "$BIN" report "$dir/conv.sol" | grep -Eq '^solver: progressive, [0-9]+ shots, unshot power [0-9.e-]+ of the emitted \(tolerance 0.0001\)$'; then
    ok "converged: no warning; report gives the unshot power against the tolerance"
else
    bad "converged: $(cat "$dir/err")"
fi

# Previews every 0.05 s of solving, through the camera 'main' at 40x30:
# PNGs of that size, as many as report lists.
mkdir -p "$dir/prev"
png_size() { od -An -tu1 -j16 -N8 "$1" | awk '{ print $3 * 256 + $4 "x" $7 * 256 + $8 }'; }
if "$BIN" solve models/cornell.rad -o "$dir/prev/p.sol" --patch-size 0.15 --processes 1 \
      --solver progressive --preview-every 0.05s --camera main --size 40x30 \
      --preview-dir "$dir/prev" > /dev/null 2> "$dir/err"; then
    n=$(ls "$dir/prev" | grep -c '\.png$')
    listed=$("$BIN" report "$dir/prev/p.sol" | grep -c '^  preview at ')
    first=$(ls "$dir/prev"/*.png | head -1)
    if [ "$n" -ge 1 ] && [ "$n" -eq "$listed" ] && [ "$(png_size "$first")" = "40x30" ] &&
       "$BIN" report "$dir/prev/p.sol" --json | grep -q '"previews": \[{"shots"'; then
        ok "previews every 0.05 s: $n PNGs of $(png_size "$first"), all listed by report"
    else
        bad "previews: $n PNGs, $listed listed, size $(png_size "$first")"
    fi
else
    bad "previews by seconds: $(cat "$dir/err")"
fi

# Issue 15 item 1: a scene with a point light solves progressively and saves.
cat > "$dir/bulb.rad" <<'R'
bands 1
material wall reflectance 0.6
light bulb point 0.5 0.9 0.5 intensity 1
polygon floor wall subdivide 4 4
  0 0 0   0 0 1   1 0 1   1 0 0
end
polygon back wall subdivide 4 4
  0 0 1   0 1 1   1 1 1   1 0 1
end
R
if "$BIN" solve "$dir/bulb.rad" -o "$dir/bulb.sol" --processes 1 --solver progressive \
      > "$dir/out" 2> "$dir/err" && [ -s "$dir/bulb.sol" ] && [ ! -s "$dir/err" ] &&
   "$BIN" report "$dir/bulb.sol" > /dev/null; then
    ok "point light: progressive solve saved ($(head -1 "$dir/out"))"
else
    bad "point light: $(cat "$dir/err")"
fi

# The row store: under 24 KiB Gauss-Seidel refuses, advising the
# progressive solver, which then drops and recomputes rows (the estimate
# printed first, as for Gauss-Seidel); report counts them.
"$BIN" solve models/cornell.rad -o "$dir/gs.sol" --patch-size 0.15 --processes 1 \
    --max-memory 24K > /dev/null 2> "$dir/err"
if [ $? -eq 2 ] && grep -q 'more than the 24.0 KiB allowed; use --patch-size .*, or --solver progressive' "$dir/err" &&
   "$BIN" solve models/cornell.rad -o "$dir/small.sol" --patch-size 0.15 --processes 1 \
      --solver progressive --max-memory 24K > "$dir/out" 2> "$dir/err" &&
   head -n 1 "$dir/out" | grep -q '^estimate: .*(memory limit for form factors 24.0 KiB)' &&
   "$BIN" report "$dir/small.sol" | grep -Eq '^row store: [1-9][0-9]* rows dropped to stay within --max-memory, [1-9][0-9]* computed again'; then
    ok "row store within 24 KiB: $(grep '^row store' <("$BIN" report "$dir/small.sol"))"
else
    bad "row store: $(cat "$dir/err" "$dir/out")"
fi

# Refused cleanly: a bad cadence, camera options without previews, an
# unknown camera (at the first preview: nothing saved).
refuse() {
    local name=$1 pattern=$2; shift 2
    rm -f "$dir/r.sol"
    "$BIN" "$@" > /dev/null 2> "$dir/err"
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l < "$dir/err")" -eq 1 ] && grep -Eq -- "$pattern" "$dir/err" &&
       [ ! -e "$dir/r.sol" ]; then
        ok "$name: $(cat "$dir/err")"
    else
        bad "$name: exit $rc: $(cat "$dir/err")"
    fi
}
refuse "cadence 2x" "--preview-every: '2x' is not K shots" solve models/cornell.rad -o "$dir/r.sol" --solver progressive --preview-every 2x
refuse "cadence 0s" "--preview-every: '0s' is not K shots" solve models/cornell.rad -o "$dir/r.sol" --solver progressive --preview-every 0s
refuse "camera without previews" "camera options are for previews" solve models/cornell.rad -o "$dir/r.sol" --camera main
refuse "unknown camera" "camera 'nope' not found" solve models/cornell.rad -o "$dir/r.sol" --patch-size 0.2 --processes 1 --solver progressive --preview-every 5 --camera nope --preview-dir "$dir/prev"

echo "progressive.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
