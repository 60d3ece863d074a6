#!/bin/sh
# pdr delaunay and pdr check end to end: random points, a grid read from a
# .node file, every way of naming the mesh, the output format, and (when
# TetGen is installed) a TetGen mesh checked by pdr and vice versa.
set -u
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdr-delaunay-XXXXXX") || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# Random points: summary, files, a clean check.
"$PDR" delaunay --random 3000 --seed 5 -o "$tmp/r" --faces >"$tmp/out" 2>&1 ||
    fail "pdr delaunay --random exited $?: $(cat "$tmp/out")"
grep -q '^tetrahedra: *[1-9][0-9]*$' "$tmp/out" || fail "no tetrahedra count: $(cat "$tmp/out")"
grep -q '^tetrahedra per second:' "$tmp/out" || fail "no rate in the summary"
grep -q '^peak RSS bytes:' "$tmp/out" || fail "no peak RSS in the summary"
grep -q '^mesh bytes per tet:' "$tmp/out" || fail "no bytes per tet in the summary"
for f in r.node r.ele r.face; do [ -s "$tmp/$f" ] || fail "$f not written"; done
for f in "$tmp"/*.tmp.*; do [ -e "$f" ] && fail "temporary file left: $f"; done
ntets=$(sed -n 's/^tetrahedra: *//p' "$tmp/out")
head=$(grep -v '^#' "$tmp/r.ele" | head -1 | awk '{print $1, $2, $3}')
[ "$head" = "$ntets 4 0" ] || fail ".ele header '$head', expected '$ntets 4 0'"
nhull=$(sed -n 's/^convex hull faces: *//p' "$tmp/out")
fhead=$(grep -v '^#' "$tmp/r.face" | head -1 | awk '{print $1}')
[ "$fhead" = "$nhull" ] || fail ".face has $fhead faces, summary says $nhull"
# Numbered from 1 like TetGen; 3000 points.
grep -v '^#' "$tmp/r.node" | head -2 | tail -1 | grep -q '^ *1 ' || fail ".node does not start at 1"

for name in "$tmp/r" "$tmp/r.node" "$tmp/r.ele"; do
    "$PDR" check "$name" >"$tmp/chk" 2>&1 || fail "pdr check $name: $(cat "$tmp/chk")"
    grep -q '^ok: 0 defects$' "$tmp/chk" || fail "pdr check $name: no verdict"
done
grep -q "tetrahedra  *$ntets\$" "$tmp/chk" || fail "check counts a different number of tets"

# --check inside pdr delaunay, and the same points read back from the file
# give the same mesh size.
"$PDR" delaunay --check "$tmp/r.node" -o "$tmp/r2" >"$tmp/out2" 2>&1 ||
    fail "pdr delaunay --check r.node: $(cat "$tmp/out2")"
grep -q '^check seconds:.*(ok)' "$tmp/out2" || fail "--check did not report ok"
grep -q "^tetrahedra: *$ntets\$" "$tmp/out2" || fail "re-reading the points changed the mesh"
cmp -s "$tmp/r.node" "$tmp/r2.node" || fail "the .node file does not round-trip"

# A grid (cospherical everywhere), numbered from 0, with attributes and
# markers, and comments.
awk 'BEGIN { print "# a grid"; print "512 3 1 1";
             n = 0; for (i = 0; i < 8; i++) for (j = 0; j < 8; j++) for (k = 0; k < 8; k++) {
               printf "%d %d %d %d 0.5 %d # p\n", n, i, j, k, n % 2; n++ } }' >"$tmp/grid.node"
"$PDR" delaunay "$tmp/grid.node" -o "$tmp/g" >"$tmp/out" 2>&1 || fail "grid: $(cat "$tmp/out")"
"$PDR" check "$tmp/g" >"$tmp/chk" 2>&1 || fail "grid check: $(cat "$tmp/chk")"
grep -v '^#' "$tmp/g.ele" | sed -n 2p | grep -q '^ *0 ' || fail "grid .ele not numbered from 0"
grep -v '^#' "$tmp/g.node" | sed -n 1p | grep -q '^ *512  *3  *1  *1$' || fail "grid .node header lost attributes/markers"
grep -v '^#' "$tmp/g.ele" | awk 'NR > 1 { for (i = 2; i <= 5; i++) if ($i < 0 || $i > 511) bad = 1 }
    END { exit bad }' || fail "grid node number out of range"

# Duplicates are skipped, counted, and accepted by the checker.
{ echo "6 3 0 0"; echo "1 0 0 0"; echo "2 1 0 0"; echo "3 0 1 0"; echo "4 0 0 1";
  echo "5 1 0 0"; echo "6 0.2 0.2 0.2"; } >"$tmp/dup.node"
"$PDR" delaunay "$tmp/dup.node" -o "$tmp/d" >"$tmp/out" 2>&1 || fail "dup: $(cat "$tmp/out")"
grep -q '^duplicate points: *1 ' "$tmp/out" || fail "duplicate not counted: $(cat "$tmp/out")"
"$PDR" check "$tmp/d" >"$tmp/chk" 2>&1 || fail "dup check: $(cat "$tmp/chk")"
grep -q 'duplicate points (not inserted) *1$' "$tmp/chk" || fail "check does not see the duplicate"

# TetGen's mesh passes our checker, ours has TetGen's orientation.
if [ -n "${TETGEN:-}" ] && [ -x "$TETGEN" ]; then
    (cd "$tmp" && "$TETGEN" -Q r.node) >/dev/null 2>&1 || fail "tetgen failed on r.node"
    "$PDR" check "$tmp/r.1" >"$tmp/chk" 2>&1 || fail "pdr check on TetGen's mesh: $(cat "$tmp/chk")"
    tg=$(grep -v '^#' "$tmp/r.1.ele" | head -1 | awk '{print $1}')
    [ "$tg" = "$ntets" ] || fail "TetGen has $tg tetrahedra, pdr $ntets"
else
    echo "tetgen not found: TetGen comparison skipped"
fi
echo "pdr delaunay/check: ok"
