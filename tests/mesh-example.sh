#!/bin/sh
# TetGen's own example.poly (two regions with attributes and volume
# bounds, two holes, an inclined internal facet), read from Debian's
# tetgen package when it is installed: meshed with -q 2.0 and the input's
# regional volume bounds, it passes pdr check against the input, and the
# region attributes reach the .ele file.
set -u
fail() { echo "FAIL: $*"; exit 1; }
ex=${TETGEN_EXAMPLE:-/usr/share/doc/tetgen/examples/example.poly}
[ -r "$ex" ] || { echo "SKIP: $ex not found (Debian package tetgen)"; exit 77; }
tmp=$(pwd)/mesh-example.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$PDR" mesh -q 2.0 -o "$tmp/ex" "$ex" >"$tmp/out" 2>"$tmp/err" ||
    { rc=$?; cat "$tmp/out" "$tmp/err"; fail "pdr mesh exited $rc"; }
cat "$tmp/out"
grep -q '^input: .*: 28 vertices, .* 23 facets, 2 holes, 2 regions' "$tmp/out" ||
    fail "input summary"
grep -q '^left above the bound: 0 tetrahedra with radius-edge >= 2$' "$tmp/out" ||
    fail "tetrahedra left above the bound"
"$PDR" check --plc "$ex" --max-ratio 2 "$tmp/ex" >"$tmp/chk" ||
    { cat "$tmp/chk"; fail "pdr check found defects"; }
grep -Eq '^  facets not covered \(area differs\) +0$' "$tmp/chk" || fail "coverage"
# one attribute column carrying the two regions' attributes, 10 and 20
head -2 "$tmp/ex.ele" | grep -Eq '^ *[0-9]+ +4 +1$' || fail ".ele header: $(head -2 "$tmp/ex.ele")"
attrs=$(awk 'NR > 2 && $1 !~ /^#/ { print $6 }' "$tmp/ex.ele" | sort -u | tr '\n' ' ')
[ "$attrs" = "10 20 " ] || fail "region attributes are '$attrs', expected '10 20 '"
echo "ok"
