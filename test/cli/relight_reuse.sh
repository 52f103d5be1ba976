#!/usr/bin/env bash
# relight_reuse.sh - `relight` reuses the stored form factors, shown without
# the program's own counters ("0 hemi-cube rows computed" and the report's
# rows_computed, which relight.sh checks, are the program's word for it):
#   - the relit file holds no MATRIX but a MATRIXREF to the base file's
#     (docs/solution-format.md), through relit.sol.matrix, whose MATRIX is the
#     base file's byte for byte; MESH is the base's too; PATCHDATA, which the
#     relight must change, differs;
#   - no hemi-cube engine is ever started: every command runs with
#     MESA_GL_VERSION_OVERRIDE=2.1, under which Mesa cannot give a hemi-cube
#     worker the GL 4.5 context it asks for, so any form-factor row, element
#     hemi-cube or light item buffer would fail the command.  A control solve
#     under the same variable must fail that way, or the evidence proves
#     nothing.
# The base scene is the Cornell box at 0.2 m patches with one split of
# elements and a punctual light, so that patch rows, element rows and a
# light's stored power all have to be reused.
set -u
cd "$(dirname "$0")/../.."
. test/cli/lib.bash
NOGL="MESA_GL_VERSION_OVERRIDE=2.1"

{ cat models/cornell.rad; echo "light bulb point 0.28 0.4 0.28 intensity 0.05"; } > "$dir/scene.rad"
"$BIN" solve "$dir/scene.rad" -o "$dir/base.sol" --patch-size 0.2 --element-levels 1 \
    > /dev/null 2>&1 || { echo "cannot solve the base scene"; exit 1; }

# Control: the variable does stop the hemi-cube on this machine.
env "$NOGL" "$BIN" solve "$dir/scene.rad" -o "$dir/control.sol" --patch-size 0.2 \
    > /dev/null 2> "$dir/err"
rc=$?
if [ "$rc" -eq 1 ] && grep -q '^radiosity: error: hemi-cube: ' "$dir/err" && [ ! -e "$dir/control.sol" ]; then
    ok "control: solve under $NOGL fails: $(cat "$dir/err")"
else
    bad "control: solve under $NOGL exited $rc ($(cat "$dir/err")): the variable no longer keeps Mesa from starting a hemi-cube, so the checks below would prove nothing"
fi

# Relight under the same variable: patch light, punctual light and a
# reflectance, with elements to re-gather.
if env "$NOGL" "$BIN" relight "$dir/base.sol" -o "$dir/relit.sol" --light light=0.5 --light bulb=2 \
       --reflectance floor=0.3 > "$dir/out" 2>&1 && [ -s "$dir/relit.sol" ]; then
    ok "relight under $NOGL: $(cat "$dir/out")"
else
    bad "relight under $NOGL: $(cat "$dir/out")"
fi

# The same for a variations file, rendered.
printf 'variant dim\n  light light=0.25\nend\nvariant red_floor\n  reflectance floor=0.6,0.1,0.1\nend\n' > "$dir/v.txt"
mkdir -p "$dir/var"
if env "$NOGL" "$BIN" relight "$dir/base.sol" -o "$dir/var" --variations "$dir/v.txt" --render \
       --size 32x32 > "$dir/out" 2>&1 && [ -s "$dir/var/dim.exr" ] && [ -s "$dir/var/red_floor.png" ]; then
    ok "relight --variations --render under $NOGL"
else
    bad "relight --variations --render under $NOGL: $(cat "$dir/out")"
fi

# The stored sections: MATRIX (through the reference) and MESH byte for
# byte, PATCHDATA changed.
if [ -s "$dir/relit.sol" ]; then
    for tag in MESH PDAT; do
        section_body "$dir/base.sol" "$tag" > "$dir/base.$tag" || bad "base.sol has no $tag section"
        section_body "$dir/relit.sol" "$tag" > "$dir/relit.$tag" || bad "relit.sol has no $tag section"
    done
    section_body "$dir/base.sol" MTRX > "$dir/base.MTRX" || bad "base.sol has no MTRX section"
    section_body "$dir/relit.sol.matrix" MTRX > "$dir/relit.MTRX" || bad "relit.sol.matrix has no MTRX section"
    m=$(stat -c %s "$dir/base.MTRX")
    if [ "$m" -gt 1000 ] && cmp -s "$dir/base.MTRX" "$dir/relit.MTRX" &&
       ! section_body "$dir/relit.sol" MTRX > /dev/null && section_body "$dir/relit.sol" MREF > /dev/null; then
        ok "MATRIX section identical ($m bytes), referred to, not copied"
    else
        bad "MATRIX section: $m bytes in base, $(stat -c %s "$dir/relit.MTRX") relit, $(cmp "$dir/base.MTRX" "$dir/relit.MTRX" 2>&1)"
    fi
    if [ -s "$dir/base.MESH" ] && cmp -s "$dir/base.MESH" "$dir/relit.MESH"; then
        ok "MESH section identical ($(stat -c %s "$dir/base.MESH") bytes)"
    else
        bad "MESH section differs"
    fi
    if [ -s "$dir/base.PDAT" ] && ! cmp -s "$dir/base.PDAT" "$dir/relit.PDAT"; then
        ok "PATCHDATA section changed by the relight"
    else
        bad "PATCHDATA section unchanged or missing"
    fi
fi

echo "relight_reuse.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
