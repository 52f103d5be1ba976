# lib.bash - shared by the command-line tests (sourced, not run: run_tests.sh
# runs test/cli/*.sh only): the program under test, a scratch directory
# removed on exit, the counters each script ends by printing and the two
# functions that count.

BIN=${RADIOSITY_BIN:-build/release/radiosity}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
passed=0; failed=0

# ok TEXT / bad TEXT: count a check passed or failed and say which.
ok()  { passed=$((passed + 1)); echo "ok   $1"; }
bad() { failed=$((failed + 1)); echo "FAIL $1"; }

# room: a small valid polygon file (a floor and a lamp above it) that tests
# edit with sed to make one thing wrong or different.
room() {
cat <<'R'
bands 3
material white reflectance 0.5 0.5 0.5
material lamp reflectance 0 emission 10 10 10
polygon floor white
  0 0 0   0 0 1   1 0 1   1 0 0
end
polygon lamp lamp
  0.4 1 0.4   0.6 1 0.4   0.6 1 0.6   0.4 1 0.6
end
R
}

# section_at FILE TAG: the byte offset and length of section TAG's body in a
# version 6 file (its index at the end), or nothing when there is none.
section_at() { # FILE TAG
    python3 - "$1" "$2" <<'P'
import struct, sys
b = open(sys.argv[1], 'rb').read()
at = struct.unpack_from('<Q', b, 16)[0]
count = struct.unpack_from('<I', b, at)[0]
for q in range(count):
    tag, _, off, length, crc = struct.unpack_from('<4sIQQQ', b, at + 8 + 32 * q)
    if tag == sys.argv[2].encode():
        print(off, length)
P
}
# section_body FILE TAG: that body on stdout; status 1 when there is none.
section_body() {
    local off len
    read -r off len < <(section_at "$1" "$2")
    [ -n "${len:-}" ] || return 1
    tail -c +$((off + 1)) "$1" | head -c "$len"
}
