#!/bin/sh
# Memory failure (issue 14): every allocation goes through proto's hook
# (proto/pr_alloc.h), and PDR_ALLOC_FAIL=N makes the N-th allocation of a
# pdr run and every later one fail. For each command below the test first
# runs it with PDR_ALLOC_FAIL=0 (count only) to learn its number of
# allocations T, then for every N in 1..T runs it again in a fresh
# directory with PDR_ALLOC_FAIL=N and requires: exit status 1, one line
# saying "pdr COMMAND: out of memory" (and no other line about memory),
# no file left behind (no output, no temporary),
# and, in the sanitizer build, no AddressSanitizer, LeakSanitizer or UBSan
# report. PDR_ALLOC_FAIL=T+1 must then succeed, so 1..T was every
# allocation of the run. The commands: pdr mesh (conforming and
# constrained), pdr delaunay (random points and a .node file), pdr check
# and pdr domain, on inputs small enough that all of them together make a
# few hundred allocations. Past ALLOC_FAIL_ALL (3000) allocations, N goes on
# in ALLOC_FAIL_STEPS (500) even steps up to T. Cases run ALLOC_FAIL_JOBS
# (2) at a time.
#
#   tests/alloc-fail.sh --case DIR N ARGS...   one case (used by xargs)
set -u

# One case: pdr ARGS with the N-th allocation failing, in DIR/N (fresh).
if [ "${1:-}" = --case ]; then
    top=$2
    n=$3
    shift 3
    dir=$top/$n
    log=$top/log.$n
    mkdir "$dir" || exit 99
    (cd "$dir" && PDR_ALLOC_FAIL=$n exec "$PDR" "$@") >"$log" 2>&1
    rc=$?
    why=
    [ $rc -eq 1 ] || why="; exit $rc, expected 1"
    # One line says it, naming the command: "pdr mesh: out of memory".
    noom=$(grep -c 'out of memory' "$log")
    [ "$noom" -eq 1 ] || why="$why; $noom lines say 'out of memory', expected 1"
    grep -q "^pdr $1: out of memory" "$log" || why="$why; no 'pdr $1: out of memory' line"
    grep -q '^pdr: allocations: [0-9]* made, [1-9][0-9]* refused$' "$log" ||
        why="$why; no allocation was refused"
    grep -Eq 'Sanitizer|runtime error:' "$log" && why="$why; sanitizer report"
    left=$(ls -A "$dir")
    [ -z "$left" ] || why="$why; left files: $(echo "$left" | tr '\n' ' ')"
    if [ -n "$why" ]; then
        {
            echo "FAIL: PDR_ALLOC_FAIL=$n pdr $*: ${why#; }"
            sed 's/^/    /' "$log" | head -n 40
        } >"$top/fail.$n"
        exit 1
    fi
    rm -rf "$dir" "$log"
    exit 0
fi

fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/alloc-fail.$$
mkdir -p "$tmp/in" || exit 99
trap 'rm -rf "$tmp"' EXIT
all=${ALLOC_FAIL_ALL:-3000}
steps=${ALLOC_FAIL_STEPS:-500}
jobs=${ALLOC_FAIL_JOBS:-2}
self=$top_srcdir/tests/alloc-fail.sh

# A malformed PDR_ALLOC_FAIL is a usage error, not ignored.
PDR_ALLOC_FAIL=x "$PDR" info >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] || fail "PDR_ALLOC_FAIL=x: exit status $?, expected 2"
grep -q "PDR_ALLOC_FAIL='x'" "$tmp/err" || fail "PDR_ALLOC_FAIL=x: no message"

# Inputs, made without failures: the built-in cube with a cubical void
# (conforming mode) and a tiny point set.
(cd "$tmp/in" && "$PDR" domain cube-in-cube -o cic.poly >/dev/null) || exit 99
(cd "$tmp/in" && "$PDR" delaunay --random 60 --points-only -o pts -q) || exit 99

total=0
# sweep NAME ARGS...: learns T, runs every case, checks T+1.
sweep() {
    name=$1
    shift
    d=$tmp/$name
    mkdir "$d" || exit 99
    (cd "$d" && PDR_ALLOC_FAIL=0 "$PDR" "$@") >"$tmp/count" 2>&1 ||
        fail "$name: exit $? without failures: $(cat "$tmp/count")"
    t=$(sed -n 's/^pdr: allocations: \([0-9]*\) made, 0 refused$/\1/p' "$tmp/count")
    [ -n "$t" ] || fail "$name: no allocation count: $(cat "$tmp/count")"
    [ "$t" -gt 10 ] || fail "$name: only $t allocations"
    rm -rf "${d:?}"/*
    start=$(date +%s)
    if [ "$t" -le "$all" ]; then
        seq 1 "$t"
    else
        seq 1 "$all"
        seq "$all" $(((t - all + steps - 1) / steps)) "$t" | sed 1d
    fi >"$tmp/cases"
    ncases=$(wc -l <"$tmp/cases")
    xargs -P "$jobs" -I{} "${SHELL:-/bin/sh}" "$self" --case "$d" {} "$@" <"$tmp/cases"
    nfail=$(find "$d" -name 'fail.*' | wc -l)
    if [ "$nfail" -gt 0 ]; then
        echo "FAIL: $name: $nfail of $ncases cases failed; the first ones:"
        find "$d" -name 'fail.*' | sed 's/.*fail\.//' | sort -n | head -n 5 |
            while read -r n; do cat "$d/fail.$n"; done
        exit 1
    fi
    (cd "$d" && PDR_ALLOC_FAIL=$((t + 1)) "$PDR" "$@") >"$tmp/count" 2>&1 ||
        fail "$name: PDR_ALLOC_FAIL=$((t + 1)) (one past the count) failed: $(cat "$tmp/count")"
    grep -q '^pdr: allocations: [0-9]* made, 0 refused$' "$tmp/count" ||
        fail "$name: PDR_ALLOC_FAIL=$((t + 1)) refused an allocation"
    echo "ok: $name: $t allocations, $ncases failed in turn ($(($(date +%s) - start)) s)"
    total=$((total + ncases))
}

# pdr mesh in the conforming mode, every output format (written as one
# set: a failure in the last writer leaves none of them).
sweep mesh mesh "$tmp/in/cic.poly" -o out -f node,vtu,msh
# pdr mesh in the constrained mode on a triangulated surface (.off).
sweep mesh-cdt mesh "$top_srcdir/tests/data/plc/tet.off" -o out --mo cdt
# pdr delaunay on random points with the exact check, and on a .node file.
sweep delaunay delaunay --random 200 -o out --faces --check
sweep delaunay-node delaunay "$tmp/in/pts.node" -o out --faces
# pdr check reads a mesh and writes nothing.
(cd "$tmp/in" && "$PDR" mesh cic.poly -o cic -Q) || exit 99
sweep check check "$tmp/in/cic"
# pdr domain writes a .poly.
sweep domain domain cube-in-cube -o out.poly
echo "ok: $total runs with a failing allocation, every one a clean 'out of memory'"
