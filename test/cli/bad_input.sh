#!/usr/bin/env bash
# bad_input.sh - every bad input of issue 2 gets one line
# "radiosity: error: FILE: WHERE: WHAT" naming the file, exit status 2, and
# leaves no output file (nor a temporary one) behind.
set -u
. "$(dirname "$0")/lib.bash"

# expect NAME FILE PATTERN [OPTION...]: solve FILE (with the options) must
# fail with status 2, a single stderr line that names FILE and matches
# PATTERN (extended regex, any case), and no output.
expect() {
    local name=$1 file=$2 pattern=$3
    shift 3
    rm -f "$dir"/out.sol "$dir"/out.sol.*
    "$BIN" solve "$file" -o "$dir/out.sol" "$@" > "$dir/stdout" 2> "$dir/stderr"
    local rc=$? lines msg
    lines=$(wc -l < "$dir/stderr")
    msg=$(cat "$dir/stderr")
    local leftovers
    leftovers=$(ls "$dir" | grep -c '^out\.sol' || true)
    if [ "$rc" -eq 2 ] && [ "$lines" -eq 1 ] && [ "$leftovers" -eq 0 ] &&
       grep -q '^radiosity: error: ' "$dir/stderr" && grep -qF "$(basename "$file")" "$dir/stderr" &&
       grep -Eiq "$pattern" "$dir/stderr"; then
        passed=$((passed + 1)); echo "ok   $name: $msg"
    else
        failed=$((failed + 1))
        echo "FAIL $name: exit $rc, $lines stderr lines, $leftovers output files, message: $msg (wanted /$pattern/)"
    fi
}


expect "missing file" "$dir/nope.rad" "cannot open|no such file"
mkdir -p "$dir/adir.rad"
expect "unreadable (a directory)" "$dir/adir.rad" "cannot|directory|read"

printf 'bands 3\nmaterial white reflectance 0.5\npolygon floor white\n 0 0 0  1 0 0 oops\nend\n' > "$dir/syntax.rad"
expect "malformed polygon file" "$dir/syntax.rad" "line [0-9]+"

printf '{"asset": {"version": "2.0"}, "meshes": [ {' > "$dir/broken.gltf"
expect "malformed glTF" "$dir/broken.gltf" "json|parse|malformed|invalid"

cat > "$dir/lines.gltf" <<'G'
{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
 "nodes":[{"name":"tri","mesh":0}],
 "materials":[{"name":"glow","pbrMetallicRoughness":{"baseColorFactor":[0.5,0.5,0.5,1]},"emissiveFactor":[1,1,1]}],
 "meshes":[{"name":"tri","primitives":[{"attributes":{"POSITION":0},"material":0,"mode":1}]}],
 "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
 "bufferViews":[{"buffer":0,"byteLength":36}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}
G
expect "primitive mode LINES, --strict" "$dir/lines.gltf" "mode|TRIANGLES" --strict
# without --strict the lines are skipped with a warning, and nothing is left
"$BIN" solve "$dir/lines.gltf" -o "$dir/out.sol" > /dev/null 2> "$dir/stderr"
if [ $? -eq 2 ] && [ "$(wc -l < "$dir/stderr")" -eq 2 ] &&
   grep -q "^radiosity: warning: .*lines.gltf: mesh 'tri' (LINES): primitives without area" "$dir/stderr" &&
   grep -q "^radiosity: error: .*lines.gltf: no polygons: the scene is empty" "$dir/stderr" &&
   [ ! -e "$dir/out.sol" ]; then
    passed=$((passed + 1)); echo "ok   primitive mode LINES: skipped, then the empty scene refused"
else
    failed=$((failed + 1)); echo "FAIL primitive mode LINES without --strict: $(cat "$dir/stderr")"
fi

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   1 0 0/' > "$dir/two.rad"
expect "polygon with 2 vertices" "$dir/two.rad" "at least 3|fewer than 3|3 points|3 vertices"

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   0 0 1   0 0 2/' > "$dir/zero.rad"
expect "zero-area polygon" "$dir/zero.rad" "zero area|degenerate|collinear"

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   0 0 1   1 0.5 1   1 0 0/' > "$dir/nonplanar.rad"
expect "non-planar polygon" "$dir/nonplanar.rad" "planar"

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   0 0 1   0.2 0 0.2   1 0 0/' > "$dir/nonconvex.rad"
expect "non-convex polygon" "$dir/nonconvex.rad" "convex"

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   0 0 nan   1 0 1   1 0 0/' > "$dir/nan.rad"
expect "NaN coordinate" "$dir/nan.rad" "nan|finite|number"

room | sed 's/  0 0 0   0 0 1   1 0 1   1 0 0/  0 0 0   0 0 1   1 0 inf   1 0 0/' > "$dir/inf.rad"
expect "infinite coordinate" "$dir/inf.rad" "inf|finite|number"

room | sed 's/material white reflectance 0.5 0.5 0.5/material white reflectance 0.5 1.2 0.5/' > "$dir/rho.rad"
expect "reflectance above 1" "$dir/rho.rad" "reflectance"

room | sed 's/material white reflectance 0.5 0.5 0.5/material white reflectance 0.5 1 0.5/' > "$dir/rho1.rad"
expect "reflectance exactly 1" "$dir/rho1.rad" "reflectance"

room | sed 's/emission 10 10 10/emission 10 -1 10/' > "$dir/neg.rad"
expect "negative emission" "$dir/neg.rad" "emission|negative"

room | sed 's/^polygon floor white/polygon floor marble/' > "$dir/unknown.rad"
expect "unknown material" "$dir/unknown.rad" "unknown material|marble"

room | sed 's/emission 10 10 10/emission 0/' > "$dir/dark.rad"
expect "no emitter" "$dir/dark.rad" "emitter|emission"

room | sed 's/material white reflectance 0.5 0.5 0.5/material white reflectance 0.6 transmittance 0.4/' > "$dir/glass.rad"
expect "reflectance + transmittance = 1" "$dir/glass.rad" "reflectance \\+ transmittance = 1 must be < 1"

sed 's/"emissiveFactor":\[1,1,1\]}/"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_diffuse_transmission":{"diffuseTransmissionFactor":-0.5}}}/; s/"mode":1/"mode":4/' "$dir/lines.gltf" > "$dir/dt.gltf"
expect "diffuseTransmissionFactor out of range" "$dir/dt.gltf" "material 'glow': diffuseTransmissionFactor -0.5 is not in \\[0, 1\\]"

# a good file still works and leaves exactly the output
room > "$dir/good.rad"
if "$BIN" solve "$dir/good.rad" -o "$dir/good.sol" > /dev/null 2>&1 && [ -s "$dir/good.sol" ] &&
   [ "$(ls "$dir" | grep -c 'good\.sol')" -eq 1 ]; then
    passed=$((passed + 1)); echo "ok   good file solves"
else
    failed=$((failed + 1)); echo "FAIL good file did not solve"
fi

echo "bad_input.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
