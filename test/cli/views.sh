#!/usr/bin/env bash
# views.sh - issue 21 from the command line: `render` with many views writes
# one image per camera or path line, each the very file a single-view render
# of that camera writes; bad views and clashes are refused before anything
# is written; `export` writes its files; both make a missing -o DIR as
# `mkdir -p` does (issue 37), and only once their input is known good.
# Cost: one solve of the small room (~0.2 s) and a dozen 64×64 renders.
set -u
. "$(dirname "$0")/lib.bash"

# refuse NAME PATTERN ARGS...: exit 2, one line matching PATTERN, and
# nothing written into $dir/out.
refuse() {
    local name=$1 pattern=$2; shift 2
    rm -rf "$dir/out"; mkdir "$dir/out"
    "$BIN" "$@" > "$dir/stdout" 2> "$dir/stderr"
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l < "$dir/stderr")" -eq 1 ] &&
       grep -Eq "^radiosity: error: .*$pattern" "$dir/stderr" && [ -z "$(ls "$dir/out")" ]; then
        ok "$name: $(cat "$dir/stderr")"
    else
        bad "$name: exit $rc, stderr: $(cat "$dir/stderr"), out: $(ls "$dir/out") (wanted /$pattern/)"
    fi
}

{ room; cat <<'C'
camera front eye 0.5 0.5 -1.5 target 0.5 0.4 0.5 up 0 1 0 fov 50
camera "side" eye 1.6 0.6 0.5 target 0.5 0.3 0.5 up 0 1 0 fov 50
camera low/left eye 0.1 0.2 -1 target 0.5 0.3 0.5 up 0 1 0 fov 60
C
} | sed 's/"side"/side/' > "$dir/room.rad"
"$BIN" solve "$dir/room.rad" -o "$dir/room.sol" --refine-threshold 0 > /dev/null 2>&1 || { echo "cannot solve the room"; exit 1; }

# --all-cameras: one EXR and one PNG per camera, named after it ('/' -> '_'),
# each identical to what a single-view render of that camera writes.
mkdir "$dir/all"
if "$BIN" render "$dir/room.sol" -o "$dir/all" --all-cameras --size 64x64 > "$dir/stdout" 2>&1 &&
   [ "$(ls "$dir/all" | tr '\n' ' ')" = "front.exr front.png low_left.exr low_left.png side.exr side.png " ]; then
    ok "--all-cameras: $(cat "$dir/stdout")"
else
    bad "--all-cameras: $(cat "$dir/stdout"); files: $(ls "$dir/all")"
fi
same=0
for c in front side low/left; do
    f=$(echo "$c" | tr / _)
    "$BIN" render "$dir/room.sol" -o "$dir/one.exr" --png "$dir/one.png" --camera "$c" --size 64x64 &&
        cmp -s "$dir/one.exr" "$dir/all/$f.exr" && cmp -s "$dir/one.png" "$dir/all/$f.png" && same=$((same + 1))
done
if [ "$same" -eq 3 ]; then ok "each view's files equal the single-view render's"; else bad "only $same of 3 views equal the single-view render"; fi

# --camera A,B and --camera repeated: those views only; --no-png: EXR only.
mkdir "$dir/two"
if "$BIN" render "$dir/room.sol" -o "$dir/two" --camera side,front --size 32x32 --no-png > /dev/null 2>&1 &&
   [ "$(ls "$dir/two" | tr '\n' ' ')" = "front.exr side.exr " ] &&
   "$BIN" render "$dir/room.sol" -o "$dir/two" --camera low/left --camera side --size 32x32 --threads 1 > /dev/null 2>&1 &&
   [ "$(ls "$dir/two" | wc -l)" -eq 5 ]; then
    ok "--camera side,front / --camera repeated"
else
    bad "--camera lists: $(ls "$dir/two")"
fi

# --path: frame-0001.. in order; the line's eye/target is the view.
cat > "$dir/fly.txt" <<'P'
# a short fly-through
eye 0.5,0.5,-1.5 target 0.5,0.4,0.5 fov 50

eye 0.6,0.5,-1.4 target 0.5,0.4,0.5 fov 50   # second
eye 0.7,0.5,-1.3 target 0.5,0.4,0.5 up 0,1,0 fov 40
P
mkdir "$dir/fly"
if "$BIN" render "$dir/room.sol" -o "$dir/fly" --path "$dir/fly.txt" --size 64x64 > "$dir/stdout" 2>&1 &&
   [ "$(ls "$dir/fly" | tr '\n' ' ')" = "frame-0001.exr frame-0001.png frame-0002.exr frame-0002.png frame-0003.exr frame-0003.png " ] &&
   cmp -s "$dir/fly/frame-0001.exr" "$dir/all/front.exr" &&
   ! cmp -s "$dir/fly/frame-0002.exr" "$dir/all/front.exr"; then
    ok "--path: three frames, the first the 'front' camera's view"
else
    bad "--path: $(cat "$dir/stdout"); $(ls "$dir/fly")"
fi

# The default EXR is uncompressed (a 64x64 RGB float image: at least
# 49,152 bytes of pixels); --exr-compression zip makes every view's EXR in
# the call smaller and leaves the PNGs unchanged.  (test_render checks each
# codec's pixels read back bit-exact.)
mkdir "$dir/zip"
if "$BIN" render "$dir/room.sol" -o "$dir/zip" --all-cameras --size 64x64 --exr-compression zip > /dev/null 2>&1 &&
   [ "$(stat -c %s "$dir/all/front.exr")" -gt 49152 ] &&
   [ "$(stat -c %s "$dir/zip/front.exr")" -lt 49152 ] &&
   [ "$(stat -c %s "$dir/zip/side.exr")" -lt "$(stat -c %s "$dir/all/side.exr")" ] &&
   cmp -s "$dir/zip/front.png" "$dir/all/front.png"; then
    ok "--exr-compression zip: $(stat -c %s "$dir/zip/front.exr") bytes against the default's $(stat -c %s "$dir/all/front.exr")"
else
    bad "--exr-compression zip: $(ls -l "$dir/zip" "$dir/all")"
fi
refuse "--exr-compression word" "--exr-compression: 'lzw'" render "$dir/room.sol" -o "$dir/out" --all-cameras --exr-compression lzw

printf 'eye 0,0,0 target 1,1,1\neye 1,1,1 target 1,1,1\n' > "$dir/bad.txt"
refuse "path: eye = target" "bad.txt: line 2: eye and target coincide" render "$dir/room.sol" -o "$dir/out" --path "$dir/bad.txt"
refuse "path: missing file" "nofile.txt: cannot open" render "$dir/room.sol" -o "$dir/out" --path "$dir/nofile.txt"
refuse "unknown camera in a list" "camera 'back' not found" render "$dir/room.sol" -o "$dir/out" --camera front,back
refuse "a camera twice" "camera 'front' named twice" render "$dir/room.sol" -o "$dir/out" --camera front,side --camera front
# A missing -o DIR is made with its parents; a refused view makes none, and
# a file in the way is an error naming it.
if "$BIN" render "$dir/room.sol" -o "$dir/new/a/b" --all-cameras --size 64x64 > /dev/null 2>&1 &&
   cmp -s "$dir/new/a/b/front.exr" "$dir/all/front.exr" && [ "$(ls "$dir/new/a/b" | wc -l)" -eq 6 ]; then
    ok "render -o DIR: a missing DIR made with its parents (mkdir -p)"
else
    bad "render -o DIR missing: $(ls -R "$dir/new" 2>&1)"
fi
refuse "no directory made for a refused view" "camera 'back' not found" render "$dir/room.sol" -o "$dir/out/none" --camera front,back
refuse "a file in the way of -o DIR" "room.rad/sub: cannot create directory '.*/room.rad/sub': Not a directory" render "$dir/room.sol" -o "$dir/room.rad/sub" --all-cameras
refuse "--png with many views" "PNG goes beside its EXR" render "$dir/room.sol" -o "$dir/out" --all-cameras --png "$dir/out/x.png"
refuse "--path and --all-cameras" "not both" render "$dir/room.sol" -o "$dir/out" --all-cameras --path "$dir/fly.txt"
refuse "--no-png with one view" "go with several views" render "$dir/room.sol" -o "$dir/out/x.exr" --camera front --no-png
refuse "--threads 0" "--threads: '0'" render "$dir/room.sol" -o "$dir/out" --all-cameras --threads 0

# export: the files, and a summary line.
mkdir "$dir/data"
if "$BIN" export "$dir/room.sol" -o "$dir/data" > "$dir/stdout" 2>&1 &&
   [ "$(ls "$dir/data" | tr '\n' ' ')" = "F.mtx patches.csv " ] &&
   head -1 "$dir/data/patches.csv" | grep -q '^patch,object,material,area,centroid_x,.*,F_row,rho_R,rho_G,rho_B,E_R,E_G,E_B,B_R,B_G,B_B$' &&
   head -1 "$dir/data/F.mtx" | grep -qx '%%MatrixMarket matrix coordinate real general'; then
    ok "export: $(cat "$dir/stdout")"
else
    bad "export: $(cat "$dir/stdout"); $(ls "$dir/data")"
fi
if "$BIN" export "$dir/room.sol" -o "$dir/new/data" > /dev/null 2>&1 &&
   cmp -s "$dir/new/data/patches.csv" "$dir/data/patches.csv" && cmp -s "$dir/new/data/F.mtx" "$dir/data/F.mtx"; then
    ok "export -o DIR: a missing DIR made, the same files"
else
    bad "export -o DIR missing: $(ls -R "$dir/new" 2>&1)"
fi
printf 'not a solution' > "$dir/bad.sol"
refuse "export: no directory made for a bad solution" "bad.sol: not a radiosity solution file" export "$dir/bad.sol" -o "$dir/out/none"
refuse "export: no solution" "usage: radiosity export" export -o "$dir/out"

echo "views.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
