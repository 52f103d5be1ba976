#!/usr/bin/env bash
# parts.sh - issue 21 from the command line: the solution file in parts.
# render and report never read F, so a damaged MATRIX section leaves them
# whole; so does a relight that only scales the one light (by superposition
# of the stored light response: exactly 2 B for light=2), while a relight
# that needs F (--reflectance) refuses it naming the section; a relight shares its
# base's matrix (a hard link OUT.matrix, or the base's path where no link
# can be made) instead of copying it, stays right when the base is moved or
# solved again, and fails clearly - never silently - when the matrix it
# shares is removed or altered.  The same for the elements' rows
# (ELEMENTROWS): render, render --gather and report never read them.
# Cost: ~3 s (small Cornell boxes).
set -u
. "$(dirname "$0")/lib.bash"

flip_byte() { # FILE OFFSET: inverts one byte in place (the file keeps its inode)
    python3 -c "
import sys
f = open(sys.argv[1], 'r+b'); f.seek(int(sys.argv[2])); b = f.read(1)
f.seek(int(sys.argv[2])); f.write(bytes([b[0] ^ 0xFF])); f.close()" "$1" "$2"
}
inode() { stat -c %i "$1"; }
# report without the stage times and the provenance that differs by run
numbers() { "$BIN" report "$1" --json | sed -e 's/"stages": {.*//' -e 's/"solution": "[^"]*"//'; }

"$BIN" solve models/cornell.rad -o "$dir/base.sol" --patch-size 0.1 > /dev/null 2>&1 ||
    { echo "cannot solve the base scene"; exit 1; }
"$BIN" render "$dir/base.sol" -o "$dir/base.exr" --size 64x64 > /dev/null 2>&1 || exit 1

# A damaged MATRIX: render and report do not notice (same image, same
# numbers), nor does a relight by superposition (one light group: its
# response is the solution itself, so light=2 is exactly 2 B and reads no
# byte of F); a relight that needs F refuses naming the section.  (Before
# the stored responses, any relight of a damaged F failed.)
cp "$dir/base.sol" "$dir/damaged.sol"
read -r m mlen < <(section_at "$dir/damaged.sol" MTRX)
flip_byte "$dir/damaged.sol" $((m + mlen / 2))
if "$BIN" render "$dir/damaged.sol" -o "$dir/damaged.exr" --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/base.exr" "$dir/damaged.exr" &&
   [ "$(numbers "$dir/damaged.sol")" = "$(numbers "$dir/base.sol")" ]; then
    ok "render and report of a solution whose MATRIX is damaged: identical"
else
    bad "render or report of a damaged MATRIX differs or fails"
fi
"$BIN" relight "$dir/damaged.sol" -o "$dir/x2.sol" --light light=2 > "$dir/stdout" 2> "$dir/stderr"
rc=$?
# every patch's and element's B exactly twice the base's (relative 1e-12)
twice() { # BASE RELIT
    rm -rf "$dir/ea" "$dir/eb"; mkdir -p "$dir/ea" "$dir/eb"
    "$BIN" export "$1" -o "$dir/ea" > /dev/null && "$BIN" export "$2" -o "$dir/eb" > /dev/null &&
    python3 - "$dir/ea" "$dir/eb" <<'P'
import csv, sys
worst = 0.0
for f in ('patches.csv', 'elements.csv'):
    a = list(csv.DictReader(open(sys.argv[1] + '/' + f)))
    b = list(csv.DictReader(open(sys.argv[2] + '/' + f)))
    assert len(a) == len(b) > 0
    for ra, rb in zip(a, b):
        for k in ('B_R', 'B_G', 'B_B'):
            x, y = 2 * float(ra[k]), float(rb[k])
            worst = max(worst, abs(x - y) / max(abs(x), 1e-300))
print('%.3g' % worst)
sys.exit(0 if worst <= 1e-12 else 1)
P
}
# export needs F, which x2.sol shares damaged: the same relight of the
# intact base gives the numbers, and x2.sol's PATCHDATA and ELEMENTS must be
# its byte for byte.
"$BIN" relight "$dir/base.sol" -o "$dir/x3.sol" --light light=2 > /dev/null 2>&1
same_section() { # A B TAG
    section_body "$1" "$3" > "$dir/sa" && section_body "$2" "$3" > "$dir/sb" && [ -s "$dir/sa" ] &&
        cmp -s "$dir/sa" "$dir/sb"
}
if [ "$rc" -eq 0 ] && grep -q "relit by superposition of 1 stored light response (form factors not read)" "$dir/stdout" &&
   same_section "$dir/x2.sol" "$dir/x3.sol" PDAT && same_section "$dir/x2.sol" "$dir/x3.sol" ELEM &&
   worst=$(twice "$dir/base.sol" "$dir/x3.sol"); then
    ok "relight --light light=2 of it by superposition: exactly 2 B (worst relative difference $worst): $(cat "$dir/stdout" | tail -n 1)"
else
    bad "superposed relight of a damaged MATRIX: exit $rc, $(cat "$dir/stdout" "$dir/stderr"), 2 B: ${worst:-?}"
fi
"$BIN" relight "$dir/damaged.sol" -o "$dir/x.sol" --reflectance floor=0.3 > /dev/null 2> "$dir/stderr"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "damaged.sol: section MATRIX: checksum mismatch" "$dir/stderr" &&
   [ ! -e "$dir/x.sol" ]; then
    ok "relight --reflectance of it: $(cat "$dir/stderr")"
else
    bad "relight --reflectance of a damaged MATRIX: exit $rc, $(cat "$dir/stderr")"
fi
# a damaged section that render needs is refused by render, named
read -r p plen < <(section_at "$dir/base.sol" PDAT)
cp "$dir/base.sol" "$dir/pdat.sol"
flip_byte "$dir/pdat.sol" $((p + plen / 2))
if ! "$BIN" render "$dir/pdat.sol" -o "$dir/p.exr" > /dev/null 2> "$dir/stderr" &&
   grep -q "pdat.sol: section PATCHDATA: checksum mismatch" "$dir/stderr"; then
    ok "render of a damaged PATCHDATA: $(cat "$dir/stderr")"
else
    bad "render of a damaged PATCHDATA: $(cat "$dir/stderr")"
fi

# A damaged ELEMENTROWS (the elements' row entries F_ej, format version 7):
# render, with and without --gather, and report never read it (same images,
# same numbers); what needs the rows refuses it naming the section: export,
# and relight (every relight writes them again, and --reflectance gathers
# the elements through them).
read -r r rlen < <(section_at "$dir/base.sol" ELRW)
cp "$dir/base.sol" "$dir/erows.sol"
[ -n "${rlen:-}" ] && flip_byte "$dir/erows.sol" $((r + rlen / 2))
gather() { "$BIN" render "$1" -o "$2" --size 24x24 --gather --no-cache-file > /dev/null 2>&1; }
if [ -n "${rlen:-}" ] &&
   "$BIN" render "$dir/erows.sol" -o "$dir/erows.exr" --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/base.exr" "$dir/erows.exr" &&
   [ "$(numbers "$dir/erows.sol")" = "$(numbers "$dir/base.sol")" ] &&
   gather "$dir/base.sol" "$dir/base-g.exr" && gather "$dir/erows.sol" "$dir/erows-g.exr" &&
   cmp -s "$dir/base-g.exr" "$dir/erows-g.exr"; then
    ok "render, render --gather and report of a solution whose ELEMENTROWS is damaged: identical"
else
    bad "render, render --gather or report of a damaged ELEMENTROWS differs or fails (ELRW: ${rlen:-none})"
fi
for cmd in "export -o $dir/ex-erows" "relight -o $dir/e1.sol --reflectance floor=0.3" \
           "relight -o $dir/e2.sol --light light=2"; do
    mkdir -p "$dir/ex-erows"
    read -r verb rest <<< "$cmd"
    # shellcheck disable=SC2086
    "$BIN" $verb "$dir/erows.sol" $rest > /dev/null 2> "$dir/stderr"
    rc=$?
    if [ "$rc" -eq 2 ] && grep -q "erows.sol: section ELEMENTROWS: checksum mismatch" "$dir/stderr" &&
       [ ! -e "$dir/e1.sol" ] && [ ! -e "$dir/e2.sol" ] && [ -z "$(ls "$dir/ex-erows")" ]; then
        ok "$verb ${rest#-o * } of it: $(cat "$dir/stderr")"
    else
        bad "$verb of a damaged ELEMENTROWS: exit $rc, $(cat "$dir/stderr")"
    fi
done

# A relight shares the matrix: a hard link, no copy; the output is smaller
# than the base by about its MATRIX (the elements, on by default, and their
# rows are the relit file's own).
mkdir -p "$dir/lit"
read -r _ mlen < <(section_at "$dir/base.sol" MTRX)
if "$BIN" relight "$dir/base.sol" -o "$dir/lit/lit.sol" --light light=2 > "$dir/stdout" 2>&1 &&
   grep -q "form factors shared with .*lit.sol.matrix (a hard link, no copy)" "$dir/stdout" &&
   [ "$(inode "$dir/lit/lit.sol.matrix")" = "$(inode "$dir/base.sol")" ] &&
   [ $(( $(stat -c %s "$dir/lit/lit.sol") + mlen / 2 )) -lt "$(stat -c %s "$dir/base.sol")" ]; then
    ok "relight shares F: $(grep shared "$dir/stdout")"
else
    bad "relight sharing: $(cat "$dir/stdout")"
fi
"$BIN" render "$dir/lit/lit.sol" -o "$dir/lit.exr" --size 64x64 > /dev/null 2>&1
"$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/back.sol" --light light=0.5 > /dev/null 2>&1
"$BIN" render "$dir/lit/back.sol" -o "$dir/back.exr" --size 64x64 > /dev/null 2>&1
lit_numbers=$(numbers "$dir/lit/lit.sol")

# The base moved away, then solved again with other options at its old
# place: the relit solution keeps its own link, its answer is unchanged.
mkdir -p "$dir/elsewhere"
mv "$dir/base.sol" "$dir/elsewhere/base.sol"
"$BIN" solve models/cornell.rad -o "$dir/base.sol" --patch-size 0.2 > /dev/null 2>&1
if "$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/again.sol" --light light=0.5 > /dev/null 2>&1 &&
   "$BIN" render "$dir/lit/again.sol" -o "$dir/again.exr" --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/back.exr" "$dir/again.exr"; then
    ok "after the base moved and was solved again, relight of the relit solution is unchanged"
else
    bad "relight after the base moved"
fi

# Its matrix altered in place (the base's bytes, one inode): a clear error
# for a relight that reads F (--resolve).
read -r m mlen < <(section_at "$dir/elsewhere/base.sol" MTRX)
flip_byte "$dir/elsewhere/base.sol" $((m + 100))
"$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/y.sol" --light light=3 --resolve > /dev/null 2> "$dir/stderr"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "lit.sol.matrix: section MATRIX: checksum mismatch" "$dir/stderr" &&
   "$BIN" render "$dir/lit/lit.sol" -o "$dir/lit2.exr" --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/lit.exr" "$dir/lit2.exr"; then
    ok "shared matrix altered: render unchanged, relight: $(cat "$dir/stderr")"
else
    bad "shared matrix altered: exit $rc, $(cat "$dir/stderr")"
fi
flip_byte "$dir/elsewhere/base.sol" $((m + 100))

# Its matrix removed: render and report still work, relight says what is gone.
# (The reference falls back on the base's path when it was written: the
# base solved again there is another matrix, which is refused as changed.)
"$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/y.sol" --light light=3 > /dev/null 2>&1
rm "$dir/lit/lit.sol.matrix"
"$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/y.sol" --light light=3 > /dev/null 2> "$dir/stderr"
if [ $? -eq 2 ] && grep -q "base.sol has changed since this solution was written" "$dir/stderr"; then
    ok "shared link removed, the base's path holds another matrix: $(cat "$dir/stderr")"
else
    bad "shared link removed, another base: $(cat "$dir/stderr")"
fi
rm "$dir/elsewhere/base.sol" "$dir/base.sol"
"$BIN" relight "$dir/lit/lit.sol" -o "$dir/lit/y.sol" --light light=3 > /dev/null 2> "$dir/stderr"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "section MATRIXREF: the matrix it shares is gone: cannot open .*lit.sol.matrix (nor .*base.sol): No such file" "$dir/stderr" &&
   [ "$(numbers "$dir/lit/lit.sol")" = "$lit_numbers" ] &&
   "$BIN" render "$dir/lit/lit.sol" -o "$dir/lit3.exr" --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/lit.exr" "$dir/lit3.exr"; then
    ok "shared matrix removed: render and report unchanged, relight: $(cat "$dir/stderr")"
else
    bad "shared matrix removed: exit $rc, $(cat "$dir/stderr")"
fi

# Where no hard link can be made (here: OUT.matrix is a directory), the
# reference names the base by its path; changing the base is then an error.
"$BIN" solve models/cornell.rad -o "$dir/b2.sol" --patch-size 0.2 > /dev/null 2>&1
mkdir -p "$dir/nolink.sol.matrix/blocker"
if "$BIN" relight "$dir/b2.sol" -o "$dir/nolink.sol" --light light=2 > "$dir/stdout" 2>&1 &&
   grep -q "shared with .*b2.sol (by path)" "$dir/stdout" &&
   "$BIN" relight "$dir/nolink.sol" -o "$dir/n2.sol" --light light=0.5 > /dev/null 2>&1; then
    ok "no hard link: $(grep shared "$dir/stdout")"
else
    bad "no hard link: $(cat "$dir/stdout")"
fi
"$BIN" solve models/cornell.rad -o "$dir/b2.sol" --patch-size 0.2 --resolution 64 > /dev/null 2>&1
"$BIN" relight "$dir/nolink.sol" -o "$dir/n3.sol" --light light=0.5 > /dev/null 2> "$dir/stderr"
rc=$?
if [ "$rc" -eq 2 ] && grep -q "b2.sol has changed since this solution was written" "$dir/stderr"; then
    ok "base solved again under a by-path reference: $(cat "$dir/stderr")"
else
    bad "base solved again under a by-path reference: exit $rc, $(cat "$dir/stderr")"
fi
rm "$dir/b2.sol"
"$BIN" relight "$dir/nolink.sol" -o "$dir/n3.sol" --light light=0.5 > /dev/null 2> "$dir/stderr"
if [ $? -eq 2 ] && grep -q "the matrix it shares is gone: cannot open .*b2.sol: No such file" "$dir/stderr"; then
    ok "base removed under a by-path reference: $(cat "$dir/stderr")"
else
    bad "base removed under a by-path reference: $(cat "$dir/stderr")"
fi

# relight --variations reads F once and every variant shares it.
printf 'variant dim\n  light light=0.5\nend\nvariant off\n  reflectance white=0.2\nend\n' > "$dir/v.txt"
mkdir -p "$dir/vars"
"$BIN" solve models/cornell.rad -o "$dir/b3.sol" --patch-size 0.2 > /dev/null 2>&1
if "$BIN" relight "$dir/b3.sol" -o "$dir/vars" --variations "$dir/v.txt" > "$dir/stdout" 2>&1 &&
   [ "$(grep -c 'a hard link, no copy' "$dir/stdout")" -eq 2 ] &&
   [ "$(inode "$dir/vars/dim.sol.matrix")" = "$(inode "$dir/b3.sol")" ] &&
   [ "$(inode "$dir/vars/off.sol.matrix")" = "$(inode "$dir/b3.sol")" ]; then
    ok "relight --variations: both variants share the base's F"
else
    bad "relight --variations sharing: $(cat "$dir/stdout")"
fi

echo "parts.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
