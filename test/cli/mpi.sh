#!/usr/bin/env bash
# mpi.sh - solves under mpirun (issue 38): `mpirun -np 3 radiosity solve`
# runs radiosity-mpi, spreads the rows and element hemi-cubes over three
# ranks and writes the very solution one process writes (F's rows, B and
# the element arrays bit for bit; only the stage times differ), naming the
# three ranks; a computing rank and the assembling rank that exit part-way
# (RADIOSITY_TEST_RANK_EXIT=k:n: rank k exits after n blocks) end the job
# naming them, and the same command run again computes only the rows the
# assembling rank had not stored, to the same solution.  The plain program
# loads no MPI library.  As root in a container OpenMPI needs the
# OMPI_ALLOW_RUN_AS_ROOT pair, and shared memory without single copy.
# Cost: ~25 s (a Cornell box of 133 patches, solved seven times).
set -u
. "$(dirname "$0")/lib.bash"
MPI_BIN=$(dirname "$BIN")/radiosity-mpi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
args=(models/cornell.rad --patch-size 0.15 --processes 1)
mpi() { timeout 120 mpirun --oversubscribe -np 3 "$@"; }

# same_solution A B: every section of the two files alike but INFO (stage
# times); MATRIX's row blocks compared as a set (they are journaled in the
# order they arrive).  Prints what differs.
same_solution() {
    python3 - "$1" "$2" <<'P'
import struct, sys
def sections(fn):
    b = open(fn, 'rb').read()
    at = struct.unpack_from('<Q', b, 16)[0]
    out = {}
    for q in range(struct.unpack_from('<I', b, at)[0]):
        tag, _, off, length, crc = struct.unpack_from('<4sIQQQ', b, at + 8 + 32 * q)
        out[tag] = b[off:off + length]
    return out
def rows(body):
    at, recs = 16, []
    while at + 24 <= len(body) and body[at:at + 4] == b'RBLK':
        length = struct.unpack_from('<Q', body, at + 8)[0]
        recs.append(body[at + 24:at + 24 + length])
        at += 24 + length
    return body[:16], sorted(recs), body[at:]
a, b = sections(sys.argv[1]), sections(sys.argv[2])
bad = [t for t in a if t != b'INFO' and
       (t not in b or (rows(a[t]) != rows(b[t]) if t == b'MTRX' else a[t] != b[t]))]
print(' '.join(t.decode() for t in bad) if bad or a.keys() != b.keys() else 'same')
P
}
# computed LOG: the "N rows computed" of a solve's output.
computed() { sed -n 's/.* \([0-9]*\) rows computed.*/\1/p' "$1"; }

[ -x "$MPI_BIN" ] && ok "radiosity-mpi is built beside radiosity" || bad "no $MPI_BIN"
if ldd "$BIN" | grep -qi mpi; then bad "radiosity links MPI: $(ldd "$BIN" | grep -i mpi)"; else
    ok "radiosity loads no MPI library"; fi

"$BIN" solve "${args[@]}" -o "$dir/one.sol" > "$dir/one.log" 2>&1 ||
    bad "single-process solve: $(tail -1 "$dir/one.log")"

mpi "$BIN" solve "${args[@]}" -o "$dir/three.sol" > "$dir/three.log" 2>&1
rc=$?
[ $rc -eq 0 ] && ok "mpirun -np 3 solve exits 0" || bad "mpirun -np 3 solve: status $rc: $(tail -3 "$dir/three.log")"
grep -q "radiosity: MPI: 3 ranks: 0 on .*, 1 on .*, 2 on " "$dir/three.log" &&
    ok "the output names 3 ranks" || bad "no line naming 3 ranks: $(tail -2 "$dir/three.log")"
# every rank computed some hemi-cubes
grep "MPI: 3 ranks" "$dir/three.log" | grep -vq "(0 hemi-cubes" &&
    ok "each rank computed hemi-cubes" || bad "a rank computed none: $(grep 'MPI:' "$dir/three.log")"
s=$(same_solution "$dir/one.sol" "$dir/three.sol")
rows=$(computed "$dir/one.log") # every row, computed by the single process
[ "$s" = same ] && ok "3 ranks: the single process's solution, bit for bit" || bad "3 ranks differ in: $s"

# The same command again after a rank died (f NAME: NAME.sol, NAMEb.log):
# it keeps the journaled rows, computes only the others (as many in all
# as the single process computed: the mesh decides how many), and gives
# the single process's solution.
rerun_resumes() { # what, name
    mpi "$BIN" solve "${args[@]}" -o "$dir/$2.sol" > "$dir/$2b.log" 2>&1
    local kept n s
    kept=$(sed -n 's/^resumed: \([0-9]*\) rows kept.*/\1/p' "$dir/$2b.log")
    n=$(computed "$dir/$2b.log")
    [ -n "$kept" ] && [ "$kept" -gt 0 ] && [ -n "$rows" ] && [ $((kept + n)) -eq "$rows" ] &&
        ok "$1: the rerun computes only the $n rows not kept ($kept kept)" ||
        bad "rerun $1: kept '$kept', computed '$n'"
    s=$(same_solution "$dir/one.sol" "$dir/$2.sol")
    [ "$s" = same ] && ok "resumed $1: the same solution" || bad "resumed $1 differs in: $s"
}

# A computing rank exits after 2 blocks.  Under --enable-recovery the job
# outlives it and rank 0 names it; the rerun computes only what is missing.
RADIOSITY_TEST_RANK_EXIT=1:2 mpi --enable-recovery "$BIN" solve "${args[@]}" -o "$dir/f1.sol" \
    > "$dir/f1.log" 2>&1
grep -q "radiosity: error: MPI rank 1 (pid [0-9]* on .*) stopped while computing rows" "$dir/f1.log" &&
    ok "a computing rank that exits is named" || bad "rank 1's exit not named: $(grep -v '^$' "$dir/f1.log" | head -5)"
[ ! -e "$dir/f1.sol" ] && [ -s "$dir/f1.sol.partial" ] && ok "its rows stay in the .partial file" ||
    bad "after rank 1's exit: $(ls "$dir")"
rerun_resumes "after rank 1" f1

# The same by default: mpirun ends the job and names the rank itself.
RADIOSITY_TEST_RANK_EXIT=2:2 mpi "$BIN" solve "${args[@]}" -o "$dir/f2.sol" > "$dir/f2.log" 2>&1
rc=$?
[ $rc -ne 0 ] && grep -q "\[\[[0-9]*,1\],2\]" "$dir/f2.log" && [ ! -e "$dir/f2.sol" ] &&
    ok "without recovery mpirun ends the job naming rank 2 (status $rc)" ||
    bad "rank 2's exit without recovery: status $rc: $(grep -v '^$' "$dir/f2.log" | head -5)"
mpi "$BIN" solve "${args[@]}" -o "$dir/f2.sol" > "$dir/f2b.log" 2>&1
s=$(same_solution "$dir/one.sol" "$dir/f2.sol")
grep -q "^resumed: [1-9][0-9]* rows kept" "$dir/f2b.log" && [ "$s" = same ] &&
    ok "resumed after mpirun's abort: the same solution" || bad "after rank 2: $s, $(grep resumed "$dir/f2b.log")"

# The assembling rank exits after 3 blocks: rank 1 names it.
RADIOSITY_TEST_RANK_EXIT=0:3 mpi --enable-recovery "$BIN" solve "${args[@]}" -o "$dir/f0.sol" \
    > "$dir/f0.log" 2>&1
grep -q "radiosity: error: MPI rank 0 (pid [0-9]* on .*), the assembling rank, stopped" "$dir/f0.log" &&
    ok "the assembling rank that exits is named" || bad "rank 0's exit not named: $(grep -v '^$' "$dir/f0.log" | head -5)"
rerun_resumes "after rank 0" f0

# A row that stops two workers, wherever it is drawn, ends the job with
# its message and no rank left waiting (the timeout would say 124).
RADIOSITY_TEST_CRASH_ROW=100 mpi "$BIN" solve "${args[@]}" -o "$dir/c.sol" > "$dir/c.log" 2>&1
rc=$?
[ $rc -ne 0 ] && [ $rc -ne 124 ] && grep -q "the row of patch 100 stopped two workers" "$dir/c.log" &&
    ok "a row that cannot be computed ends the job (status $rc)" ||
    bad "crash row: status $rc: $(grep -v '^$' "$dir/c.log" | head -3)"

echo "mpi.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
