#!/usr/bin/env bash
# bake_texture.sh - issue 37, textured materials in a bake: a room whose
# floor samples a PNG checker (written by test/browser/bake_texture.js, UVs
# an affine function of the position with a seam) is solved with elements
# and baked; the bakes pass the Khronos validator, and bake_texture.js
# checks from the files alone that every floor vertex has its cell's
# (u, v) within 1e-5, that COLOR_0 × ρ̄ = _RADIANCE × 2^EV within 1/65535
# per band, and that the image is the input's byte for byte.  The solution
# file carries the texture (section TEXTURES), and a damaged one gives one
# line and leaves nothing.
# Needs test/browser/node_modules (`make deps`).  Cost: one small solve
# (~1 s of CPU) and two node runs.
set -u
. "$(dirname "$0")/lib.bash"
browser=test/browser

if [ ! -d "$browser/node_modules/gltf-validator" ]; then
    bad "test/browser/node_modules is missing: run 'make deps' (npm ci in test/browser)"
    echo "bake_texture.sh: $passed passed, $failed failed"
    exit 1
fi

mkdir "$dir/in"
node "$browser/bake_texture.js" make "$dir/in" || { echo "cannot write the fixture"; exit 1; }
if out=$(node "$browser/validate.js" "$dir/in/room.gltf" 2>&1); then
    ok "the fixture is valid glTF: $out"
else
    bad "the fixture: $out"
fi

if "$BIN" solve "$dir/in/room.gltf" -o "$dir/room.sol" --patch-size 0.5 --resolution 64 \
       > "$dir/out" 2> "$dir/err" && [ "$(wc -l < "$dir/err")" -eq 1 ] &&
   grep -q "material 'checker': texture coordinates ignored by the solve.*bake keeps" "$dir/err" &&
   grep -q "^elements: " "$dir/out" &&
   read -r off len < <(section_at "$dir/room.sol" TEXR) && [ "${len:-0}" -gt 0 ]; then
    ok "solved with elements, one warning (the solve's mean); TEXTURES: $len bytes"
else
    bad "solve: $(cat "$dir/err" "$dir/out")"
fi

if "$BIN" bake "$dir/room.sol" -o "$dir/room.glb" > "$dir/out" 2>&1 &&
   ev=$(sed -n 's/.*exposure \(-\{0,1\}[0-9.]*\) EV.*/\1/p' "$dir/out") && [ -n "$ev" ]; then
    ok "bake .glb: $(cat "$dir/out")"
else
    bad "bake .glb: $(cat "$dir/out")"
    ev=0
fi
"$BIN" bake "$dir/room.sol" -o "$dir/room.gltf" --exposure "$ev" > /dev/null 2>&1 ||
    bad "bake .gltf failed"
if out=$(node "$browser/validate.js" "$dir/room.glb" "$dir/room.gltf" 2>&1); then
    ok "validator: $(tr '\n' ' ' <<<"$out")"
else
    bad "validator: $out"
fi
for f in room.glb room.gltf; do
    if out=$(node "$browser/bake_texture.js" check "$dir/$f" "$ev" "$dir/in" 2>&1); then
        ok "$f: $out"
    else
        bad "$f: $out"
    fi
done

# A damaged TEXTURES section: one line naming the file, nothing written.
cp "$dir/room.sol" "$dir/damaged.sol"
read -r off len < <(section_at "$dir/room.sol" TEXR)
printf '\x5a\x5a\x5a\x5a' | dd of="$dir/damaged.sol" bs=1 seek=$((off + len / 2)) conv=notrunc 2> /dev/null
mkdir "$dir/o"
"$BIN" bake "$dir/damaged.sol" -o "$dir/o/x.glb" > "$dir/out" 2> "$dir/err"
rc=$?
if [ "$rc" -ne 0 ] && [ "$(wc -l < "$dir/err")" -eq 1 ] &&
   grep -q "^radiosity: error: $dir/damaged.sol: .*TEXTURES" "$dir/err" && [ -z "$(ls -A "$dir/o")" ]; then
    ok "damaged TEXTURES: $(cat "$dir/err")"
else
    bad "damaged TEXTURES: exit $rc, $(cat "$dir/err"), left: $(ls -A "$dir/o")"
fi

echo "bake_texture.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
