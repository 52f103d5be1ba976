#!/usr/bin/env bash
# gather.sh - `radiosity render --gather`: images written, the cache saved
# beside the solution and reused by the next render, a stale cache refused
# with a warning, report's cache line, option errors.  Cost ~2 s.
set -u
. "$(dirname "$0")/lib.bash"

check() { # name, command status (0 = ok), detail on failure
    if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"
    else failed=$((failed + 1)); echo "FAIL $1: $3"; fi
}

room > "$dir/room.rad"
"$BIN" solve "$dir/room.rad" -o "$dir/room.sol" --processes 1 > /dev/null 2>&1
g=(render "$dir/room.sol" --gather --size 32x32 --eye 0.5,0.6,-1 --target 0.5,0,0.5)

"$BIN" "${g[@]}" -o "$dir/a.exr" --png "$dir/a.png" > "$dir/out1" 2> "$dir/err1"
s=$?
[ $s -eq 0 ] && [ -s "$dir/a.exr" ] && [ -s "$dir/a.png" ] && [ -s "$dir/room.sol.icache" ] &&
    grep -Eq "gather: 1024 pixels in .* [1-9][0-9]* gathers" "$dir/out1"
check "first render writes the images and the cache" $? "$(cat "$dir/out1" "$dir/err1")"

"$BIN" "${g[@]}" -o "$dir/b.exr" > "$dir/out2" 2>&1
grep -q " 0 gathers (0.00 % of pixels)" "$dir/out2" && cmp -s "$dir/a.exr" "$dir/b.exr"
check "second render reuses the cache: no gather, the same image" $? "$(cat "$dir/out2")"

"$BIN" report "$dir/room.sol" > "$dir/rep" 2>&1
grep -Eq "gather cache: .*room.sol.icache \(current\): [0-9]+ records" "$dir/rep"
check "report prints the cache" $? "$(grep -i cache "$dir/rep")"
"$BIN" report "$dir/room.sol" --json | grep -q '"gather_cache": {"file": '
check "report --json prints the cache" $? "$("$BIN" report "$dir/room.sol" --json | tail -2)"

# another epsilon: another key, the file is refused with a warning and rebuilt
"$BIN" "${g[@]}" -o "$dir/c.exr" --epsilon 0.2 > "$dir/out3" 2> "$dir/err3"
[ $? -eq 0 ] && grep -q "radiosity: warning: .*room.sol.icache: made for another solution or other settings" "$dir/err3" &&
    grep -Eq " [1-9][0-9]* gathers" "$dir/out3"
check "a stale cache is refused with a warning and computed anew" $? "$(cat "$dir/out3" "$dir/err3")"

# a damaged cache likewise
printf 'garbage' > "$dir/room.sol.icache"
"$BIN" "${g[@]}" -o "$dir/d.exr" > /dev/null 2> "$dir/err4"
[ $? -eq 0 ] && grep -q "radiosity: warning: .*not an irradiance cache file" "$dir/err4"
check "a damaged cache is refused with a warning" $? "$(cat "$dir/err4")"

# the reference mode writes no cache
rm -f "$dir/x.icache"
"$BIN" "${g[@]}" -o "$dir/e.exr" --no-cache --cache "$dir/x.icache" > /dev/null 2>&1
[ $? -eq 0 ] && [ ! -e "$dir/x.icache" ]
check "--no-cache neither reads nor writes a cache file" $? ""

# option errors: one line, status 2
"$BIN" render "$dir/room.sol" -o "$dir/f.exr" --epsilon 0.1 > /dev/null 2> "$dir/err5"
[ $? -eq 2 ] && grep -q "radiosity: error: render: --epsilon is a --gather option" "$dir/err5"
check "a gather option without --gather is refused" $? "$(cat "$dir/err5")"
"$BIN" "${g[@]}" -o "$dir/f.exr" --epsilon 3 > /dev/null 2> "$dir/err6"
[ $? -eq 2 ] && grep -q "radiosity: error: --epsilon: '3' is not a number in" "$dir/err6"
check "--epsilon out of range is refused" $? "$(cat "$dir/err6")"
"$BIN" "${g[@]}" -o "$dir/f.exr" --glossy shiny > /dev/null 2> "$dir/err7"
[ $? -eq 2 ] && grep -q "glossy: 'shiny' is not auto, sample or light-vector" "$dir/err7"
check "--glossy with an unknown mode is refused" $? "$(cat "$dir/err7")"

echo "gather.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
