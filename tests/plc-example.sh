#!/bin/sh
# TetGen's own example.poly (read from Debian's tetgen package, never
# copied here) is read and validated, and survives a write/read round trip.
set -u
fail() { echo "FAIL: $*"; exit 1; }
ex=/usr/share/doc/tetgen/examples/example.poly
[ -r "$ex" ] || { echo "SKIP: $ex not installed (Debian package tetgen)"; exit 77; }
tool=$top_builddir/tests/plc_tool
tmp=$(pwd)/plc-example.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$tool" "$ex" -o "$tmp/again.poly" >"$tmp/first" 2>"$tmp/err" || { cat "$tmp/err"; fail "example.poly refused"; }
grep -q '^vertices 28 facets 23 polygons 24 .* holes 2 regions 2 ' "$tmp/first" ||
    fail "unexpected summary: $(cat "$tmp/first")"
"$tool" "$tmp/again.poly" >"$tmp/second" 2>"$tmp/err" || { cat "$tmp/err"; fail "round trip refused"; }
cmp -s "$tmp/first" "$tmp/second" || fail "round trip differs: $(cat "$tmp/first") / $(cat "$tmp/second")"
echo "example.poly: $(cat "$tmp/first")"
