#!/bin/sh
# pdr domain: both model problems and the sphere are written, pass the
# validator, and read back; bad usage exits 2 and writes nothing.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tool=$top_builddir/tests/plc_tool
tmp=$(pwd)/domain-cli.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$PDR" domain --help >"$tmp/help" || fail "--help exited $?"
grep -q 'half-tee brace' "$tmp/help" || fail "--help does not describe the tee"
"$PDR" --help | grep -q '^  domain ' || fail "pdr --help does not list domain"

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >"$tmp/out" || fail "cube-in-cube exited $?"
grep -q 'wrote .*cic.poly (cube-in-cube: 16 vertices, 12 facets, 1 holes)' "$tmp/out" ||
    fail "cube-in-cube summary: $(cat "$tmp/out")"
"$tool" "$tmp/cic.poly" >"$tmp/sum" || fail "cube-in-cube output refused"
grep -q '^vertices 16 facets 12 polygons 12 segments 24 .* holes 1 regions 1 triangles 24 ' \
    "$tmp/sum" || fail "cube-in-cube reads back as $(cat "$tmp/sum")"

"$PDR" domain tee --angle 45 --length 3 -o "$tmp/tee.poly" >"$tmp/out" || fail "tee exited $?"
"$tool" "$tmp/tee.poly" >"$tmp/sum" || fail "tee output refused"
grep -q '^vertices 12 facets 8 polygons 8 segments 18 ' "$tmp/sum" ||
    fail "tee reads back as $(cat "$tmp/sum")"

# The sphere: 20 * 4^N triangles, V = F/2 + 2, E = 3F/2; meshed, every
# facet covered, the volume that of the polyhedron (pdr check --plc) and a
# bit under the ball's 4pi/3 r^3.
"$PDR" domain sphere --level 2 --radius 2 -o "$tmp/sph.poly" >"$tmp/out" || fail "sphere exited $?"
grep -q 'wrote .*sph.poly (sphere: 162 vertices, 320 facets, 0 holes)' "$tmp/out" ||
    fail "sphere summary: $(cat "$tmp/out")"
"$tool" "$tmp/sph.poly" >"$tmp/sum" || fail "sphere output refused"
grep -q '^vertices 162 facets 320 polygons 320 segments 480 .* regions 1 triangles 320 ' \
    "$tmp/sum" || fail "sphere reads back as $(cat "$tmp/sum")"
"$PDR" mesh -Q -o "$tmp/sphm" "$tmp/sph.poly" || fail "meshing the sphere exited $?"
"$PDR" check --max-ratio 2 --plc "$tmp/sph.poly" "$tmp/sphm" >"$tmp/chk" ||
    fail "the sphere's mesh fails pdr check: $(grep -i 'defect\|not\|above' "$tmp/chk")"
awk '/^tetrahedra .* volume/ { v = $NF } END { exit !(v > 30 && v < 4 * 3.14159266 * 8 / 3) }' \
    "$tmp/chk" || fail "sphere volume: $(grep '^tetrahedra' "$tmp/chk")"

# Default output name in the current directory.
(cd "$tmp" && "$PDR" domain tee >/dev/null) || fail "tee with default name"
[ -s "$tmp/tee.poly" ] || fail "no tee.poly written by default"

# Usage errors: exit 2, a clear message, no file.
check_usage() {
    want=$1
    shift
    "$PDR" domain "$@" -o "$tmp/bad.poly" >"$tmp/out" 2>&1
    rc=$?
    [ $rc -eq 2 ] || fail "pdr domain $*: exit $rc, expected 2"
    grep -Fq -- "$want" "$tmp/out" || fail "pdr domain $*: no '$want' in: $(cat "$tmp/out")"
    [ ! -e "$tmp/bad.poly" ] || fail "pdr domain $*: wrote a file"
}
check_usage "pdr domain: unknown domain 'ball'" ball
check_usage "pdr domain: tee options given for sphere" sphere --web 0.1
check_usage "pdr domain: --level: 8 is not a whole number from 0 to 7" sphere --level 8
check_usage "pdr domain: --level: 2.5 is not a whole number from 0 to 7" sphere --level 2.5
check_usage "pdr domain: the sphere's radius must be positive" sphere --radius 0
check_usage "pdr domain: which domain?"
check_usage "pdr domain: cube-in-cube options given for tee" tee --inner 0.3
check_usage "pdr domain: --angle: 'abc' is not a number" tee --angle abc
check_usage "pdr domain: the void's side must be positive and smaller" cube-in-cube --inner 2
check_usage "pdr domain: the tee's angle must be in (0, 90] degrees" tee --angle 95
check_usage "pdr domain: the web is too thick" tee --web 0.95
echo "pdr domain: ok"
