#!/usr/bin/env bash
# real.sh - issue 15 from the command line: every file of test/data/real/
# solves and renders, each kind of repaired or ignored thing is named in
# exactly one warning line on stderr (and nothing else is printed there),
# --strict keeps the old refusals as one error line, and render takes an
# orthographic camera from the scene or from --ortho.
# Cost: about 6 s (five small solves; each opens the hemi-cube engine).
set -u
source "$(dirname "$0")/lib.bash"
real=test/data/real

# solves FILE LINES NEEDLE...: exit 0, exactly LINES lines on stderr, each a
# warning naming FILE, no two alike in kind, each NEEDLE in one of them;
# then renders the solution from the scene's camera.
solves() {
    local file=$1 lines=$2; shift 2
    local base=${file%.*}
    "$BIN" solve "$real/$file" -o "$dir/$base.sol" --patch-size 0.5 --resolution 64 \
        > "$dir/stdout" 2> "$dir/stderr"
    local rc=$? why=""
    [ "$rc" -eq 0 ] || why="exit $rc"
    [ "$(wc -l < "$dir/stderr")" -eq "$lines" ] || why="$why; $(wc -l < "$dir/stderr") lines"
    grep -v -q "^radiosity: warning: $real/$file: " "$dir/stderr" && why="$why; a line not a warning on the file"
    [ "$(sed 's/^[^:]*: [^:]*: [^:]*: [^:]*: //' "$dir/stderr" | sort | uniq -d | wc -l)" -eq 0 ] ||
        why="$why; a kind said twice"
    for needle in "$@"; do
        grep -F -q -- "$needle" "$dir/stderr" || why="$why; no '$needle'"
    done
    if [ -z "$why" ] &&
       "$BIN" render "$dir/$base.sol" -o "$dir/$base.exr" --png "$dir/$base.png" --size 48x48 \
           > /dev/null 2>&1 && [ -s "$dir/$base.exr" ] && [ -s "$dir/$base.png" ]; then
        ok "$file solves with $lines warning lines and renders"
    else
        bad "$file:${why:- render failed}: $(cat "$dir/stderr")"
    fi
}

solves textured.gltf 4 "meshes 'floor', 'wall': primitives without the TEXCOORD set" \
    "extensions KHR_texture_transform, KHR_materials_specular: ignored" \
    "materials 'checker floor', 'bricks', 'lamp': texture coordinates ignored" \
    "material 'checker floor': normal, occlusion and metallic-roughness textures ignored"
solves no-material.gltf 5 "mesh 'floor': primitives without a material get glTF's default" \
    "mesh 'floor' (LINES): primitives without area (points, lines) skipped" \
    "material 'gold': metallicFactor drawn by render --gather only" "material 'leaf' (MASK): alphaMode ignored" \
    "light 'bulb': range ignored"
solves vertex-colors.glb 3 "primitives without the TEXCOORD set of their baseColorTexture" \
    "material 'painted': reflectance >= 1 clamped to 0.95 (--strict refuses it)" \
    "material 'label': texture coordinates ignored"
solves ortho.gltf 1 "extensions KHR_materials_transmission, KHR_materials_volume: ignored"

# refuses NAME PATTERN ARGS...: exit 2 and one error line matching PATTERN.
refuses() {
    local name=$1 pattern=$2; shift 2
    "$BIN" "$@" > "$dir/stdout" 2> "$dir/stderr"
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l < "$dir/stderr")" -eq 1 ] &&
       grep -q '^radiosity: error: ' "$dir/stderr" && grep -Eq -- "$pattern" "$dir/stderr"; then
        ok "$name: $(cat "$dir/stderr")"
    else
        bad "$name: exit $rc, stderr: $(cat "$dir/stderr") (wanted /$pattern/)"
    fi
}

refuses "--strict: no material" "no-material.gltf: mesh 'floor' primitive 0: no material" \
    solve "$real/no-material.gltf" -o "$dir/s.sol" --strict
refuses "--strict: reflectance 1" "material 'painted': baseColorFactor 1 is not a reflectance below 1" \
    solve "$real/vertex-colors.glb" -o "$dir/s.sol" --strict
refuses "--fov with --ortho" "--fov and --ortho exclude each other" \
    render "$dir/textured.sol" -o "$dir/x.exr" --fov 40 --ortho 1

# --strict takes what needs no repair (the warnings about ignored things stay).
if "$BIN" solve "$real/textured.gltf" -o "$dir/strict.sol" --strict --patch-size 1 --resolution 32 \
       > /dev/null 2> "$dir/stderr" && [ "$(wc -l < "$dir/stderr")" -eq 4 ]; then
    ok "--strict solves textured.gltf"
else
    bad "--strict textured.gltf: $(cat "$dir/stderr")"
fi

# The orthographic camera comes back from the solution file by name (its
# pixels are checked by test_real); an explicit --ortho view renders too.
if "$BIN" report "$dir/ortho.sol" > /dev/null &&
   "$BIN" render "$dir/ortho.sol" -o "$dir/plan.exr" --camera plan --size 30x30 > /dev/null 2>&1 &&
   "$BIN" render "$dir/textured.sol" -o "$dir/o.exr" --ortho 1.5 --size 30x30 > /dev/null 2>&1 &&
   [ -s "$dir/plan.exr" ] && [ -s "$dir/o.exr" ]; then
    ok "render: the scene's orthographic camera and --ortho"
else
    bad "render with an orthographic camera"
fi

echo "real.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
