#!/bin/sh
# CGAL parts that mesh sequentially in a fraction of a second and on 2
# PEs ran on until the progress bound or the timeout stopped them:
#  - pinion_small.off with exact facets (--facet-tol 0): the PEs refined
#    without the rules of the sequential quality refinement
#    (ref_mesher.refining unset), so the subsegment splits that faces no
#    flip mends ask for had no bound there (stuck_past_bound in
#    refine/refine_run.c): points piled up along segments with tens of
#    thousands of tetrahedra between them, each step slower;
#  - pinion.off (default --facet-tol: near-planar facets), also on
#    3 PEs with latency 100us-1ms: it stopped on the progress bound after
#    some 30 s (main before the merge of branch cadqual, d98f215): its Mo,
#    24,146 tetrahedra on 1,849 vertices, had cavities of thousands of
#    tetrahedra across the interface, given up as too big to migrate and
#    searched again for each neighbour. Splitting the recovery's bad
#    subfacets (refine_run.c) leaves a Mo of 5,679 tetrahedra, which the
#    PEs refine.
# Since rank 0 refines such a mesh alone up to --rank0-points points
# before the PEs start (cli/mesh_par.c, refine_alone), these runs give
# --rank0-points 0 to keep the PEs refining the coarse conforming mesh;
# with the default, pinion_small on 2 PEs is meshed by rank 0 alone (the
# sequential mesh, byte for byte, and the summary says so: before, 2 PEs
# took 2-65 s where the sequential run takes 0.3 s, or stopped on the
# progress bound under load), and with --rank0-points 1000 rank 0 pauses
# and the PEs refine from there (a Mo of some 6,000 tetrahedra).
# Taken at test time from Debian's libcgal-dev (tests/cad-lib.sh; skipped,
# exit 77, without the package). For each run:
#  - pdr mesh -n P exits 0 within 120 s (bounds for loaded machines, not
#    timings: the sequential runs take 0.1-0.4 s; pinion on 3 PEs with
#    latency about 9 s on a 2-core VM);
#  - the mesh has at most 1.5 times the sequential mesh's tetrahedra
#    (pinion_small before branch cadqual: 33,725, against 38,700-41,600
#    in six runs and 57,700-61,900 in runs with the PEs' queues fixed but
#    not their refining flag, whose splits then still ran on);
#  - pdr check --plc IN --max-ratio 2 finds nothing but what the summary
#    reports (faces not locally Delaunay, as many as it says; tetrahedra
#    above ratio 2, no more than it says), as for the sequential mesh.
set -u
fail() { echo "FAIL: $*"; exit 1; }
. "$top_srcdir/tests/cad-lib.sh"
tmp=$(pwd)/mesh-parallel-cad.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
cad_extract "$tmp" pinion_small pinion

# part NAME FACET-OPTIONS...: the sequential mesh of NAME.off with those
# options; its tetrahedra in $nseq.
part() {
    name=$1
    shift
    in=$tmp/data/meshes/$name.off
    facet="$*"
    # shellcheck disable=SC2086
    timeout 60 "$PDR" mesh $facet -o "$tmp/$name-seq" "$in" >"$tmp/$name-seq.out" 2>&1 ||
        { cat "$tmp/$name-seq.out"; fail "$name sequential: exit $?"; }
    cad_tets "$name-seq" "$tmp/$name-seq.out"
    nseq=$nt
}

# run LABEL PDR-MESH-OPTIONS...: the part on PEs, checked as above.
run() {
    label=$name-$1
    shift
    # shellcheck disable=SC2086
    timeout 120 "$PDR" mesh "$@" $facet -o "$tmp/$label" "$in" >"$tmp/$label.out" 2>&1
    rc=$?
    [ "$rc" -eq 0 ] || { tail -n 5 "$tmp/$label.out"; fail "$label: pdr mesh $* exited $rc"; }
    cad_tets "$label" "$tmp/$label.out"
    [ $((2 * nt)) -le $((3 * nseq)) ] || fail "$label: $nt tetrahedra, sequentially $nseq"
    # shellcheck disable=SC2086
    cad_check "$label" "$in" "$tmp/$label" "$tmp/$label.out" $facet
    cad_check_cover "$label" "$tmp/$label" "$tmp/$label.out"
    echo "$label: $nt tetrahedra (sequentially $nseq), $nd faces not locally Delaunay"
}

part pinion_small --facet-tol 0
run par2 -n 2 --rank0-points 0
part pinion
run par2 -n 2 --rank0-points 0
run par3 -n 3 --latency 100us-1ms --rank0-points 0

# pinion_small with the default facets: rank 0 alone, then rank 0 first.
part pinion_small
run alone -n 2
grep -q '^parallel: 2 PEs; rank 0 refined the mesh alone' "$tmp/$label.out" ||
    fail "$label: $(grep '^parallel' "$tmp/$label.out")"
for ext in node ele face; do
    cmp -s "$tmp/$name-seq.$ext" "$tmp/$label.$ext" || fail "$label: .$ext not the sequential one"
done
run paused -n 2 --rank0-points 1000
mo=$(sed -n 's/^parallel: 2 PEs, 2 parts, Mo \([0-9]*\) tetrahedra.*/\1/p' "$tmp/$label.out")
[ "${mo:-0}" -gt 3000 ] || fail "$label: $(grep '^parallel' "$tmp/$label.out")"
echo "$label: Mo $mo tetrahedra"
echo "ok"
