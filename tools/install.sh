#!/usr/bin/env bash
# install.sh - what `make install`, `make uninstall` and `make headers` do,
# kept out of the Makefile so that it stays readable.  One list of files
# (manifest, below) serves both directions, so uninstall removes exactly
# what install put there and nothing else.
#
#   tools/install.sh headers OUTDIR HEADER...
#       the public headers as installed: OUTDIR/NAME.h, each of its
#       #include "../module/NAME.h" rewritten to #include <radiosity/NAME.h>
#   tools/install.sh install DESTDIR PREFIX BUILD VERSION
#   tools/install.sh uninstall DESTDIR PREFIX BUILD VERSION
#
# Installed under DESTDIR/PREFIX: bin/radiosity; lib/libradiosity.a;
# lib/libradiosity.so.VERSION with the links libradiosity.so.MAJOR (the
# soname) and libradiosity.so (for -lradiosity); include/radiosity/*.h;
# lib/pkgconfig/radiosity.pc; share/man/man1/radiosity.1.  LIBS_PRIVATE
# (from the Makefile's LDLIBS) is what a static link needs besides the
# library; PUB_HEADERS the public headers' names (NAME.h), so that
# uninstall needs no build.  OSMesa is never linked: hemicube/gl.c loads it
# at run time.
set -euo pipefail

die() { echo "install.sh: $*" >&2; exit 2; }

# The headers' installed copies.  Every include of another public header is
# rewritten; an include of anything else in quotes is refused, since it
# would not be installed.
headers() { # OUTDIR HEADER...
    local out=$1 h name
    shift
    mkdir -p "$out"
    rm -f "$out"/*.h
    for h in "$@"; do
        name=$(basename "$h")
        sed -E 's|^#include "(\.\./)*([a-z_]+/)*([a-z_]+\.h)"|#include <radiosity/\3>|' "$h" \
            > "$out/$name.tmp"
        if grep -n '^#include "' "$out/$name.tmp" >&2; then
            rm -f "$out/$name.tmp"
            die "$h: includes a header that is not installed"
        fi
        mv "$out/$name.tmp" "$out/$name"
    done
}

# manifest BUILD VERSION: every installed path, relative to PREFIX, one a
# line: kind (bin, lib, so, link, header, data), path, and for a link its
# target.
manifest() { # BUILD VERSION
    local b=$1 v=$2 major=${2%%.*} h
    echo "bin bin/radiosity"
    echo "lib lib/libradiosity.a"
    echo "so lib/libradiosity.so.$v"
    echo "link lib/libradiosity.so.$major libradiosity.so.$v"
    echo "link lib/libradiosity.so libradiosity.so.$major"
    for h in $PUB_HEADERS; do
        echo "header include/radiosity/$h"
    done
    echo "data lib/pkgconfig/radiosity.pc"
    echo "data share/man/man1/radiosity.1"
}

pc_file() { # PREFIX VERSION
    cat <<PC
prefix=$1
exec_prefix=\${prefix}
libdir=\${exec_prefix}/lib
includedir=\${prefix}/include

Name: radiosity
Description: diffuse global illumination by the hemi-cube method (radiosity)
Version: $2
Cflags: -I\${includedir}
Libs: -L\${libdir} -lradiosity
Libs.private: ${LIBS_PRIVATE:--lOpenEXRCore-3_1 -lpng -lembree3 -lstdc++ -lm -lpthread}
PC
}

install_all() { # DESTDIR PREFIX BUILD VERSION
    local root=$1$2 b=$3 v=$4 kind path target
    [ -x "$b/radiosity" ] && [ -f "$b/libradiosity.a" ] && [ -f "$b/libradiosity.so.$v" ] ||
        die "$b: build the program and the libraries first (make prog lib headers)"
    [ -d "$b/include/radiosity" ] || die "$b/include/radiosity: no headers (make headers)"
    while read -r kind path target; do
        mkdir -p "$root/$(dirname "$path")"
        case $kind in
            bin) install -m 755 "$b/radiosity" "$root/$path" ;;
            lib) install -m 644 "$b/libradiosity.a" "$root/$path" ;;
            so) install -m 755 "$b/$(basename "$path")" "$root/$path" ;;
            link) ln -sfn "$target" "$root/$path" ;;
            header) install -m 644 "$b/$path" "$root/$path" ;;
            data) case $path in
                      *.pc) pc_file "$2" "$v" > "$root/$path.tmp"
                            chmod 644 "$root/$path.tmp"; mv "$root/$path.tmp" "$root/$path" ;;
                      *.1) install -m 644 docs/radiosity.1 "$root/$path" ;;
                  esac ;;
        esac
        echo "installed $root/$path"
    done < <(manifest "$b" "$v")
}

# Removes the manifest's files; of the directories only include/radiosity,
# which is the project's own, and only once it is empty.
uninstall_all() { # DESTDIR PREFIX BUILD VERSION
    local root=$1$2 kind path target
    while read -r kind path target; do
        if [ -e "$root/$path" ] || [ -L "$root/$path" ]; then
            rm -f "$root/$path"
            echo "removed $root/$path"
        fi
    done < <(manifest "$3" "$4")
    rmdir "$root/include/radiosity" 2>/dev/null || true
}

case ${1:-} in
    install | uninstall)
        [ $# -eq 5 ] || die "usage: install.sh $1 DESTDIR PREFIX BUILD VERSION"
        case $3 in /*) ;; *) die "PREFIX '$3' is not an absolute path" ;; esac
        [ -n "${PUB_HEADERS:-}" ] || die "PUB_HEADERS is empty (run it through make)" ;;
esac
case ${1:-} in
    headers) shift; [ $# -ge 2 ] || die "usage: install.sh headers OUTDIR HEADER..."; headers "$@" ;;
    install) install_all "$2" "$3" "$4" "$5" ;;
    uninstall) uninstall_all "$2" "$3" "$4" "$5" ;;
    *) die "usage: install.sh headers|install|uninstall ..." ;;
esac
