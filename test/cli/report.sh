#!/usr/bin/env bash
# report.sh - `radiosity report` says what it skipped and why (issue 6):
# back hemi-cubes only behind transmitting sheets.
set -u
. "$(dirname "$0")/lib.bash"

# a transmitting sheet solves, and the report says which back hemi-cubes it drew
room | sed 's/^material white reflectance 0.5 0.5 0.5/&\nmaterial paper reflectance 0.1 transmittance 0.5/' > "$dir/sheet.rad"
cat >> "$dir/sheet.rad" <<'S'
polygon sheet paper subdivide 2 2
  0 0.5 0   0 0.5 1   1 0.5 1   1 0.5 0
end
S
if "$BIN" solve "$dir/sheet.rad" -o "$dir/sheet.sol" > /dev/null 2>&1 &&
   "$BIN" report "$dir/sheet.sol" > "$dir/report" 2>&1 &&
   grep -q "transmission: 8 patches on the two sides of transmitting sheets, 8 back hemi-cubes" "$dir/report"; then
    passed=$((passed + 1)); echo "ok   transmitting sheet: $(grep transmission: "$dir/report")"
else
    failed=$((failed + 1)); echo "FAIL transmitting sheet: $(cat "$dir/report" 2>/dev/null)"
fi

# an opaque scene draws no back hemi-cube, and the report says why
room > "$dir/opaque.rad"
if "$BIN" solve "$dir/opaque.rad" -o "$dir/opaque.sol" > /dev/null 2>&1 &&
   "$BIN" report "$dir/opaque.sol" | grep -Eq "skipped: back hemi-cubes of all [0-9]+ patches \(no material transmits diffusely\)"; then
    passed=$((passed + 1)); echo "ok   opaque scene: no back hemi-cubes"
else
    failed=$((failed + 1)); echo "FAIL opaque scene: $("$BIN" report "$dir/opaque.sol" 2>&1 | grep -i back)"
fi

if "$BIN" report "$dir/sheet.sol" --json | grep -q '"transmission": {"sheet_patches": 8, "back_hemicubes": 8}'; then
    passed=$((passed + 1)); echo "ok   transmitting sheet: --json counts"
else
    failed=$((failed + 1)); echo "FAIL transmitting sheet: --json: $("$BIN" report "$dir/sheet.sol" --json | grep transmission)"
fi

# the patch size used is shown even when it was the default (issue 36): the
# room's bounds are the unit cube, so diagonal / 34 = sqrt(3) / 34
if "$BIN" report "$dir/opaque.sol" | grep -q "^patch size: 0.0509427 scene units" &&
   "$BIN" report "$dir/opaque.sol" --json | grep -q '"patch_size": 0.0509426708'; then
    passed=$((passed + 1)); echo "ok   default patch size shown: $("$BIN" report "$dir/opaque.sol" | grep '^patch size')"
else
    failed=$((failed + 1)); echo "FAIL default patch size: $("$BIN" report "$dir/opaque.sol" 2>&1 | grep -i 'patch')"
fi

echo "report.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
