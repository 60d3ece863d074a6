#!/bin/sh
# Near-planar facets (plc/fm.h, pdr mesh --facet-tol; issue 12). The test
# writes a box 1 x 0.5 x 0.5 whose four long faces are tessellated as CAD
# tools do, in strips 1 long and 0.05 wide, each cut into two triangles
# with corners of 2.9 degrees, and whose end faces are grids; the box is
# rotated and written with six significant digits, so that the two
# triangles of a strip lie off one plane by the rounding (up to 1e-5 of
# the diagonal, the thin triangles magnifying it):
#  - exactly, most strips stay two facets and their diagonals segments:
#    pdr mesh leaves tetrahedra above radius-edge 2 (the premise);
#  - with --facet-tol 1e-4 the box has its 6 facets (84 segments: its
#    edges, split where the end faces' grids meet them), the mesh has no
#    tetrahedron above 2, and pdr check --plc with the same tolerance
#    passes (coverage in projection, volume within the allowance);
#  - pdr check without the tolerance fails that mesh: its boundary takes
#    other diagonals than the input's triangles.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-strips.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

# The box: x in 1 piece, y and z in 10; a rotation by (0.3, 0.5, 0.7)
# radians about the axes and a shift; vertices shared by their printed
# coordinates.
awk 'function vid(x, y, z,   p, q, r, s) {
        p = c1 * x + c2 * y + c3 * z + 0.123457
        q = c4 * x + c5 * y + c6 * z - 0.312345
        r = c7 * x + c8 * y + c9 * z + 0.213579
        s = sprintf("%g %g %g", p, q, r)
        if (!(s in id)) { id[s] = nv; vs[nv++] = s }
        return id[s]
    }
    # point (i, j) of face f: 0 z=0, 1 z=H (x, y); 2 y=0, 3 y=W (x, z);
    # 4 x=0, 5 x=L (y, z)
    function pt(f, i, j,   x, y, z) {
        if (f <= 1) { x = i / nx * L; y = j / ny * W; z = f * H }
        else if (f <= 3) { x = i / nx * L; z = j / nz * H; y = (f - 2) * W }
        else { y = i / ny * W; z = j / nz * H; x = (f - 4) * L }
        return vid(x, y, z)
    }
    function tri(a, b, c, flip) { t[nt++] = flip ? a " " c " " b : a " " b " " c }
    BEGIN {
        nv = 0; nt = 0
        L = 1; W = 0.5; H = 0.5; nx = 1; ny = 10; nz = 10
        ca = cos(0.3); sa = sin(0.3); cb = cos(0.5); sb = sin(0.5); cg = cos(0.7); sg = sin(0.7)
        c1 = cb * cg; c2 = sa * sb * cg - ca * sg; c3 = ca * sb * cg + sa * sg
        c4 = cb * sg; c5 = sa * sb * sg + ca * cg; c6 = ca * sb * sg - sa * cg
        c7 = -sb; c8 = sa * cb; c9 = ca * cb
        for (f = 0; f < 6; f++) {
            ni = f <= 3 ? nx : ny; nj = f <= 1 ? ny : nz
            flip = f == 0 || f == 3 || f == 4   # outward orientation
            for (i = 0; i < ni; i++)
                for (j = 0; j < nj; j++) {
                    a = pt(f, i, j); b = pt(f, i + 1, j); c = pt(f, i + 1, j + 1); d = pt(f, i, j + 1)
                    tri(a, b, c, flip); tri(a, c, d, flip)
                }
        }
        print "OFF"; print nv, nt, 0
        for (k = 0; k < nv; k++) print vs[k]
        for (k = 0; k < nt; k++) print 3, t[k]
    }' >"$tmp/strips.off" || exit 99
grep -q '^242 480 0$' "$tmp/strips.off" || fail "the generated box has not 242 vertices, 480 triangles"

# bad OUT: the count of tetrahedra the summary leaves above the bound.
bad() { sed -n 's/^left above the bound: \([0-9]*\) tetrahedra.*/\1/p' "$1"; }

# Exact facets: the strips' diagonals stay segments.
timeout 60 "$PDR" mesh --facet-tol 0 -o "$tmp/exact" "$tmp/strips.off" >"$tmp/exact.out" 2>&1 ||
    { cat "$tmp/exact.out"; fail "--facet-tol 0: pdr mesh failed"; }
n0=$(bad "$tmp/exact.out")
[ -n "$n0" ] && [ "$n0" -gt 0 ] ||
    { cat "$tmp/exact.out"; fail "premise: exact facets leave '$n0' tetrahedra above 2"; }

# Near-planar facets: the box's own 6.
timeout 60 "$PDR" mesh --facet-tol 1e-4 -o "$tmp/bent" "$tmp/strips.off" >"$tmp/bent.out" 2>&1 ||
    { cat "$tmp/bent.out"; fail "--facet-tol 1e-4: pdr mesh failed"; }
grep -q '^input: .*: 242 vertices, 84 segments, 6 facets' "$tmp/bent.out" ||
    { cat "$tmp/bent.out"; fail "--facet-tol 1e-4: not the box's 6 facets"; }
grep -q '^near-planar facets: 6 merged facets' "$tmp/bent.out" ||
    { cat "$tmp/bent.out"; fail "--facet-tol 1e-4: the summary does not count 6 near-planar facets"; }
n1=$(bad "$tmp/bent.out")
[ "$n1" = 0 ] || { cat "$tmp/bent.out"; fail "--facet-tol 1e-4: '$n1' tetrahedra above 2"; }
"$PDR" check --facet-tol 1e-4 --plc "$tmp/strips.off" --max-ratio 2 "$tmp/bent" >"$tmp/bent.chk" 2>&1 ||
    { cat "$tmp/bent.chk"; fail "--facet-tol 1e-4: pdr check found defects"; }
grep -Eq '^  facets covered by subfacets +6$' "$tmp/bent.chk" || fail "pdr check: not 6 facets covered"
grep -q 'allowed (near-planar facets)' "$tmp/bent.chk" || fail "pdr check: no volume allowance shown"

# The same mesh against the exact facets: its boundary is not theirs.
"$PDR" check -q --plc "$tmp/strips.off" "$tmp/bent" >"$tmp/bent0.chk" 2>&1 &&
    fail "pdr check without --facet-tol passed a mesh off the input's triangles"

# The option is documented and checked.
"$PDR" mesh --help | grep -q -- '--facet-tol T' || fail "pdr mesh --help does not give --facet-tol"
"$PDR" check --help | grep -q -- '--facet-tol T' || fail "pdr check --help does not give --facet-tol"
"$PDR" mesh --facet-tol -1 "$tmp/strips.off" >/dev/null 2>&1
[ $? -eq 2 ] || fail "--facet-tol -1 is no usage error"
echo "strips: exact $n0 tetrahedra above 2, --facet-tol 1e-4: $(grep '^mesh:' "$tmp/bent.out")"
