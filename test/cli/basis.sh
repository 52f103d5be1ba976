#!/usr/bin/env bash
# basis.sh - issue 21: relight by superposition of the stored light
# responses (solution.h, rad_basis).  The Cornell box with a second emitting
# object ("other") and a point light ("bulb"), elements on: three light
# groups, solved once.  Then:
#   - a relight that only scales the groups (light=2, bulb=0.5, other=off)
#     takes the superposition path, and agrees with the same relight under
#     --resolve (F read, Gauss-Seidel again) in every patch's and element's
#     B and in the report's per-object numbers, within a few times the
#     solve tolerance relative to max B;
#   - a reflectance edit, an emission given to an object that emitted
#     nothing, and a point light turned on that was dark when solved each
#     take the full path and say why;
#   - the relit file carries the base's BASIS section unchanged, and a
#     relight of it superposes again;
#   - --variations chooses per variant, and a variant that re-solves
#     leaves the base's responses to the next.
# Cost: ~3 s (a 0.15 m Cornell box, one split of elements).
set -u
. "$(dirname "$0")/lib.bash"

{ cat models/cornell.rad; cat <<'R'
material glow reflectance 0 emission 3 2 1
polygon other glow
    0.35 0.10 0.558
    0.20 0.10 0.558
    0.20 0.25 0.558
    0.35 0.25 0.558
end
light bulb point 0.28 0.4 0.28 intensity 0.05
R
} > "$dir/k3.rad"
"$BIN" solve "$dir/k3.rad" -o "$dir/base.sol" --patch-size 0.15 --element-levels 1 > /dev/null 2>&1 ||
    { echo "cannot solve the base scene"; exit 1; }

# The groups the file holds: BASIS's head is u32 groups, patches, bands,
# lights, elements.
head=$(section_body "$dir/base.sol" BASI | od -An -tu4 -N20 | xargs)
set -- $head
if [ "${1:-0}" -eq 3 ] && [ "${4:-0}" -eq 1 ] && [ "${5:-0}" -gt "${2:-0}" ]; then
    ok "BASIS holds 3 light groups ($2 patches, $3 bands, $4 light, $5 elements)"
else
    bad "BASIS head: '$head'"
fi

# Superposition against the full re-solve.
edits=(--light light=2 --light bulb=0.5 --light other=off)
"$BIN" relight "$dir/base.sol" -o "$dir/sup.sol" "${edits[@]}" > "$dir/sup.out" 2>&1
rc1=$?
"$BIN" relight "$dir/base.sol" -o "$dir/res.sol" "${edits[@]}" --resolve > "$dir/res.out" 2>&1
rc2=$?
if [ "$rc1" -eq 0 ] && grep -q "relit by superposition of 3 stored light responses (form factors not read)" "$dir/sup.out" &&
   [ "$rc2" -eq 0 ] && grep -q "re-solved with the stored form factors: --resolve" "$dir/res.out"; then
    ok "superposition and --resolve: $(tail -n 1 "$dir/sup.out" | sed 's/.*relit with/relit with/')"
else
    bad "relights: $rc1 $(cat "$dir/sup.out"); $rc2 $(cat "$dir/res.out")"
fi
mkdir -p "$dir/es" "$dir/er"
"$BIN" export "$dir/sup.sol" -o "$dir/es" > /dev/null 2>&1
"$BIN" export "$dir/res.sol" -o "$dir/er" > /dev/null 2>&1
"$BIN" report "$dir/sup.sol" --json > "$dir/sup.json" 2> /dev/null
"$BIN" report "$dir/res.sol" --json > "$dir/res.json" 2> /dev/null
# Tolerance 1e-4 (the solve's): the differences are measured at 7.1e-7
# (patches) and 3.5e-7 (elements) of max B, and at most 5.9e-6 (absorbed)
# of each per-object quantity's largest value; bound 5e-4 (5 x the tolerance), which a wrong
# factor or a group left out exceeds by orders of magnitude.
if out=$(python3 - "$dir" <<'P'
import csv, json, sys
d = sys.argv[1]
def values(path):
    return [[float(r[k]) for k in ('B_R', 'B_G', 'B_B')] for r in csv.DictReader(open(path))]
msg, good = [], True
for f in ('patches.csv', 'elements.csv'):
    a, b = values(d + '/es/' + f), values(d + '/er/' + f)
    top = max(max(r) for r in b)
    worst = max(abs(x - y) for ra, rb in zip(a, b) for x, y in zip(ra, rb)) / top
    good &= len(a) == len(b) > 0 and worst <= 5e-4
    msg.append('%s %.2g' % (f, worst))
s, r = json.load(open(d + '/sup.json')), json.load(open(d + '/res.json'))
for key in ('radiosity', 'emitted', 'absorbed'):
    top = max(max(o[key]) for o in r['objects'])
    worst = max(abs(x - y) for a, b in zip(s['objects'], r['objects'])
                for x, y in zip(a[key], b[key])) / top
    good &= worst <= 5e-4
    msg.append('%s %.2g' % (key, worst))
print(', '.join(msg))
sys.exit(0 if good else 1)
P
); then
    ok "superposition = re-solve within 5e-4 of max B: $out"
else
    bad "superposition against re-solve: $out"
fi

# Fallbacks: each says why.
fallback() { # WHAT WHY ARGS...
    local what=$1 why=$2; shift 2
    "$BIN" relight "$dir/base.sol" -o "$dir/fb.sol" "$@" > "$dir/fb.out" 2>&1
    local rc=$?
    if [ "$rc" -eq 0 ] && grep -q "re-solved with the stored form factors: $why" "$dir/fb.out"; then
        ok "$what: $(grep -o 're-solved.*;' "$dir/fb.out")"
    else
        bad "$what: exit $rc, $(cat "$dir/fb.out")"
    fi
}
fallback "a reflectance edit" "reflectance changed" --reflectance floor=0.3 --light light=2
fallback "emission on an object that emitted nothing" "'floor' (material 'white') emits, but emitted nothing when solved" --emission floor=1
# A new colour for an emitter is a scaling per band (one c per group and
# band): superposed too.
"$BIN" relight "$dir/base.sol" -o "$dir/col.sol" --emission other=1,1,1 > "$dir/col.out" 2>&1
if [ $? -eq 0 ] && grep -q "relit by superposition of 3" "$dir/col.out"; then
    ok "a new colour for 'other' (per-band factors 1/3, 1/2, 1) superposes"
else
    bad "a new colour: $(cat "$dir/col.out")"
fi
{ cat "$dir/k3.rad"; echo "light dark point 0.1 0.3 0.1 intensity 0"; } > "$dir/dark.rad"
"$BIN" solve "$dir/dark.rad" -o "$dir/dark.sol" --patch-size 0.3 --element-levels 0 > /dev/null 2>&1
"$BIN" relight "$dir/dark.sol" -o "$dir/fb.sol" --emission dark=0.05 > "$dir/fb.out" 2>&1
if [ $? -eq 0 ] && grep -q "re-solved with the stored form factors: light 'dark' shines, but was dark when solved" "$dir/fb.out"; then
    ok "a point light turned on: $(grep -o 're-solved.*;' "$dir/fb.out")"
else
    bad "a point light turned on: $(cat "$dir/fb.out")"
fi

# The relit file carries the base's BASIS unchanged (it still describes the
# sources solved with), and relights again by superposition: every light
# back at nominal gives Σ_g B^(g), the base's B within the tolerance
# (measured 2.9e-6 of max B; bound 5e-4 as above).
"$BIN" relight "$dir/sup.sol" -o "$dir/again.sol" --light light=1 --light bulb=1 --light other=1 > "$dir/again.out" 2>&1
mkdir -p "$dir/eb" "$dir/ea"
"$BIN" export "$dir/base.sol" -o "$dir/eb" > /dev/null 2>&1
"$BIN" export "$dir/again.sol" -o "$dir/ea" > /dev/null 2>&1
if cmp -s <(section_body "$dir/base.sol" BASI) <(section_body "$dir/sup.sol" BASI) &&
   grep -q "relit by superposition of 3" "$dir/again.out" &&
   worst=$(python3 - "$dir" <<'P'
import csv, sys
d = sys.argv[1]
def values(path):
    return [[float(r[k]) for k in ('B_R', 'B_G', 'B_B')] for r in csv.DictReader(open(path))]
a, b = values(d + '/ea/patches.csv'), values(d + '/eb/patches.csv')
top = max(max(r) for r in b)
worst = max(abs(x - y) for ra, rb in zip(a, b) for x, y in zip(ra, rb)) / top
print('%.2g' % worst)
sys.exit(0 if len(a) == len(b) > 0 and worst <= 5e-4 else 1)
P
); then
    ok "BASIS carried over unchanged; back at nominal by superposition: the base's B within $worst of max B"
else
    bad "BASIS carried over: $(cat "$dir/again.out") ${worst:-}"
fi

# --variations: the choice per variant; the base's responses survive a
# variant that re-solves (which stores its own, for its new ρ).
printf 'variant a\n  light light=0.5\nend\nvariant b\n  reflectance floor=0.2\nend\nvariant c\n  light bulb=3\nend\n' > "$dir/v.txt"
mkdir -p "$dir/vo"
"$BIN" relight "$dir/base.sol" -o "$dir/vo" --variations "$dir/v.txt" > "$dir/v.out" 2>&1
if grep -q "variant 'a', relit by superposition of 3" "$dir/v.out" &&
   grep -q "variant 'b', re-solved with the stored form factors: reflectance changed" "$dir/v.out" &&
   grep -q "variant 'c', relit by superposition of 3" "$dir/v.out" &&
   cmp -s <(section_body "$dir/base.sol" BASI) <(section_body "$dir/vo/c.sol" BASI) &&
   section_body "$dir/vo/b.sol" BASI > "$dir/b.basi" &&
   ! cmp -s <(section_body "$dir/base.sol" BASI) "$dir/b.basi"; then
    ok "variations: superposed, re-solved (its own responses), superposed again"
else
    bad "variations: $(cat "$dir/v.out")"
fi

echo "basis.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
