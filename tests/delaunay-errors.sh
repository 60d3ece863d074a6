#!/bin/sh
# Bad input to pdr delaunay and pdr check: every malformed file is reported
# as file:line with exit status 1 and nothing written; usage errors exit 2;
# a corrupted .ele makes pdr check fail with the right defect counted.
# shellcheck disable=SC2016 # awk programs in single quotes
set -u
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdr-delerr-XXXXXX") || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# expect_error FILE-CONTENT MESSAGE-REGEX: pdr delaunay must exit 1, print
# the message, and leave the old output untouched and no temporary file.
n=0
expect_error() {
    n=$((n + 1))
    printf '%b' "$1" >"$tmp/bad$n.node"
    echo old >"$tmp/out$n.ele"
    "$PDR" delaunay "$tmp/bad$n.node" -o "$tmp/out$n" >"$tmp/log" 2>&1
    rc=$?
    [ $rc -eq 1 ] || fail "case $n: exit status $rc, expected 1 ($(cat "$tmp/log"))"
    grep -Eq "$2" "$tmp/log" || fail "case $n: message '$(cat "$tmp/log")' does not match '$2'"
    [ "$(cat "$tmp/out$n.ele")" = old ] || fail "case $n: old output was overwritten"
    [ ! -e "$tmp/out$n.node" ] || fail "case $n: a .node was written"
    for f in "$tmp"/*.tmp.*; do [ -e "$f" ] && fail "case $n: temporary file left: $f"; done
    return 0
}

expect_error '4 2 0 0\n1 0 0\n2 1 0\n3 0 1\n4 1 1\n' 'bad1\.node:1: dimension must be 3, not 2'
expect_error '4 3 0 0\n1 0 0 0\n2 1 abc 0\n3 0 1 0\n4 0 0 1\n' 'bad2\.node:3: y coordinate: .abc. is not a number'
expect_error '4 3 0 0\n1 0 0 0\n2 1 0 0\n4 0 1 0\n5 0 0 1\n' 'bad3\.node:4: point index 4 out of sequence \(expected 3\)'
expect_error '10 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n' 'bad4\.node:6: file ends after 5 of 10 points'
expect_error '# nothing\n\n' 'bad5\.node: empty file'
expect_error '3 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n' 'bad6\.node: 3 points: a tetrahedralization needs at least 4'
expect_error '5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n5 2 3 0\n' 'coplanar'
expect_error '4 3 0 0\n1 0 0 0\n2 1 0 0 7\n3 0 1 0\n4 0 0 1\n' "bad8\.node:3: unexpected '7' after the point's values"
expect_error '4 3 0 0\n2 0 0 0\n3 1 0 0\n4 0 1 0\n5 0 0 1\n' 'bad9\.node:2: the first point index must be 0 or 1, not 2'
expect_error '4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1e999\n' 'bad10\.node:5: z coordinate 1e999 is not a finite number'
expect_error '-4 3 0 0\n' 'bad11\.node:1: point count -4 is out of range'

"$PDR" delaunay "$tmp/missing.node" >"$tmp/log" 2>&1
[ $? -eq 1 ] || fail "missing input should exit 1"
grep -q "missing.node: cannot open: No such file" "$tmp/log" || fail "missing input: $(cat "$tmp/log")"

# Usage errors exit 2.
for args in "" "--random 10 $tmp/x.node" "--bogus" "--random abc" "--random 10 --faces" \
    "--seed x --random 10" "a.node b.node"; do
    # shellcheck disable=SC2086
    "$PDR" delaunay $args >"$tmp/log" 2>&1
    [ $? -eq 2 ] || fail "pdr delaunay $args: expected exit 2 ($(cat "$tmp/log"))"
done
"$PDR" check >/dev/null 2>&1
[ $? -eq 2 ] || fail "pdr check without a mesh should exit 2"
"$PDR" delaunay --help | grep -q '^Usage: pdr delaunay' || fail "no delaunay --help"
"$PDR" check --help | grep -q '^Usage: pdr check' || fail "no check --help"

# A good mesh, then corrupted copies of its .ele.
"$PDR" delaunay --random 500 --seed 2 -o "$tmp/m" -q || fail "could not make a mesh"
"$PDR" check -q "$tmp/m" >/dev/null || fail "the good mesh does not pass"
corrupt() { # corrupt NAME AWK-PROGRAM: m.ele through awk into NAME.ele
    cp "$tmp/m.node" "$tmp/$1.node"
    grep -v '^#' "$tmp/m.ele" | awk "$2" >"$tmp/$1.ele"
}
expect_defect() { # expect_defect NAME REGEX
    "$PDR" check "$tmp/$1" >"$tmp/log" 2>&1
    rc=$?
    [ $rc -eq 1 ] || fail "pdr check $1: exit $rc, expected 1 ($(cat "$tmp/log"))"
    grep -q '^FAILED' "$tmp/log" || fail "pdr check $1: no FAILED verdict"
    grep -Eq "$2" "$tmp/log" || fail "pdr check $1: '$2' not found in: $(cat "$tmp/log")"
}
# Two vertices swapped in one tetrahedron: inverted.
corrupt swapped 'NR == 10 { t = $2; $2 = $3; $3 = t } { print }'
expect_defect swapped 'inverted tetrahedra +1 +<-- DEFECT'
# One tetrahedron removed: a hole whose faces have no neighbour.
corrupt holed 'NR == 1 { $1 = $1 - 1 } NR == 20 { next } NR > 20 { $1 = $1 - 1 } { print }'
expect_defect holed '(open|non-convex) convex hull edges +[1-9]|hull edges +[1-9]'
# One tetrahedron replaced by a copy of another: faces in three tets.
corrupt doubled 'NR == 8 { a = $2; b = $3; c = $4; d = $5 } NR == 9 { $2 = a; $3 = b; $4 = c; $5 = d } { print }'
expect_defect doubled 'faces in more than two tetrahedra +[1-9]'
# A vertex moved: no longer Delaunay (or worse).
cp "$tmp/m.ele" "$tmp/moved.ele"
grep -v '^#' "$tmp/m.node" | awk 'NR == 101 { $2 = $2 + 0.2 } { print }' >"$tmp/moved.node"
expect_defect moved '(not locally Delaunay|inverted tetrahedra|folded faces) +[1-9]'
# Parse errors in .ele are file:line errors.
corrupt range 'NR == 5 { $3 = 9999 } { print }'
"$PDR" check "$tmp/range" >"$tmp/log" 2>&1
[ $? -eq 1 ] || fail "out-of-range node should exit 1"
grep -q 'range\.ele:5: node number 9999 is out of range \[1, 500\]' "$tmp/log" ||
    fail "out-of-range node: $(cat "$tmp/log")"
corrupt five 'NR == 1 { $2 = 5 } { print }'
"$PDR" check "$tmp/five" >"$tmp/log" 2>&1
grep -q 'five\.ele:1: nodes per tetrahedron must be 4 or 10, not 5' "$tmp/log" ||
    fail "bad nodes per tet: $(cat "$tmp/log")"
"$PDR" check "$tmp/nothere" >"$tmp/log" 2>&1
[ $? -eq 1 ] || fail "missing mesh should exit 1"
grep -q 'nothere.node: cannot open' "$tmp/log" || fail "missing mesh: $(cat "$tmp/log")"
echo "pdr delaunay/check errors: ok ($n malformed .node files)"
