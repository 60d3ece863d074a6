#!/bin/sh
# Malformed PLC inputs (tests/data/plc) give the documented file:line
# message, and nothing is written when the input is refused.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tool=$top_builddir/tests/plc_tool
[ -x "$tool" ] || { echo "plc_tool not built"; exit 99; }
out=$(pwd)/plc-errors.$$
mkdir -p "$out" || exit 99
trap 'rm -rf "$out"' EXIT
cd "$top_srcdir/tests/data/plc" || exit 99

# fixture | a line that must appear in the diagnostics, verbatim
while IFS='|' read -r file msg; do
    [ -n "$file" ] || continue
    rm -f "$out/w.poly"
    "$tool" "$file" -o "$out/w.poly" >"$out/stdout" 2>"$out/stderr"
    rc=$?
    [ $rc -eq 1 ] || fail "$file: exit $rc, expected 1"
    grep -Fqx -- "$msg" "$out/stderr" || {
        cat "$out/stderr"
        fail "$file: missing message: $msg"
    }
    [ ! -e "$out/w.poly" ] || fail "$file: output written although the input was refused"
    ls "$out" | grep -q tmp && fail "$file: a temporary file was left behind"
done <<'TABLE'
bad-number.poly|bad-number.poly:6: y coordinate: 'x1' is not a number
index-out-of-range.poly|index-out-of-range.poly:23: vertex index 9 is out of range [1, 8]
gap-numbering.poly|gap-numbering.poly:5: vertex number 4 where 3 was expected (numbers must be consecutive)
truncated.poly|truncated.poly:15: unexpected end of file while reading the facet list
missing-node.poly|missing-node.poly:3: the vertex count is 0, so the vertices must be in missing-node.node
duplicate-vertex.poly|duplicate-vertex.poly:11: vertex 9 duplicates vertex 6 (same coordinates)
repeated-corner.poly|repeated-corner.poly:23: facet 6: polygon uses vertex 6 more than once
zero-area.poly|zero-area.poly:26: facet 7: polygon has zero area (its corners are collinear)
non-planar.poly|non-planar.poly:22: facet 6 is not planar: vertex 8 is 0.0025 away from its plane (tolerance 1.74e-09)
crossing-segments.poly|crossing-segments.poly:20: facet 5: edges (2, 3) and (4, 1) cross
open-box.poly|open-box.poly:16: facet 3: edge (5, 6) belongs to no other facet (the surface is open there)
intersecting.poly|intersecting.poly:22: facets 2 and 9 (line 36) intersect near (1, 0.5, 0.75)
t-junction.poly|t-junction.poly:19: facets 3 and 6 (line 25) intersect near (0.25, 0, 1)
four-d.off|four-d.off:1: the 4OFF variant of OFF is not supported (plain OFF, and COFF, NOFF, CNOFF, STOFF with their extra vertex data ignored)
open.off|open.off:8: facet 1: edge (1, 2) belongs to no other facet (the surface is open there)
welded-open.off|welded-open.off:14: facet 4: edge (2, 5) belongs to no other facet (the surface is open there)
no-endloop.stl|no-endloop.stl:7: expected 'vertex' or 'endloop', found 'endfacet'
unknown.xyz|unknown.xyz: unknown input format '.xyz': expected .poly, .smesh, .off, .stl, .ply, .obj or .mesh
TABLE

# The valid fixtures pass (colour.off: COFF, a colour after each vertex;
# welded.off: a vertex written twice, merged).
for f in cube.smesh tet.off tet.stl colour.off welded.off; do
    "$tool" "$f" >"$out/stdout" 2>"$out/stderr" || { cat "$out/stderr"; fail "$f refused"; }
done
echo "plc errors: ok"
