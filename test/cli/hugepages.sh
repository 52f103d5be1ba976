#!/usr/bin/env bash
# hugepages.sh - main runs itself again once with glibc's tunable
# glibc.malloc.hugetlb=1 added to GLIBC_TUNABLES (radiosity/cli/cli_process.c,
# with_huge_pages: transparent huge pages for malloc's memory), and only
# once:
#   - without GLIBC_TUNABLES, the running program's environment holds it;
#   - a hugetlb setting given (here 0, off) is left as it is: no second run;
#   - under Valgrind (its preload library named in LD_PRELOAD; here a name
#     that does not exist, which the loader reports and ignores) no second
#     run either: /proc/self/exe would be Valgrind's tool;
#   - a render and a report are the same bytes either way, and with another
#     tunable given (the setting is appended to it; glibc rewrites the
#     variable it has read, so the environment does not show that one).
# The program is caught while it waits to open a FIFO as its solution
# (its wait channel wait_for_partner; before that it has run itself again,
# or not; it then refuses the FIFO).
# Cost: well under 1 s (one solve of a two-polygon room).
set -u
. "$(dirname "$0")/lib.bash"

# env_of WANT LABEL ENV-ARGS...: the GLIBC_TUNABLES line of the program's
# environment once it waits at the FIFO, started through `env ENV-ARGS...`
# (-u GLIBC_TUNABLES: without one), must be WANT (empty: no such line).
env_of() {
    local want=$1 label=$2; shift 2
    rm -f "$dir/fifo"; mkfifo "$dir/fifo"
    env "$@" "$BIN" report "$dir/fifo" > /dev/null 2>&1 &
    local pid=$! got="" k
    for k in $(seq 100); do
        [ "$(cat "/proc/$pid/wchan" 2>/dev/null)" = wait_for_partner ] && break
        sleep 0.05
    done
    got=$(tr '\0' '\n' < "/proc/$pid/environ" 2>/dev/null | grep '^GLIBC_TUNABLES=' || true)
    : > "$dir/fifo" # let it go: it refuses the FIFO
    wait "$pid" 2>/dev/null
    if [ "$got" = "$want" ]; then
        ok "$label: runs with '$want'"
    else
        bad "$label: runs with '$got', not '$want'"
    fi
}

env_of "GLIBC_TUNABLES=glibc.malloc.hugetlb=1" "no tunables given" -u GLIBC_TUNABLES
env_of "GLIBC_TUNABLES=glibc.malloc.hugetlb=0" "huge pages turned off" GLIBC_TUNABLES=glibc.malloc.hugetlb=0
env_of "" "under Valgrind" -u GLIBC_TUNABLES LD_PRELOAD=/nonexistent/vgpreload_memcheck-amd64-linux.so

room > "$dir/room.rad"
if "$BIN" solve "$dir/room.rad" -o "$dir/room.sol" > /dev/null 2>&1 &&
   env -u GLIBC_TUNABLES "$BIN" render "$dir/room.sol" -o "$dir/on.exr" --size 64x64 > /dev/null 2>&1 &&
   GLIBC_TUNABLES=glibc.malloc.hugetlb=0 "$BIN" render "$dir/room.sol" -o "$dir/off.exr" --size 64x64 > /dev/null 2>&1 &&
   GLIBC_TUNABLES=glibc.malloc.tcache_count=7 "$BIN" render "$dir/room.sol" -o "$dir/other.exr" --size 64x64 > /dev/null 2>&1 &&
   env -u GLIBC_TUNABLES "$BIN" report "$dir/room.sol" > "$dir/on.txt" 2>&1 &&
   GLIBC_TUNABLES=glibc.malloc.hugetlb=0 "$BIN" report "$dir/room.sol" > "$dir/off.txt" 2>&1 &&
   cmp -s "$dir/on.exr" "$dir/off.exr" && cmp -s "$dir/on.exr" "$dir/other.exr" &&
   cmp -s "$dir/on.txt" "$dir/off.txt"; then
    ok "render and report: the same bytes with and without huge pages, and with another tunable"
else
    bad "render or report differ with huge pages: $(ls -l "$dir")"
fi

echo "hugepages.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
