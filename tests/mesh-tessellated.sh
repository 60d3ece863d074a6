#!/bin/sh
# Tessellated closed surfaces (issue 12), from tests/data/surf (written by
# tools/gen-surfaces --synthetic):
#  - the cube [-1,1]^3 with every face a grid of triangles (866 vertices,
#    1,728 triangles): its coplanar triangles merge into 6 facets and it
#    meshes into a full mesh that pdr check passes; with --no-merge it
#    either meshes (pdr check finding nothing but the faces not locally
#    Delaunay and tetrahedra above ratio 2 that the summary reports) or
#    fails with a message, never an empty mesh and exit 0;
#  - a square frame (genus 1) and a slanted octahedron with gridded faces:
#    full meshes that pass pdr check;
#  - the needle (a tetrahedron surface with a vertex at y = 99999999999):
#    ends in bounded time with a mesh that passes pdr check or a clear
#    error, never exit 0 without a mesh;
#  - pdr check --plc fails an empty mesh of a closed surface.
set -u
fail() { echo "FAIL: $*"; exit 1; }
. "$top_srcdir/tests/cad-lib.sh"
tmp=$(pwd)/mesh-tessellated.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
data=$top_srcdir/tests/data/surf

# mesh_ok NAME IN [OPTIONS]: pdr mesh exits 0 within 120 s with tetrahedra
# and pdr check --plc passes (with the same merge option).
mesh_ok() {
    name=$1 in=$2
    shift 2
    timeout 120 "$PDR" mesh "$@" -o "$tmp/$name" "$in" >"$tmp/$name.out" 2>&1
    rc=$?
    [ "$rc" -eq 0 ] || { cat "$tmp/$name.out"; fail "$name: pdr mesh exited $rc"; }
    nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$tmp/$name.out")
    [ -n "$nt" ] && [ "$nt" -gt 0 ] || fail "$name: '$nt' tetrahedra"
    merge=
    case " $* " in *" --no-merge "*) merge=--no-merge ;; esac
    "$PDR" check --plc "$in" $merge --max-ratio 2 "$tmp/$name" >"$tmp/$name.chk" 2>&1 ||
        { cat "$tmp/$name.out" "$tmp/$name.chk"; fail "$name: pdr check found defects"; }
    grep -Eq '^  facets not covered \(area differs\) +0$' "$tmp/$name.chk" || fail "$name: coverage"
    echo "$name: $(grep '^mesh:' "$tmp/$name.out")"
}

# The grid-triangulated cube: 6 facets after the merge, a full mesh.
mesh_ok cube "$data/gridcube.off"
grep -q '^input preparation: 1728 coplanar triangles merged (1728 facets before, 6 after)' \
    "$tmp/cube.out" || fail "the cube's triangles did not merge into 6 facets"
"$PDR" mesh --help | grep -q -- '--merge-angle' || fail "--help does not give --merge-angle"
"$PDR" mesh --help | grep -q -- '--max-points' || fail "--help does not give --max-points"

# Without the merge: a mesh that passes, or a clear error; never exit 0
# with an empty mesh.
timeout 120 "$PDR" mesh --no-merge -o "$tmp/cubenm" "$data/gridcube.off" >"$tmp/cubenm.out" 2>&1
rc=$?
case $rc in
0)
    nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$tmp/cubenm.out")
    [ -n "$nt" ] && [ "$nt" -gt 0 ] || fail "--no-merge: exit 0 with '$nt' tetrahedra"
    # (tetrahedra may be left above ratio 2 next to the 45-degree angles
    # of the unmerged triangles, and faces not locally Delaunay where the
    # splits next to them were refused: the summary counts both, and pdr
    # check must find nothing else and no more of them)
    cad_check "cube --no-merge" "$data/gridcube.off" "$tmp/cubenm" "$tmp/cubenm.out" --no-merge
    cad_check_cover "cube --no-merge" "$tmp/cubenm" "$tmp/cubenm.out"
    echo "cube --no-merge: $(grep '^mesh:' "$tmp/cubenm.out"), $nd faces not locally Delaunay"
    ;;
124) fail "--no-merge: still running after 120 s" ;;
*)
    grep -q '^pdr mesh: ' "$tmp/cubenm.out" || fail "--no-merge: exit $rc without a message"
    echo "cube --no-merge: $(grep '^pdr mesh: ' "$tmp/cubenm.out")"
    ;;
esac

mesh_ok frame "$data/frame.off"
mesh_ok octa "$data/octa-6.off"

# The needle: bounded time, a mesh or a clear error.
timeout 120 "$PDR" mesh -o "$tmp/needle" "$data/needle.off" >"$tmp/needle.out" 2>&1
rc=$?
case $rc in
0)
    [ -s "$tmp/needle.ele" ] || fail "needle: exit 0 without a mesh"
    "$PDR" check -q --plc "$data/needle.off" "$tmp/needle" || fail "needle: pdr check"
    echo "needle: $(grep '^mesh:' "$tmp/needle.out")"
    ;;
124) fail "needle: still running after 120 s" ;;
*)
    grep -Eq '^pdr mesh: (stopped after inserting|the boundary recovery (does not terminate|cannot recover))' \
        "$tmp/needle.out" || { cat "$tmp/needle.out"; fail "needle: exit $rc without a clear error"; }
    [ ! -e "$tmp/needle.ele" ] || fail "needle: a mesh was written although it failed"
    echo "needle: $(grep '^pdr mesh: ' "$tmp/needle.out" | cut -c1-100)..."
    ;;
esac

# A small bound on the points stops the cube with the bound's message.
"$PDR" mesh --max-points 10 -f none "$data/gridcube.off" >"$tmp/bound.out" 2>&1 &&
    fail "--max-points 10 did not stop the run"
grep -q '^pdr mesh: stopped after inserting 10 points' "$tmp/bound.out" ||
    { cat "$tmp/bound.out"; fail "--max-points: no clear message"; }

# pdr check fails an empty mesh of a closed surface.
printf '0 3 0 0\n' >"$tmp/empty.node"
printf '0 4 0\n' >"$tmp/empty.ele"
"$PDR" check -q --plc "$data/gridcube.off" "$tmp/empty" >"$tmp/empty.chk" 2>&1 &&
    fail "pdr check passed an empty mesh"
echo "ok"
