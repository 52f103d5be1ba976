# lib.bash - shared by the command-line tests (sourced, not run: run_tests.sh
# runs test/cli/*.sh only): the program under test, a scratch directory
# removed on exit, the counters each script ends by printing.

BIN=${RADIOSITY_BIN:-build/release/radiosity}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
passed=0; failed=0

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
