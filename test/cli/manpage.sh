#!/usr/bin/env bash
# manpage.sh - the manual page docs/radiosity.1 (written by hand) against
# the program's own usage text: every command `radiosity --help` lists has
# a section (.SS) of its own, every long option it prints is named in the
# page, and the page's version is the program's.  A failure names what is
# missing, so that a new option is added to both.  Cost: one --help.
set -u
cd "$(dirname "$0")/../.."
. test/cli/lib.bash
page=docs/radiosity.1

"$BIN" --help > "$dir/help" 2>&1 || bad "--help exited non-zero"
# The page as text: roff's escaped hyphens and font changes undone.
sed -e 's/\\-/-/g' -e 's/\\f[BIRP]//g' "$page" > "$dir/page"

# Commands: the usage text's "  NAME ARG..." lines under "commands:".
cmds=$(sed -n '/^commands:/,/^$/p' "$dir/help" | sed -n 's/^  \([a-z][a-z0-9-]*\) .*/\1/p' | sort -u)
missing=""
for c in $cmds; do
    grep -Eq "^\.SS \"?$c( |\"|$)" "$dir/page" || missing="$missing $c"
done
if [ -n "$cmds" ] && [ -z "$missing" ]; then
    ok "every command has a section: $(echo $cmds)"
else
    bad "commands without a .SS section in $page:${missing:- (no commands found in --help)}"
fi

# Long options: every --word in the usage text, as a whole word in the page.
opts=$(grep -oE -- '--[a-z][a-z0-9-]*' "$dir/help" | sort -u)
missing=""
for o in $opts; do
    grep -Eq -- "(^|[^a-z0-9-])$o([^a-z0-9-]|$)" "$dir/page" || missing="$missing $o"
done
if [ "$(wc -w <<<"$opts")" -ge 40 ] && [ -z "$missing" ]; then
    ok "all $(wc -w <<<"$opts") long options of --help are in $page"
else
    bad "options printed by --help but missing from $page:${missing:- (fewer than 40 options found)}"
fi

# The version in the page's title line is the program's.
v=$("$BIN" --version | sed -n '1s/^radiosity //p')
if [ -n "$v" ] && grep -q "^\.TH RADIOSITY 1 .*\"radiosity $v\"" "$page"; then
    ok "the page is the manual of radiosity $v"
else
    bad "the .TH line of $page does not say \"radiosity $v\": $(grep '^\.TH' "$page")"
fi

echo "manpage.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
