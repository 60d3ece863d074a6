#!/bin/sh
# A flat tetrahedron on a facet (its four vertices on the facet) is removed
# by splitting the subfacet it lies on, with no floor. In the constrained
# mode that split could go to a subsegment beyond which the subfacet's
# circumcentre lies and leave the flat tetrahedron standing, or make a
# new one of the same subfacet and the new point: the next split halved
# the same piece again, down to the resolution floor (refine/refine.h,
# REF_FLAT_TRIES). Two of CGAL's parts (Debian's libcgal-dev, taken at
# test time as in tests/mesh-cad-public.sh) showed it:
#  - mpi_triang.off, sequentially: an edge of 3.7e-9 in a part 35 across
#    (26,112 tetrahedra; 23,024 since, shortest edge 9.7e-7);
#  - part.off on 2 PEs with latency, about one run in ten, at rank 0's
#    finish and on the PEs: edges of 2^-33, up to 14,605 tetrahedra
#    against TetGen's 3,340 (at most 7,642 in 200 runs since).
# Each mesh must pass pdr check --plc IN --max-ratio 2 but for what the
# summary reports (tests/cad-lib.sh), and its shortest edge (pdr check's
# quality report) must be at least 1e-7. The parallel runs are three, so
# they catch the old cascade only about one time in four; the sequential
# one catches it every time.
# Without the package the test is skipped (exit 77), never passed.
set -u
fail() { echo "FAIL: $*"; exit 1; }
. "$top_srcdir/tests/cad-lib.sh"
tmp=$(pwd)/mesh-cad-flat.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
cad_extract "$tmp" mpi_triang part
data=$tmp/data/meshes

# shortest LABEL MESH: the shortest edge pdr check reports is >= 1e-7.
shortest() {
    s=$(sed -n 's/^shortest edge \([0-9.eE+-]*\)$/\1/p' "$2.chk")
    [ -n "$s" ] || fail "$1: no shortest edge in pdr check's report"
    awk -v s="$s" 'BEGIN { exit !(s >= 1e-7) }' || fail "$1: shortest edge $s, below 1e-7"
}

timeout 60 "$PDR" mesh -o "$tmp/mpi" "$data/mpi_triang.off" >"$tmp/mpi.out" 2>&1
rc=$?
[ "$rc" -eq 0 ] || { cat "$tmp/mpi.out"; fail "mpi_triang: pdr mesh exited $rc"; }
cad_tets mpi_triang "$tmp/mpi.out"
cad_check mpi_triang "$data/mpi_triang.off" "$tmp/mpi" "$tmp/mpi.out"
cad_check_cover mpi_triang "$tmp/mpi" "$tmp/mpi.out"
shortest mpi_triang "$tmp/mpi"
echo "mpi_triang: $nt tetrahedra, shortest edge $s"

for run in 1 2 3; do
    timeout 120 "$PDR" mesh -n 2 --rank0-points 0 --latency 50us-2ms -o "$tmp/par" \
        "$data/part.off" >"$tmp/par.out" 2>&1
    rc=$?
    [ "$rc" -eq 0 ] || { cat "$tmp/par.out"; fail "part -n 2, run $run: exit $rc"; }
    cad_tets "part -n 2" "$tmp/par.out"
    [ "$nt" -le 8350 ] || fail "part -n 2, run $run: $nt tetrahedra, TetGen 3340"
    cad_check "part -n 2" "$data/part.off" "$tmp/par" "$tmp/par.out"
    shortest "part -n 2, run $run" "$tmp/par"
    echo "part -n 2, run $run: $nt tetrahedra, shortest edge $s"
done
echo "ok"
