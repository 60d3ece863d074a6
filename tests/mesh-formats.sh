#!/bin/sh
# The same closed surface as .off, .obj, .ply and Medit .mesh gives the
# same mesh: each file is written here from tests/data/surf/torus-0.3.off
# and gridcube.off (a cube whose faces are grids of triangles: the
# constrained mode is chosen for it only because it is a surface file)
# (awk, vertices and faces in the same order, with the decorations other
# tools add: normals and texture indices in OBJ, extra properties and
# elements in PLY, skipped sections in Medit), meshed by pdr mesh with a
# size bound, and its .node, .ele and .face compared byte for byte with
# those of the .off. A 2-PE run of the .ply is checked against its input
# (the parallel pipeline reads the file on rank 0 only). Then a point
# cloud and a broken file are refused with file:line and no output.
set -u
fail() { echo "FAIL: $*"; exit 1; }
pdr=${PDR:-./pdr}
tmp=$(pwd)/mesh-formats.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
# convert OFF DIR: DIR/t.obj, DIR/t.ply and DIR/t.mesh from OFF.
convert() {
awk 'NR == 2 { nv = $1; nf = $2; next } NR > 2 && NR <= 2 + nv { v[NR - 3] = $1 " " $2 " " $3; next }
     NR > 2 + nv && $1 == 3 { f[nfc++] = $2 " " $3 " " $4 }
     END {
        print "# from " FILENAME > obj; print "o part" > obj
        for (i = 0; i < nv; i++) { print "v " v[i] " 1 0 0" > obj; print "vn 0 0 1" > obj }
        for (k = 0; k < nfc; k++) { split(f[k], c, " ")
            if (k % 2) print "f " c[1]+1 "//1 " c[2]+1 "//1 " c[3]+1 "//1" > obj
            else print "f " c[1]-nv " " c[2]-nv " " c[3]-nv > obj }
        printf "ply\nformat ascii 1.0\ncomment from %s\nelement vertex %d\n", FILENAME, nv > ply
        printf "property double x\nproperty double y\nproperty double z\nproperty uchar red\n" > ply
        printf "element face %d\nproperty list uchar int vertex_indices\n", nfc > ply
        printf "element edge 0\nproperty int v1\nproperty int v2\nend_header\n" > ply
        for (i = 0; i < nv; i++) print v[i] " 255" > ply
        for (k = 0; k < nfc; k++) print "3 " f[k] > ply
        printf "MeshVersionFormatted 2\nDimension 3\nVertices\n%d\n", nv > mesh
        for (i = 0; i < nv; i++) print v[i] " 0" > mesh
        printf "Edges\n1\n1 2 0\nTriangles\n%d\n", nfc > mesh
        for (k = 0; k < nfc; k++) { split(f[k], c, " "); print c[1]+1, c[2]+1, c[3]+1, 0 > mesh }
        print "End" > mesh
     }' obj="$2/t.obj" ply="$2/t.ply" mesh="$2/t.mesh" "$1"
}

run() { # run NAME FILE [OPTIONS...]: pdr mesh into $tmp/NAME.*
    name=$1 in=$2
    shift 2
    "$pdr" mesh -q 2 "$@" -o "$tmp/$name" "$in" >"$tmp/$name.out" 2>&1 ||
        { cat "$tmp/$name.out"; fail "pdr mesh $in: exit $?"; }
}
for case in torus-0.3:-a:2e-4 gridcube; do
    surf=${case%%:*} opts=$(echo "${case#"$surf"}" | tr : ' ')
    off=$top_srcdir/tests/data/surf/$surf.off
    convert "$off" "$tmp" || exit 99
    # shellcheck disable=SC2086
    run off "$off" $opts
    grep -q "^initial mesh (constrained Delaunay)" "$tmp/off.out" || fail "$surf: not constrained"
    for ext in obj ply mesh; do
        # shellcheck disable=SC2086
        run "$ext" "$tmp/t.$ext" $opts
        for part in node ele face; do
            cmp -s "$tmp/off.$part" "$tmp/$ext.$part" ||
                fail "$surf.$ext: its .$part differs from the .off's"
        done
    done
done

# 2 PEs from the .ply: the merged mesh checks against the .ply.
"$pdr" mesh -n 2 --rank0-points 0 -q 2 -a 2e-4 -o "$tmp/par" "$tmp/t.ply" >"$tmp/par.out" 2>&1 ||
    { cat "$tmp/par.out"; fail "pdr mesh -n 2 t.ply"; }
"$pdr" check --plc "$tmp/t.ply" "$tmp/par" >"$tmp/check.out" 2>&1 ||
    { cat "$tmp/check.out"; fail "pdr check of the 2-PE mesh of t.ply"; }

# A point cloud, and an OBJ face naming a vertex that is not there.
printf 'ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n' >"$tmp/cloud.ply"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n' >"$tmp/bad.obj"
for bad in cloud.ply:7 bad.obj:5; do
    f=${bad%:*} line=${bad#*:}
    if "$pdr" mesh -o "$tmp/bad" "$tmp/$f" >"$tmp/bad.out" 2>&1; then fail "$f was meshed"; fi
    grep -q "$f:$line: " "$tmp/bad.out" || { cat "$tmp/bad.out"; fail "$f: no $f:$line message"; }
    [ ! -e "$tmp/bad.node" ] || fail "$f: output written"
done
echo "ok"
