#!/usr/bin/env bash
# resume.sh - nothing computed is lost, from the command line: a solve
# killed with SIGKILL part-way (its whole process group) and run again
# computes only the rows it lacks and gives the same solution as a run never
# interrupted; Ctrl-C (SIGINT) keeps the finished rows, exits 130 with a line
# saying how to resume; a worker killed mid-solve costs the one row it was
# computing (the rows it had been handed but not begun go to another
# worker), not the solve.  The kills wait for rows in OUT.partial, not for a time.
# Cost: ~6 s (a Cornell box of 907 patches, solved about four times over).
set -u
. "$(dirname "$0")/lib.bash"
args=(models/cornell.rad --patch-size 0.05 --processes 1)

# Rows in a partial file: its block heads (48 bytes of file and matrix head first).
rows_in() {
    python3 - "$1" <<'P'
import os, struct, sys
try:
    b = open(sys.argv[1], 'rb').read()
except OSError:
    print(0); sys.exit()
at, rows = 48, 0
while at + 24 <= len(b) and b[at:at + 4] == b'RBLK':
    n, length = struct.unpack_from('<IQ', b, at + 4)
    if at + 24 + length > len(b):
        break
    rows += n
    at += 24 + length
print(rows)
P
}
# The same, roughly and cheaply, while polling: block tags in the file.
tags_in() { grep -a -o RBLK "$1" 2> /dev/null | wc -l; }
# Starts a solve in a process group of its own; waits until OUT.partial
# holds at least WANT rows (or the solve ended), then sends SIGNAL to the
# group (SIGKILL) or to the solve alone (SIGINT).  Sets rc and kept.
solve_then() { # OUT WANT SIGNAL
    local out=$1 want=$2 sig=$3
    setsid "$BIN" solve "${args[@]}" -o "$out" > "$dir/stdout" 2> "$dir/stderr" &
    local pid=$!
    for _ in $(seq 1 3000); do
        [ "$(tags_in "$out.partial")" -ge "$want" ] && break
        kill -0 "$pid" 2> /dev/null || break
        sleep 0.02
    done
    if [ "$sig" = KILL ]; then kill -KILL -- "-$pid" 2> /dev/null; else kill -INT "$pid" 2> /dev/null; fi
    wait "$pid" 2> /dev/null
    rc=$?
    kept=$(rows_in "$out.partial")
}
numbers() { "$BIN" report "$1" --json | sed -e 's/"stages": {.*//' -e 's/"solution": "[^"]*"//' -e 's/"rows_computed": [0-9]*//'; }

"$BIN" solve "${args[@]}" -o "$dir/ref.sol" > "$dir/ref.out" 2>&1 || { cat "$dir/ref.out"; exit 1; }
total=$(sed -n 's/.* \([0-9]*\) rows computed.*/\1/p' "$dir/ref.out" | head -n 1)
"$BIN" render "$dir/ref.sol" -o "$dir/ref.exr" --size 64x64 > /dev/null 2>&1

# SIGKILL part-way, then the same command again.  The solve renders 64
# sample rows first for its memory estimate (issue 15), journaled like the
# others: killed after 100 rows, the second run resumes them, samples among
# the rows still missing, and its estimate counts every row of the solve.
solve_then "$dir/a.sol" 100 KILL
if [ "$rc" -eq 137 ] && [ ! -e "$dir/a.sol" ] && [ "$kept" -ge 100 ] && [ "$kept" -lt "$total" ]; then
    ok "killed (SIGKILL) with $kept of $total rows in a.sol.partial"
else
    bad "kill: exit $rc, $kept rows kept of $total, $(cat "$dir/stderr")"
fi
"$BIN" solve "${args[@]}" -o "$dir/a.sol" > "$dir/again.out" 2>&1
computed=$(sed -n 's/.* \([0-9]*\) rows computed.*/\1/p' "$dir/again.out" | head -n 1)
resumed=$(sed -n 's/^resumed: \([0-9]*\) rows.*/\1/p' "$dir/again.out")
"$BIN" render "$dir/a.sol" -o "$dir/a.exr" --size 64x64 > /dev/null 2>&1
estimated=$(sed -n 's/^estimate: .* patches .*, \([0-9]*\) rows of about .*/\1/p' "$dir/again.out")
if [ -n "$resumed" ] && [ "$resumed" -ge $((kept - 1)) ] && [ "$((resumed + computed))" -eq "$total" ] &&
   [ "$estimated" = "$total" ] &&
   [ ! -e "$dir/a.sol.partial" ] && cmp -s "$dir/ref.exr" "$dir/a.exr" &&
   [ "$(numbers "$dir/a.sol")" = "$(numbers "$dir/ref.sol")" ]; then
    ok "run again: $resumed rows resumed, $computed computed, the same solution"
else
    bad "resume: resumed '$resumed', computed '$computed' of $total; $(cat "$dir/again.out")"
fi

# Ctrl-C: exit 130, the rows kept, one line saying how to resume.
solve_then "$dir/b.sol" 50 INT
if [ "$rc" -eq 130 ] && [ ! -e "$dir/b.sol" ] && [ "$kept" -ge 50 ] &&
   grep -q "^radiosity: interrupted: $kept form-factor rows kept in .*b.sol.partial; run the same command again to resume$" "$dir/stderr"; then
    ok "Ctrl-C: $(cat "$dir/stderr")"
else
    bad "Ctrl-C: exit $rc, $kept rows kept, $(cat "$dir/stderr")"
fi
"$BIN" solve "${args[@]}" -o "$dir/b.sol" > "$dir/again.out" 2>&1
"$BIN" render "$dir/b.sol" -o "$dir/b.exr" --size 64x64 > /dev/null 2>&1
if grep -q "^resumed: $kept rows" "$dir/again.out" && cmp -s "$dir/ref.exr" "$dir/b.exr"; then
    ok "after Ctrl-C, run again: $(grep resumed "$dir/again.out")"
else
    bad "after Ctrl-C: $(cat "$dir/again.out")"
fi

# A worker killed mid-solve costs the row it was computing, not the solve.
setsid "$BIN" solve "${args[@]}" -o "$dir/c.sol" --processes 2 > "$dir/stdout" 2> "$dir/stderr" &
pid=$!
for _ in $(seq 1 3000); do
    [ "$(tags_in "$dir/c.sol.partial")" -ge 100 ] && break
    kill -0 "$pid" 2> /dev/null || break
    sleep 0.02
done
worker=$(pgrep -P "$pid" | head -n 1)
[ -n "$worker" ] && kill -KILL "$worker"
wait "$pid"
rc=$?
"$BIN" render "$dir/c.sol" -o "$dir/c.exr" --size 64x64 > /dev/null 2>&1
if [ -n "$worker" ] && [ "$rc" -eq 0 ] && cmp -s "$dir/ref.exr" "$dir/c.exr" &&
   grep -q " $total rows computed" "$dir/stdout"; then
    ok "a worker killed mid-solve (pid $worker): the solve goes on, the same solution"
else
    bad "worker killed mid-solve: worker '$worker', exit $rc, $(cat "$dir/stdout" "$dir/stderr")"
fi

echo "resume.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
