#!/bin/sh
# pdr check can fail: a mesh with one tetrahedron removed, and one with a
# tetrahedron turned inside out, are refused (exit 1) with the defect
# named; the intact mesh passes.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/check-damaged.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || exit 99
"$PDR" mesh -Q -a 0.002 -o "$tmp/m" "$tmp/cic.poly" || exit 99
"$PDR" check -q --plc "$tmp/cic.poly" "$tmp/m" >/dev/null || fail "the intact mesh fails"

# Copies the mesh to $tmp/$1.* with the .ele rewritten by awk program $2.
damage() {
    cp "$tmp/m.node" "$tmp/$1.node" && cp "$tmp/m.face" "$tmp/$1.face" || exit 99
    awk "$2" "$tmp/m.ele" >"$tmp/$1.ele" || exit 99
}
# drop the 100th tetrahedron (and fix the count)
damage hole '/^#/ { next } !h { $1 = $1 - 1; h = 1; print; next } ++n == 100 { next } { $1 = n < 100 ? $1 : $1 - 1; print }'
# swap two corners of the 100th tetrahedron
damage flip '/^#/ { next } !h { h = 1; print; next } ++n == 100 { x = $2; $2 = $3; $3 = x } { print }'

"$PDR" check --plc "$tmp/cic.poly" "$tmp/hole" >"$tmp/out"
[ $? -eq 1 ] || fail "a removed tetrahedron passed"
grep -Eq '^  one-sided faces not among them +[1-9].*DEFECT' "$tmp/out" ||
    fail "the hole's faces are not reported"
grep -Eq '^  relative difference .*DEFECT' "$tmp/out" || fail "the volume is not reported"

"$PDR" check --plc "$tmp/cic.poly" "$tmp/flip" >"$tmp/out"
[ $? -eq 1 ] || fail "an inverted tetrahedron passed"
grep -Eq '^  inverted tetrahedra +1 .*DEFECT' "$tmp/out" || fail "inversion not reported"

# --max-ratio below what the mesh has is a defect
"$PDR" check -q --max-ratio 1.0 "$tmp/m" >"$tmp/out"
[ $? -eq 1 ] || fail "--max-ratio 1 passed"
echo "ok"
