#!/bin/sh
# The dihedral-angle plot: gnuplot makes a PNG; a failing gnuplot leaves
# no file. Skipped without gnuplot.
set -u
fail() { echo "FAIL: $*"; exit 1; }
command -v gnuplot >/dev/null 2>&1 || { echo "SKIP: gnuplot not installed"; exit 77; }
tmp=$(pwd)/output-plot.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
tool=$top_builddir/tests/mesh_out_tool
"$tool" 4 -q >"$tmp/q" || fail "statistics failed"
grep -q '^tetrahedra 384 (' "$tmp/q" || fail "statistics: $(head -1 "$tmp/q")"
grep -q '^radius-edge ratio min 0.8660 max 0.8660' "$tmp/q" || fail "ratios: $(sed -n 2p "$tmp/q")"
"$tool" 4 -p "$tmp/dihedral.png" 2>"$tmp/err" || { cat "$tmp/err"; fail "plot failed"; }
head -c 8 "$tmp/dihedral.png" | od -An -c | grep -q 'P   N   G' || fail "not a PNG"
PDR_GNUPLOT=false "$tool" 4 -p "$tmp/none.png" 2>"$tmp/err" && fail "a failing gnuplot was not noticed"
grep -q 'false failed' "$tmp/err" || fail "unclear message: $(cat "$tmp/err")"
ls "$tmp" | grep -q 'none.png' && fail "a failed plot left a file: $(ls "$tmp")"
echo "plot: ok"
