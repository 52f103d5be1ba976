#!/usr/bin/env bash
# check-structure.sh - keeps the tree's shape (issue 35); run by `make test`
# (test/run_tests.sh) or by hand after `make MODE=release prog`.  Three checks,
# each a pass or a failure naming every finding:
#
#   cycles     no circle among the object files of the release build: object
#              A uses B when A leaves a symbol undefined (nm: U) that B defines
#              (T, D, B, R, G, S); every strongly connected component of more
#              than one object is printed with the edges inside it.  Only the
#              library's and the program's objects count (the Makefile lists
#              them: `make print-objects`): tests, benchmarks and tools are
#              leaves, each one main linked against the library, which nothing
#              calls back, so they can close no circle; make also deletes their
#              objects after linking.  Weak symbols (C++ inline functions and
#              templates, defined in every object that uses them) are no edge.
#   names      no two source files (.c, .cpp, .h) of one name anywhere in the
#              tree; files named *_internal.h aside.
#   functions  at most MAX_LONG (5) functions longer than MAX_LINES (120)
#              lines in the tracked .c and .cpp files, counted from the line
#              of the opening brace to that of the closing one (both stand at
#              column 0 in this code base); each long one is printed.
#
# A check that cannot look (objects not built, or older than their source)
# fails with a message saying so; it never passes silently.  Needs bash, awk
# (mawk or gawk), nm (binutils) and make; git when the tree is a checkout.
# Prints "check-structure: N passed, N failed" last; exit 1 on any failure.
set -u
cd "$(dirname "$0")/.."
B=${B:-build/release}
MAX_LINES=${MAX_LINES:-120}
MAX_LONG=${MAX_LONG:-5}
passed=0; failed=0

verdict() { # check name, its status (0: passed)
    if [ "$2" -eq 0 ]; then
        echo "$1: ok"; passed=$((passed + 1))
    else
        echo "$1: FAILED"; failed=$((failed + 1))
    fi
}

# Tracked files matching the patterns; outside a git checkout, every such
# file but the build outputs.
sources() {
    if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
        git ls-files -- "$@"
    else
        local args=() p
        for p in "$@"; do args+=(-o -name "$p"); done
        find . -path ./build -prune -o -path ./.git -prune -o -type f \( "${args[@]:1}" \) -print |
            sed 's|^\./||' | sort
    fi
}

# ------------------------------------------------------------------ cycles
check_cycles() {
    local objs problems o src total=0 missing=() stale=()
    if ! command -v nm > /dev/null; then
        echo "  nm not found (binutils)"
        return 1
    fi
    # The parent make's jobserver is not ours: ask a make of our own.
    if ! objs=$(env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL \
                make -s --no-print-directory MODE=release B="$B" print-objects 2>&1) ||
        [ -z "$objs" ]; then
        echo "  cannot list the objects (make print-objects): ${objs:-no output}"
        return 1
    fi
    for o in $objs; do
        total=$((total + 1))
        src=${o#"$B"/obj/}; src=${src%.o}
        if [ -f "$src.c" ]; then src=$src.c; elif [ -f "$src.cpp" ]; then src=$src.cpp; fi
        if [ ! -f "$o" ]; then
            missing+=("$o")
        elif [ "$src" -nt "$o" ]; then
            stale+=("$o (older than $src)")
        fi
    done
    if [ "${#missing[@]}" -eq "$total" ]; then
        echo "  none of the $total objects is built ($B/obj/ is empty or absent)"
    else
        for o in "${missing[@]}"; do echo "  not built: $o"; done
    fi
    for o in "${stale[@]}"; do echo "  out of date: $o"; done
    problems=$((${#missing[@]} + ${#stale[@]}))
    if [ "$problems" -ne 0 ]; then
        echo "  build first: make MODE=release prog (cycles not checked)"
        return 1
    fi
    # nm -A -P: "FILE: SYMBOL TYPE [VALUE SIZE]", one line a symbol.
    nm -A -P $objs 2> /dev/null | awk -v strip="$B/obj/" '
        function short(o) { return index(o, strip) == 1 ? substr(o, length(strip) + 1) : o }
        function node(o) {
            if (!(o in id)) { id[o] = ++n; name[n] = short(o) }
            return id[o]
        }
        # Tarjan: every strongly connected component once, children first.
        function strong(v,    k, w) {
            idx[v] = low[v] = ++counter
            stack[++sp] = v; onstack[v] = 1
            for (k = 1; k <= deg[v]; k++) {
                w = adj[v, k]
                if (!(w in idx)) {
                    strong(w)
                    if (low[w] < low[v]) low[v] = low[w]
                } else if (onstack[w] && idx[w] < low[v]) {
                    low[v] = idx[w]
                }
            }
            if (low[v] == idx[v]) {
                size = 0
                do { w = stack[sp--]; onstack[w] = 0; member[++size] = w; comp[w] = v } while (w != v)
                if (size > 1) report(v)
            }
        }
        function report(root,    i, j, t, a, b, line) {
            for (i = 2; i <= size; i++)  # members by name (insertion sort)
                for (j = i; j > 1 && name[member[j]] < name[member[j - 1]]; j--) {
                    t = member[j]; member[j] = member[j - 1]; member[j - 1] = t
                }
            ncomp++
            line = "  circle " ncomp " (" size " objects):"
            for (i = 1; i <= size; i++) line = line " " name[member[i]]
            print line
            for (i = 1; i <= size; i++) {
                a = member[i]
                for (j = 1; j <= size; j++) {
                    b = member[j]
                    if ((a, b) in uses)
                        print "    " name[a] " -> " name[b] ": " example[a, b] \
                              (uses[a, b] > 1 ? " (+" uses[a, b] - 1 " more)" : "")
                }
            }
        }
        {
            o = $1; sub(/:$/, "", o); v = node(o)
            if ($3 == "U") { nu++; user[nu] = v; used[nu] = $2 }
            else if ($3 ~ /^[TDBRGS]$/) definer[$2] = definer[$2] " " v
        }
        END {
            for (k = 1; k <= nu; k++) {
                if (!(used[k] in definer)) continue  # libc, OpenEXR, Embree, ...
                m = split(definer[used[k]], d, " ")
                for (i = 1; i <= m; i++) {
                    a = user[k]; b = d[i] + 0
                    if (a == b) continue
                    if (!((a, b) in uses)) { adj[a, ++deg[a]] = b; example[a, b] = used[k] }
                    uses[a, b]++
                }
            }
            if (n == 0) { print "  nm read no symbols"; exit 1 }
            for (v = 1; v <= n; v++) if (!(v in idx)) strong(v)
            exit (ncomp > 0)
        }'
}

# ------------------------------------------------------------------- names
check_names() {
    sources '*.c' '*.cpp' '*.h' | awk '
        { base = $0; sub(/.*\//, "", base) }
        base ~ /_internal\.h$/ { next }
        { count[base]++; where[base] = where[base] " " $0 }
        END {
            for (b in count) if (count[b] > 1) { print "  " count[b] " files named " b ":" where[b]; bad++ }
            exit (bad > 0)
        }' | sort
    return "${PIPESTATUS[1]}"
}

# --------------------------------------------------------------- functions
check_functions() {
    local files
    files=$(sources '*.c' '*.cpp')
    if [ -z "$files" ]; then
        echo "  no .c or .cpp files found"
        return 1
    fi
    # shellcheck disable=SC2086 # file names have no spaces (the names check sees them)
    awk -v max_lines="$MAX_LINES" -v max_long="$MAX_LONG" '
        # The signature starts at column 0 with a word and holds a "(";
        # its continuation lines are indented.
        FNR == 1 { open = 0; sig = ""; sigline = 0 }
        /^[A-Za-z_]/ && /\(/ { sig = $0; sigline = FNR; next }
        /^\{/ { open = FNR; fname = sig; fline = sigline; next }
        /^\}/ {
            if (open && FNR - open > max_lines) {
                long++
                s = fname; sub(/\(.*/, "", s); sub(/.*[^A-Za-z0-9_]/, "", s)
                if (s ~ /^[A-Z0-9_]+$/) {  # a macro such as TEST(name): keep its argument
                    t = fname; sub(/^[^(]*\(/, "", t); sub(/\).*/, "", t); s = s "(" t ")"
                }
                printf "  %s:%d %s: %d lines\n", FILENAME, fline ? fline : open, s, FNR - open
            }
            open = 0
        }
        END {
            printf "  %d function%s over %d lines (at most %d allowed)\n", long, long == 1 ? "" : "s",
                   max_lines, max_long
            exit (long > max_long)
        }' $files
}

echo "== cycles among the objects of $B (library and program)"
check_cycles; verdict cycles $?
echo "== source files of one name"
check_names; verdict names $?
echo "== functions over $MAX_LINES lines"
check_functions; verdict functions $?
echo "check-structure: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
