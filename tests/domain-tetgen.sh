#!/bin/sh
# TetGen accepts both model problems: 'tetgen -pQ' exits 0 and produces
# tetrahedra. Skipped when tetgen is not installed.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tg=${TETGEN:-}
[ -n "$tg" ] && [ -x "$tg" ] || tg=$(command -v tetgen || true)
[ -n "$tg" ] || { echo "SKIP: tetgen not installed"; exit 77; }
tmp=$(pwd)/domain-tetgen.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
for d in cube-in-cube tee; do
    "$PDR" domain $d -o "$tmp/$d.poly" >/dev/null || fail "pdr domain $d"
    "$tg" -pQ "$tmp/$d.poly" >"$tmp/log" 2>&1 || { rc=$?; cat "$tmp/log"; fail "tetgen -pQ $d.poly exited $rc"; }
    n=$(sed -n '1s/^ *\([0-9]*\).*/\1/p' "$tmp/$d.1.ele")
    [ "${n:-0}" -gt 0 ] || fail "tetgen made no tetrahedra for $d"
    echo "tetgen -pQ $d.poly: $n tetrahedra"
done
