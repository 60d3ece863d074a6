#!/bin/sh
# The .vtu (binary and ascii) and .msh 4.1 writers, read back with meshio:
# counts and order-independent checksums must match what was written,
# tetrahedra must come out positively oriented, and the Gmsh physical tags
# must carry the facet markers and regions. Skipped without meshio.
set -u
fail() { echo "FAIL: $*"; exit 1; }
py=
for c in "${PYTHON3:-}" python3 /usr/bin/python3; do
    [ -n "$c" ] || continue
    if "$c" -c 'import meshio' 2>/dev/null; then py=$c; break; fi
done
[ -n "$py" ] || { echo "SKIP: no python3 with meshio (Debian package python3-meshio)"; exit 77; }
tmp=$(pwd)/output-meshio.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$top_builddir/tests/mesh_out_tool" 3 "$tmp/cube" >"$tmp/want" || fail "mesh_out_tool failed"
cat "$tmp/want"
"$py" - "$tmp/cube" >"$tmp/got" <<'PY' || fail "meshio could not read the files"
import sys
import numpy as np
import meshio
base = sys.argv[1]
def sums(m, name):
    p = m.points
    tets = [c.data for c in m.cells if c.type == "tetra"]
    tris = [c.data for c in m.cells if c.type == "triangle"]
    t = np.concatenate(tets).astype(np.int64)
    st = np.sort(t, axis=1)
    tsum = int((st * [1, 3, 7, 13]).sum())
    a, b, c, d = (p[t[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))
    if (vol <= 0).any():
        sys.exit(name + ": a tetrahedron is not positively oriented")
    out = "points %d tetra %d" % (len(p), len(t))
    if tris:
        f = np.concatenate(tris).astype(np.int64)
        out += " triangles %d trisum %d" % (len(f), int((np.sort(f, axis=1) * [1, 3, 7]).sum()))
    out += " coordsum %.6f tetsum %d" % ((p[:, 0] + 2 * p[:, 1] + 3 * p[:, 2]).sum(), tsum)
    return out
for name in ("cube.vtu", "cube-ascii.vtu"):
    m = meshio.read(base + name[len("cube"):])
    line = sums(m, name)
    reg = m.cell_data.get("region")
    if reg is not None:
        line += " regionsum %d" % int(np.concatenate(reg).sum())
    print(name, line)
m = meshio.read(base + ".msh")
line = sums(m, "cube.msh")
phys = m.cell_data["gmsh:physical"]
tri_phys = sum(int(v.sum()) for c, v in zip(m.cells, phys) if c.type == "triangle")
tet_phys = sum(int(v.sum()) for c, v in zip(m.cells, phys) if c.type == "tetra")
print("cube.msh", line, "regionsum %d markersum %d" % (tet_phys, tri_phys))
PY
cat "$tmp/got"
field() { sed -n "s/^\(.* \)\{0,1\}$1 \([0-9.]*\).*/\2/p" "$2"; }
for k in points tetra coordsum tetsum regionsum; do
    want=$(field $k "$tmp/want")
    for f in cube.vtu cube-ascii.vtu cube.msh; do
        got=$(grep "^$f " "$tmp/got" | field $k -)
        [ "$got" = "$want" ] || fail "$f: $k $got, wrote $want"
    done
done
for k in triangles trisum markersum; do
    want=$(field $k "$tmp/want")
    got=$(grep "^cube.msh " "$tmp/got" | field $k -)
    [ "$got" = "$want" ] || fail "cube.msh: $k $got, wrote $want"
done
# The .face file: header, 1-based numbering, the same triangles.
sed -n 1p "$tmp/cube.face" | grep -qx '108 1' || fail "cube.face header: $(sed -n 1p "$tmp/cube.face")"
fsum=$(awk 'NR > 1 && !/^#/ { a = $2 - 1; b = $3 - 1; c = $4 - 1;
        if (a > b) { t = a; a = b; b = t } if (b > c) { t = b; b = c; c = t }
        if (a > b) { t = a; a = b; b = t } s += a + 3 * b + 7 * c; m += $5 }
        END { print s, m }' "$tmp/cube.face")
[ "$fsum" = "$(field trisum "$tmp/want") $(field markersum "$tmp/want")" ] ||
    fail "cube.face: trisum/markersum $fsum"
echo "meshio read-back: ok"
