#!/bin/sh
# Closed surfaces as input: an .off and an .stl tetrahedron surface (and a
# .smesh cube) mesh to radius-edge < 2 and pass pdr check against the
# input.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-surfaces.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
data=$top_srcdir/tests/data/plc
for f in tet.off tet.stl cube.smesh; do
    "$PDR" mesh -q 2 -a 0.001 -o "$tmp/$f" "$data/$f" >"$tmp/out" 2>&1 ||
        { rc=$?; cat "$tmp/out"; fail "$f: pdr mesh exited $rc"; }
    grep -q '^left above the bound: 0 ' "$tmp/out" || fail "$f: tetrahedra left"
    "$PDR" check --plc "$data/$f" --max-ratio 2 "$tmp/$f" >"$tmp/chk" ||
        { cat "$tmp/chk"; fail "$f: pdr check found defects"; }
    grep -Eq '^  facets covered by subfacets +[1-9]' "$tmp/chk" || fail "$f: coverage"
    echo "$f: $(grep '^mesh:' "$tmp/out")"
done
echo "ok"
