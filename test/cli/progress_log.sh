#!/usr/bin/env bash
# progress_log.sh - a solve whose stderr is a file (a log, not a terminal)
# writes a plain progress line every RADIOSITY_PROGRESS_SECONDS for the
# form-factor rows and for the element hemi-cubes, each with the count, the
# rate and the time left, and a last line at 100 % (issue 36); a solve
# shorter than the interval leaves the log empty.
set -u
. "$(dirname "$0")/lib.bash"

# The Cornell box at 0.08 (about 300 rows, then about 500 element
# hemi-cubes, most of them near views) on one worker: the rows take about
# 0.3 s, each job of element hemi-cubes 0.05-0.1 s, so lines every 0.01 s
# (measured 2026-12-08: 14-15 row lines, 11-13 element lines).
RADIOSITY_PROGRESS_SECONDS=0.01 "$BIN" solve models/cornell.rad -o "$dir/c.sol" --patch-size 0.08 \
    --processes 1 > "$dir/out" 2> "$dir/log"
st=$?
row='^radiosity: form factors: [0-9]+/[0-9]+ rows \([0-9]+%\), [0-9.]+ rows/s, [0-9hms]+ elapsed, ETA [0-9hms]+$'
el='^radiosity: elements: [0-9]+/[0-9]+ hemi-cubes \([0-9]+%\), [0-9.]+ hemi-cubes/s, [0-9hms]+ elapsed, ETA [0-9hms]+$'
nrow=$(grep -Ec "$row" "$dir/log")
nel=$(grep -Ec "$el" "$dir/log")
if [ "$st" -eq 0 ] && [ "$nrow" -ge 2 ] && [ "$nel" -ge 2 ]; then
    ok "log: $nrow form-factor lines, $nel element lines"
else
    bad "log: status $st, $nrow form-factor lines, $nel element lines: $(head -c 600 "$dir/log")"
fi

# Every line is one of the two (no carriage returns, no bar), and each job
# ends with its count complete.
if ! grep -Evq "$row|$el" "$dir/log" && ! grep -q $'\r' "$dir/log" &&
   grep -Eq '^radiosity: form factors: ([0-9]+)/\1 rows \(100%\)' "$dir/log" &&
   grep -Eq '^radiosity: elements: ([0-9]+)/\1 hemi-cubes \(100%\)' "$dir/log"; then
    ok "log: plain lines only, each job ends at 100 %"
else
    bad "log: $(grep -Ev "$row|$el" "$dir/log" | head -3)"
fi

# The counts a line gives grow within a job and never pass the total.
if awk -F'[ /]' '/form factors:/ { d = $4; t = $5; if (d > t || (t == lt && d < ld)) bad = 1; ld = d; lt = t }
                 END { exit bad }' "$dir/log"; then
    ok "log: counts grow to their total"
else
    bad "log: counts out of order: $(grep 'form factors' "$dir/log" | head -5)"
fi

# A solve shorter than the default interval (5 s) writes nothing to the log.
room > "$dir/room.rad"
if "$BIN" solve "$dir/room.rad" -o "$dir/r.sol" > /dev/null 2> "$dir/quiet" && [ ! -s "$dir/quiet" ]; then
    ok "short solve: empty log"
else
    bad "short solve: $(head -c 300 "$dir/quiet")"
fi

echo "progress_log.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
