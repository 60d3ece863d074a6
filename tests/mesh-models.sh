#!/bin/sh
# pdr mesh on the paper's two model problems (cube-in-cube, and the tee with
# its 60-degree edges): every tetrahedron ends below radius-edge 2, and
# pdr check, given the input, finds the mesh Delaunay, its boundary closed
# and equal to the subfacets, every facet covered and the volume equal to
# the domain's. Also the built-in default ('pdr mesh' with no input) and
# the paper's initial mesh.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-models.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$PDR" mesh --help >"$tmp/help" || fail "--help exited $?"
grep -q 'radius-edge bound' "$tmp/help" || fail "--help does not describe -q"
"$PDR" --help | grep -q '^  mesh ' || fail "pdr --help does not list mesh"

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || fail "pdr domain cube-in-cube"
"$PDR" domain tee -o "$tmp/tee.poly" >/dev/null || fail "pdr domain tee"

# name | volume bound | smallest expected number of tetrahedra
while read -r name vol least; do
    [ -n "$name" ] || continue
    "$PDR" mesh -q 2.0 -a "$vol" "$tmp/$name.poly" >"$tmp/$name.out" 2>"$tmp/$name.err" ||
        { rc=$?; cat "$tmp/$name.out" "$tmp/$name.err"; fail "$name: pdr mesh exited $rc"; }
    cat "$tmp/$name.out"
    grep -q '^left above the bound: 0 tetrahedra with radius-edge >= 2$' "$tmp/$name.out" ||
        fail "$name: tetrahedra left above the bound"
    nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$tmp/$name.out")
    [ -n "$nt" ] && [ "$nt" -ge "$least" ] || fail "$name: only '$nt' tetrahedra"
    for ext in node ele face; do
        [ -s "$tmp/$name.1.$ext" ] || fail "$name: no $name.1.$ext"
    done
    "$PDR" check --plc "$tmp/$name.poly" --max-ratio 2 "$tmp/$name.1" >"$tmp/$name.chk" ||
        { cat "$tmp/$name.chk"; fail "$name: pdr check found defects"; }
    grep -q '^ok: 0 defects$' "$tmp/$name.chk" || fail "$name: no verdict"
    grep -Eq '^  facets not covered \(area differs\) +0$' "$tmp/$name.chk" ||
        fail "$name: facet coverage not reported as complete"
    grep -Eq '^  faces not locally Delaunay +0$' "$tmp/$name.chk" || fail "$name: Delaunay"
    grep -Eq '^  relative difference +[0-9.e-]+$' "$tmp/$name.chk" ||
        fail "$name: volume not compared"
    grep -Eq '^tetrahedra with radius-edge ratio >= 2: 0$' "$tmp/$name.chk" ||
        fail "$name: ratio bound not checked"
done <<'TABLE'
cic 0.0005 2000
tee 0.002 2000
TABLE

# The dihedral angle histograms as a PNG (the paper's fig. 9), when gnuplot
# is there.
if command -v "${PDR_GNUPLOT:-gnuplot}" >/dev/null 2>&1; then
    "$PDR" check -q --plot "$tmp/fig9.png" "$tmp/tee.1" >/dev/null || fail "--plot exited $?"
    [ "$(od -An -c -N4 "$tmp/fig9.png" | tr -d ' ')" = "211PNG" ] || fail "--plot wrote no PNG"
else
    echo "no gnuplot: --plot not tried"
fi

# The paper's initial mesh of the cube-in-cube: d = 0.25/sqrt(2).
"$PDR" mesh --mo paper --mo-only -f none "$tmp/cic.poly" >"$tmp/mo.out" ||
    fail "--mo paper exited $?"
grep -q '^initial mesh (paper): .* d = 0.176777 ' "$tmp/mo.out" ||
    fail "paper Mo: $(cat "$tmp/mo.out")"
"$PDR" mesh --mo paper -a 0.001 -o "$tmp/cicp" "$tmp/cic.poly" >/dev/null ||
    fail "refining the paper's Mo exited $?"
"$PDR" check -q --plc "$tmp/cic.poly" --max-ratio 2 "$tmp/cicp" || fail "paper Mo refined"

# --mo-size: about N tetrahedra.
"$PDR" mesh --mo-size 20000 --mo-only -o "$tmp/mos" "$tmp/tee.poly" >"$tmp/mos.out" ||
    fail "--mo-size exited $?"
nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$tmp/mos.out")
[ "$nt" -ge 10000 ] && [ "$nt" -le 40000 ] || fail "--mo-size 20000 gave $nt tetrahedra"

# No input: the built-in cube-in-cube, written to the current directory.
(cd "$tmp" && "$PDR" mesh >default.out) || fail "pdr mesh without input exited $?"
[ -s "$tmp/cube-in-cube.1.ele" ] || fail "no cube-in-cube.1.ele written by default"
"$PDR" check -q --max-ratio 2 "$tmp/cube-in-cube.1" || fail "default mesh check"
echo "ok"
