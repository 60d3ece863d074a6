#!/bin/sh
# The parallel refinement on closed triangle surfaces (tests/data/surf):
# Mo is the carved constrained Delaunay mesh of the sequential mesher, the
# distributed cavities stop at its subfacets, the flips a PE cannot make
# (next to its interface, or to another cavity's locked tetrahedra) and the
# boundary splits whose cavity reaches another PE are left to rank 0,
# which flips and refines the merged mesh (refine/refine_cdt.c,
# par/par_cav.c). For gmsh parts, tessellated shapes and a UV sphere, on 2
# and 3 PEs, and on 4 PEs with 16 parts and injected latency:
#  - pdr mesh -n P exits 0 within 120 s, says the initial mesh is
#    constrained Delaunay, and every PE's tables and links pass the check
#    of PDR_REF_CHECK=end;
#  - pdr check --plc IN --max-ratio 2 finds nothing but tetrahedra above
#    ratio 2, no more than the summary reports as given up (next to small
#    input angles, or elsewhere with their splits refused; none
#    "degenerate" or "other");
#  - the mesh has within 10% of the sequential mesh's tetrahedra.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-cad-parallel.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
data=$top_srcdir/tests/data/surf

tets() { sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$1"; }

check() { # NAME IN: the mesh $tmp/NAME against IN, as above
    cn=$1
    cin=$2
    grep -q '^initial mesh (constrained Delaunay)' "$tmp/$cn.out" ||
        fail "$cn: not meshed in the constrained mode"
    left=$(sed -n 's/^left above the bound: \([0-9]*\) tetrahedra with radius-edge.*/\1/p' \
        "$tmp/$cn.out")
    [ -n "$left" ] || fail "$cn: no 'left above the bound' line"
    if [ "$left" -gt 0 ]; then
        kinds='(.*, 0 degenerate .*, 0 hidden .*, 0 other)'
        grep -q "^left above the bound: $left tetrahedra with radius-edge >= 2 $kinds" \
            "$tmp/$cn.out" || fail "$cn: $(grep '^left' "$tmp/$cn.out")"
    fi
    "$PDR" check --plc "$cin" --max-ratio 2 "$tmp/$cn" >"$tmp/$cn.chk" 2>&1
    other=$(grep -- '<-- DEFECT' "$tmp/$cn.chk" | grep -v '^tetrahedra with radius-edge ratio')
    [ -z "$other" ] || { cat "$tmp/$cn.chk"; fail "$cn: $other"; }
    bad=$(sed -n 's/^tetrahedra with radius-edge ratio >= 2: \([0-9]*\).*/\1/p' "$tmp/$cn.chk")
    [ "${bad:-x}" -le "$left" ] 2>/dev/null ||
        fail "$cn: pdr check finds '$bad' above ratio 2, the summary $left"
}

# name  volume bound (about 10^4 tetrahedra)
while read -r name a; do
    in=$data/$name.off
    timeout 120 "$PDR" mesh -a "$a" -o "$tmp/$name-seq" "$in" >"$tmp/$name-seq.out" 2>&1
    rc=$?
    [ "$rc" -eq 0 ] || { cat "$tmp/$name-seq.out"; fail "$name: sequential pdr mesh exited $rc"; }
    seq=$(tets "$tmp/$name-seq.out")
    for n in 2 3; do
        run=$name-$n
        PDR_REF_CHECK=end timeout 120 "$PDR" mesh -n "$n" -a "$a" -o "$tmp/$run" "$in" \
            >"$tmp/$run.out" 2>&1
        rc=$?
        [ "$rc" -eq 0 ] || { cat "$tmp/$run.out"; fail "$run: pdr mesh -n $n exited $rc"; }
        check "$run" "$in"
        nt=$(tets "$tmp/$run.out")
        d=$((nt > seq ? nt - seq : seq - nt))
        [ $((d * 10)) -le "$seq" ] || fail "$run: $nt tetrahedra, sequential $seq"
        echo "$run: $nt tetrahedra (sequential $seq), $left left above ratio 2"
    done
done <<EOF
torus-0.3 2e-4
boxcylsph-0.2 2e-4
gridtorus 2e-4
uvsphere 4e-4
strips-48 2e-3
EOF

# Over-decomposition with latency: cavities cross PEs, wait and collide,
# and the flips meet the other cavities' locks.
in=$data/torus-0.3.off
PDR_REF_CHECK=end timeout 120 "$PDR" mesh -n 4 --parts 16 --latency 100us-1ms -a 2e-4 \
    -o "$tmp/lat" "$in" >"$tmp/lat.out" 2>&1
rc=$?
[ "$rc" -eq 0 ] || { cat "$tmp/lat.out"; fail "lat: pdr mesh exited $rc"; }
check lat "$in"
line=$(grep '^parallel:' "$tmp/lat.out")
dist=$(echo "$line" | sed -n 's/.* \([0-9]*\) distributed.*/\1/p')
[ "${dist:-0}" -gt 0 ] || fail "lat: no distributed cavity: $line"
echo "lat: $(tets "$tmp/lat.out") tetrahedra; $line"
echo "ok"
