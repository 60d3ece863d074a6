#!/bin/sh
# pdr check compares a facet's coverage in projection on its plane: a
# thin quad facet whose corners lie off one plane by 1e-6 (within the
# planarity tolerance of a domain 1,000 long), covered by mesh faces fanned
# around a point between its two triangulations (on neither diagonal),
# passes; their area in space differs from the input triangles' by 7e-8,
# which the comparison in space refused. The same mesh with that point
# lifted 1e-4 off the facet is refused.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/check-bent-area.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

# A needle pyramid on the quad 0-1-2-3 (corner 2 lifted 1e-6), the quad
# given as two triangles across diagonal 1-3.
cat >"$tmp/tent.off" <<'END'
OFF
5 6 0
0 0 0
1 0 0
1 0.001 0.000001
0 0.001 0
0.5 0.0005 1000
3 0 3 1
3 1 3 2
3 0 1 4
3 1 2 4
3 2 3 4
3 3 0 4
END
# mesh NAME Z: four tetrahedra around point 5 at (0.3, 0.0005, Z); Z =
# 5e-7 lies between the surfaces of the quad's two triangulations.
mesh() {
    printf '6 3 0 0\n1 0 0 0\n2 1 0 0\n3 1 0.001 0.000001\n4 0 0.001 0\n5 0.3 0.0005 %s\n6 0.5 0.0005 1000\n' \
        "$2" >"$tmp/$1.node"
    printf '4 4 0\n1 1 2 5 6\n2 2 3 5 6\n3 3 4 5 6\n4 4 1 5 6\n' >"$tmp/$1.ele"
    printf '8 0\n1 1 2 5\n2 2 3 5\n3 3 4 5\n4 4 1 5\n5 1 2 6\n6 2 3 6\n7 3 4 6\n8 4 1 6\n' \
        >"$tmp/$1.face"
}
mesh fan 0.0000005
mesh lifted 0.0001

"$PDR" check --plc "$tmp/tent.off" "$tmp/fan" >"$tmp/out" 2>&1
rc=$?
grep -Eq '^  facets not covered \(area differs\) +0$' "$tmp/out" ||
    { cat "$tmp/out"; fail "the fan's area is reported as differing"; }
[ $rc -eq 0 ] || { cat "$tmp/out"; fail "the fan's mesh fails the check (exit $rc)"; }

"$PDR" check --plc "$tmp/tent.off" "$tmp/lifted" >"$tmp/out" 2>&1
[ $? -eq 1 ] || { cat "$tmp/out"; fail "a point 1e-4 off the facet passed"; }
grep -q 'DEFECT' "$tmp/out" || fail "no defect named for the lifted point"
echo "ok"
