#!/bin/sh
# A CGAL part that meshes sequentially in a fraction of a second and on
# 2 PEs ran on for minutes: pinion_small.off with exact facets
# (--facet-tol 0). The PEs refined without the rules of the sequential
# quality refinement (ref_mesher.refining unset), so the subsegment
# splits that faces no flip mends ask for had no bound there
# (stuck_past_bound in refine/refine_run.c): points piled up along
# segments with tens of thousands of tetrahedra between them, each step
# slower, until the progress bound stopped the run or the timeout did.
# Taken at test time from Debian's libcgal-dev (tests/cad-lib.sh; skipped,
# exit 77, without the package):
#  - pdr mesh -n 2 exits 0 within 120 s (the sequential run takes 0.1 s;
#    the bound is for loaded machines, not a timing);
#  - the mesh has at most 1.5 times the sequential mesh's tetrahedra
#    (33,725): 38,700-41,600 in six runs; 57,700-61,900 in runs with
#    the PEs' queues fixed but not their refining flag, whose splits
#    then still run on (main runs past the progress bound);
#  - pdr check --plc IN --max-ratio 2 finds nothing but what the summary
#    reports (faces not locally Delaunay, as many as it says; tetrahedra
#    above ratio 2, no more than it says), as for the sequential mesh.
set -u
fail() { echo "FAIL: $*"; exit 1; }
. "$top_srcdir/tests/cad-lib.sh"
tmp=$(pwd)/mesh-parallel-cad.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
cad_extract "$tmp" pinion_small
in=$tmp/data/meshes/pinion_small.off

timeout 60 "$PDR" mesh --facet-tol 0 -o "$tmp/seq" "$in" >"$tmp/seq.out" 2>&1 ||
    { cat "$tmp/seq.out"; fail "sequential: exit $?"; }
cad_tets seq "$tmp/seq.out"
nseq=$nt

timeout 120 "$PDR" mesh -n 2 --facet-tol 0 -o "$tmp/par" "$in" >"$tmp/par.out" 2>&1
rc=$?
[ "$rc" -eq 0 ] || { tail -n 5 "$tmp/par.out"; fail "2 PEs: pdr mesh -n 2 exited $rc"; }
cad_tets par "$tmp/par.out"
[ $((2 * nt)) -le $((3 * nseq)) ] || fail "2 PEs: $nt tetrahedra, sequentially $nseq"
cad_check par "$in" "$tmp/par" "$tmp/par.out" --facet-tol 0
cad_check_cover par "$tmp/par" "$tmp/par.out"
echo "pinion_small on 2 PEs: $nt tetrahedra (sequentially $nseq), $nd faces not locally Delaunay"
echo "ok"
