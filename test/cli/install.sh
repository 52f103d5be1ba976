#!/usr/bin/env bash
# install.sh - issue 37's install half: `make install PREFIX=/usr/local
# DESTDIR=TMP` puts the program, both libraries (the shared one with soname
# libradiosity.so.0), the headers, radiosity.pc and the man page in place;
# each installed header compiles alone as <radiosity/NAME.h>;
# docs/library.md's example, built with nothing but pkg-config (shared, and
# static with the .pc's Libs.private), writes the very EXR that the in-tree
# program's `render` of the solution it wrote gives; `--version` names the
# solution-file version a solve writes; `make uninstall` leaves no file.
# Cost: the install (make finds the release build up to date, or links the
# shared library), twelve header compiles, two links of the example and
# three solves of a small room (a few seconds in all).
set -u
cd "$(dirname "$0")/../.."
. test/cli/lib.bash
BIN=$(realpath "$BIN")
root=$dir/root
prefix=/usr/local
P=$root$prefix
# The release build is what is installed; MAKEFLAGS of a `make test` above
# this script would hand the nested make a job server it cannot reach.
mk() { env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make --no-print-directory -s MODE=release "$@"; }

version=$(sed -n 's/^#define RAD_VERSION_STRING "\(.*\)"/\1/p' radiosity/core/rad.h)
if mk install PREFIX=$prefix DESTDIR="$root" > "$dir/install.log" 2>&1; then
    ok "make install PREFIX=$prefix DESTDIR=TMP: $(grep -c '^installed' "$dir/install.log") files"
else
    bad "make install: $(tail -5 "$dir/install.log")"
fi

# The files, and what the shared library says of itself.
want="bin/radiosity lib/libradiosity.a lib/libradiosity.so.$version lib/pkgconfig/radiosity.pc
share/man/man1/radiosity.1 include/radiosity/rad.h include/radiosity/pipeline.h"
missing=""
for f in $want; do [ -f "$P/$f" ] || missing="$missing $f"; done
if [ -z "$missing" ] && [ "$(readlink "$P/lib/libradiosity.so.0")" = "libradiosity.so.$version" ] &&
   [ "$(readlink "$P/lib/libradiosity.so")" = libradiosity.so.0 ] && [ -x "$P/bin/radiosity" ]; then
    ok "program, libradiosity.a, libradiosity.so.$version with its links, .pc, man page, headers"
else
    bad "installed files: missing$missing; $(ls -l "$P/lib" 2>&1)"
fi
dyn=$(readelf -d "$P/lib/libradiosity.so.$version" 2>&1)
if grep -q 'SONAME.*\[libradiosity\.so\.0\]' <<<"$dyn" && ! grep -qi 'osmesa\|libGL' <<<"$dyn"; then
    ok "soname libradiosity.so.0; OSMesa not linked (loaded at run time)"
else
    bad "shared library's dynamic section: $(grep -i 'soname\|needed' <<<"$dyn")"
fi

# Every public header of the tree is installed, and each compiles alone
# (and twice in a row: its guard) with nothing but the .pc's flags.
export PKG_CONFIG_PATH=$P/lib/pkgconfig PKG_CONFIG_SYSROOT_DIR=$root
cflags=$(pkg-config --cflags radiosity)
n=0; broken=""
for h in $(make -s --no-print-directory print-headers 2>/dev/null); do
    name=$(basename "$h")
    n=$((n + 1))
    printf '#include <radiosity/%s>\n#include <radiosity/%s>\nint main(void) { return 0; }\n' \
        "$name" "$name" > "$dir/one.c"
    cc -std=c11 -Wall -Wextra -Werror -pedantic $cflags -c "$dir/one.c" -o "$dir/one.o" \
        2> "$dir/cc.err" || broken="$broken $name: $(head -3 "$dir/cc.err")"
done
if [ "$n" -ge 12 ] && [ -z "$broken" ] && ! grep -l '^#include "' "$P"/include/radiosity/*.h; then
    ok "$n headers each compile alone as <radiosity/NAME.h> ($cflags)"
else
    bad "headers ($n): $broken"
fi

# docs/library.md's example, built against the installed library with
# pkg-config only, run on a small room whose lamp is the object 'light'.
sed -n '/^```c$/,/^```$/p' docs/library.md | sed '1d;$d' > "$dir/example.c"
{ room | sed 's/^polygon lamp lamp/polygon light lamp/'
  echo "camera front eye 0.5 0.5 -1.5 target 0.5 0.4 0.5 up 0 1 0 fov 50"; } > "$dir/room.rad"
# run_example BINARY: solves in its own directory; 0 when the EXR it wrote
# is byte for byte `radiosity render half.sol` of the solution it wrote.
run_example() {
    local run=$dir/run-$(basename "$1")
    mkdir -p "$run"
    (cd "$run" && LD_LIBRARY_PATH=$P/lib "$1" "$dir/room.rad" > out.log 2>&1) &&
        "$BIN" render "$run/half.sol" -o "$run/ref.exr" > /dev/null 2>&1 &&
        cmp "$run/half.exr" "$run/ref.exr"
}
libs=$(pkg-config --libs radiosity)
if cc -std=c11 -Wall -Wextra -Werror "$dir/example.c" $cflags $libs -o "$dir/shared" 2> "$dir/cc.err" &&
   LD_LIBRARY_PATH=$P/lib ldd "$dir/shared" | grep -q "libradiosity.so.0 => $P/lib/" &&
   run_example "$dir/shared"; then
    ok "library.md's example with \`pkg-config --cflags --libs\` ($libs): its EXR = render's"
else
    bad "example, shared: $(cat "$dir/cc.err" "$dir/run-shared/out.log" 2>/dev/null | head -5)"
fi
# Static: the archive by name, then what Libs.private says it needs.
# (docs/library.md's command)
static=$(pkg-config --cflags --static --libs radiosity | sed 's/-lradiosity /-l:libradiosity.a /')
if cc -std=c11 "$dir/example.c" $static -o "$dir/static" 2> "$dir/cc.err" &&
   ! ldd "$dir/static" | grep -q libradiosity && run_example "$dir/static"; then
    ok "example linked statically with \`pkg-config --static\` ($static): its EXR = render's"
else
    bad "example, static ($static): $(head -5 "$dir/cc.err")"
fi

# --version of the installed program: the solution-file version it names
# is the one in the header of the file a solve writes (bytes 8-11).
"$BIN" solve "$dir/room.rad" -o "$dir/v.sol" --refine-threshold 0 > /dev/null 2>&1
written=$(od -An -tu4 -j8 -N4 "$dir/v.sol" | tr -d ' ')
v=$("$P/bin/radiosity" --version 2>&1)
if grep -qx "radiosity $version" <<<"$v" &&
   grep -Eqx "solution files: writes version $written, reads versions 1 to $written" <<<"$v"; then
    ok "--version: $(tr '\n' ';' <<<"$v") (a solve writes version $written)"
else
    bad "--version: '$v' (a solve writes version '$written')"
fi

# uninstall: nothing is left under the prefix but empty directories.
if mk uninstall PREFIX=$prefix DESTDIR="$root" > "$dir/uninstall.log" 2>&1 &&
   [ -z "$(find "$root" ! -type d)" ]; then
    ok "make uninstall: $(grep -c '^removed' "$dir/uninstall.log") files removed, none left"
else
    bad "make uninstall left: $(find "$root" ! -type d | head)"
fi

echo "install.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
