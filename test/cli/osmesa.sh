#!/usr/bin/env bash
# osmesa.sh - libOSMesa is loaded at run time by the hemi-cube workers only
# (hemicube/gl.c), never linked (issue 21: the process holding F must not
# carry OSMesa and LLVM):
#   - the program does not link libOSMesa (nor the libLLVM it pulls in);
#   - with a broken libOSMesa.so.8 first on LD_LIBRARY_PATH (not a shared
#     object; one without the OSMesa calls; one whose OSMesaGetProcAddress
#     finds no GL entry point), a solve fails with one line naming the
#     library and what is wrong, no crash and no output;
#   - under the same broken library, report, render, relight (no punctual
#     light) and export of a stored solution work: they never load it.
# Cost: about 2 s (one solve of a two-polygon room, three refused solves,
# two small compilations of the fake library).
set -u
. "$(dirname "$0")/lib.bash"

if ldd "$BIN" > "$dir/ldd" 2>&1 && ! grep -Eq 'libOSMesa|libLLVM|libglapi' "$dir/ldd"; then
    ok "not linked with libOSMesa, libLLVM or libglapi"
else
    bad "the program still links GL: $(grep -E 'libOSMesa|libLLVM|libglapi' "$dir/ldd")"
fi

room > "$dir/room.rad"
if ! "$BIN" solve "$dir/room.rad" -o "$dir/room.sol" > /dev/null 2> "$dir/err"; then
    bad "the room does not solve with the real library: $(cat "$dir/err")"
fi

fake=$dir/fake
mkdir -p "$fake"
# refused NAME PATTERN: solve with $fake first on the library path must fail
# (a status below 128: no signal), one stderr line matching PATTERN, no output.
refused() {
    rm -f "$dir"/out.sol*
    LD_LIBRARY_PATH=$fake "$BIN" solve "$dir/room.rad" -o "$dir/out.sol" > /dev/null 2> "$dir/err"
    local rc=$?
    if [ "$rc" -ne 0 ] && [ "$rc" -lt 128 ] && [ "$(wc -l < "$dir/err")" -eq 1 ] &&
       grep -Eq "^radiosity: error: $2" "$dir/err" && ! ls "$dir"/out.sol* > /dev/null 2>&1; then
        ok "$1: $(cat "$dir/err")"
    else
        bad "$1: exit $rc, output $(ls "$dir"/out.sol* 2> /dev/null), stderr: $(cat "$dir/err")"
    fi
}

echo 'not a shared object' > "$fake/libOSMesa.so.8"
refused "not a shared object" \
    'hemi-cube: cannot load libOSMesa\.so\.8 \(Debian package libosmesa6\): .*libOSMesa\.so\.8'

if cc -shared -fPIC -o "$fake/libOSMesa.so.8" -x c /dev/null 2> "$dir/cc"; then
    refused "no OSMesa calls" 'hemi-cube: libOSMesa\.so\.8 has no OSMesaCreateContextAttribs'
else
    bad "cannot build an empty shared object: $(cat "$dir/cc")"
fi

cat > "$fake/partial.c" <<'C'
void OSMesaCreateContextAttribs(void) {}
void OSMesaMakeCurrent(void) {}
void (*OSMesaGetProcAddress(const char *name))(void) { (void)name; return 0; }
C
if cc -shared -fPIC -o "$fake/libOSMesa.so.8" "$fake/partial.c" 2> "$dir/cc"; then
    refused "no GL entry points" 'hemi-cube: libOSMesa\.so\.8 has no gl[A-Z][A-Za-z]+ \(worker [0-9]+\)$'
else
    bad "cannot build the partial library: $(cat "$dir/cc")"
fi

# The commands that only read a solution run under the library that is no
# shared object (a program linked with libOSMesa would not even start).
echo 'not a shared object' > "$fake/libOSMesa.so.8"
without() { # NAME COMMAND...
    local name=$1
    shift
    if LD_LIBRARY_PATH=$fake "$BIN" "$@" > /dev/null 2> "$dir/err"; then
        ok "$name runs without libOSMesa"
    else
        bad "$name needs libOSMesa: $(cat "$dir/err")"
    fi
}
without report report "$dir/room.sol"
without render render "$dir/room.sol" -o "$dir/room.exr" --size 32x32
without relight relight "$dir/room.sol" -o "$dir/lit.sol" --light lamp=2
mkdir -p "$dir/csv"
without export export "$dir/room.sol" -o "$dir/csv"

echo "osmesa.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
