#!/bin/sh
# pdr mesh refuses malformed input with the reader's file:line message and
# writes nothing; usage errors exit 2; a bound below 2 warns but runs.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-errors.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
data=$top_srcdir/tests/data/plc

# fixture | a line that must appear on stderr, verbatim
while IFS='|' read -r file msg; do
    [ -n "$file" ] || continue
    (cd "$data" && "$PDR" mesh -o "$tmp/out" "$file") >"$tmp/stdout" 2>"$tmp/stderr"
    rc=$?
    [ $rc -eq 1 ] || fail "$file: exit $rc, expected 1"
    grep -Fqx -- "$msg" "$tmp/stderr" || { cat "$tmp/stderr"; fail "$file: missing: $msg"; }
    ls "$tmp" | grep -q '^out\.' && fail "$file: output written although the input was refused"
done <<'TABLE'
bad-number.poly|bad-number.poly:6: y coordinate: 'x1' is not a number
truncated.poly|truncated.poly:15: unexpected end of file while reading the facet list
non-planar.poly|non-planar.poly:22: facet 6 is not planar: vertex 8 is 0.0025 away from its plane (tolerance 1.74e-09)
open-box.poly|open-box.poly:16: facet 3: edge (5, 6) belongs to no other facet (the surface is open there)
intersecting.poly|intersecting.poly:22: facets 2 and 9 (line 36) intersect near (1, 0.5, 0.75)
TABLE

"$PDR" mesh "$tmp/none.poly" >/dev/null 2>"$tmp/stderr"
[ $? -eq 1 ] || fail "missing input: exit status"
grep -q 'none.poly' "$tmp/stderr" || fail "missing input not named"

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || exit 99
for args in "-q 1" "-q 0.5" "-q x" "-a 0" "-a -1" "-f png" "--mo dense" "--bogus" \
    "$tmp/cic.poly $tmp/cic.poly" "--domain moon"; do
    # shellcheck disable=SC2086
    "$PDR" mesh $args -o "$tmp/u" >/dev/null 2>"$tmp/stderr"
    rc=$?
    [ $rc -eq 2 ] || fail "'$args': exit $rc, expected 2"
    [ -s "$tmp/stderr" ] || fail "'$args': no message"
    ls "$tmp" | grep -q '^u\.' && fail "'$args': output written"
done

# B < 2: accepted with a warning, and the bound is met.
"$PDR" mesh -q 1.5 -a 0.005 -o "$tmp/w" "$tmp/cic.poly" >"$tmp/stdout" 2>"$tmp/stderr" ||
    fail "-q 1.5 exited $?"
grep -q 'warning: with -q 1.5 below 2, termination is not guaranteed' "$tmp/stderr" ||
    fail "no warning for -q 1.5"
grep -q '^left above the bound: 0 tetrahedra with radius-edge >= 1.5$' "$tmp/stdout" ||
    fail "-q 1.5 left tetrahedra"
"$PDR" check -q --max-ratio 1.5 "$tmp/w" || fail "-q 1.5 mesh"
echo "ok"
