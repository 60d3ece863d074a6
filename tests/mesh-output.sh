#!/bin/sh
# The .vtu and .msh files of pdr mesh read back with meshio: as many points,
# tetrahedra and boundary triangles as the TetGen files, the same volume,
# region attributes and facet markers carried. Skipped without meshio.
set -u
fail() { echo "FAIL: $*"; exit 1; }
py=
for c in "${PYTHON3:-}" python3 /usr/bin/python3; do
    [ -n "$c" ] || continue
    if "$c" -c 'import meshio' 2>/dev/null; then py=$c; break; fi
done
[ -n "$py" ] || { echo "SKIP: no python3 with meshio (Debian package python3-meshio)"; exit 77; }
tmp=$(pwd)/mesh-output.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$PDR" domain tee -o "$tmp/tee.poly" >/dev/null || exit 99
"$PDR" mesh -a 0.005 -f node,vtu,msh -o "$tmp/m" "$tmp/tee.poly" >"$tmp/out" ||
    fail "pdr mesh exited $?"
grep -q "wrote $tmp/m.vtu" "$tmp/out" || fail "no .vtu written"
grep -q "wrote $tmp/m.msh" "$tmp/out" || fail "no .msh written"
"$py" - "$tmp/m" <<'PY' || fail "meshio read-back"
import sys
import numpy as np
import meshio
base = sys.argv[1]
def rows(path):
    out = []
    for line in open(path):
        line = line.split("#")[0].split()
        if line:
            out.append(line)
    return out
node = rows(base + ".node"); ele = rows(base + ".ele"); face = rows(base + ".face")
nv, nt, nf = int(node[0][0]), int(ele[0][0]), int(face[0][0])
pts = np.array([[float(x) for x in r[1:4]] for r in node[1:]])
tets = np.array([[int(x) - 1 for x in r[1:5]] for r in ele[1:]])
def vol(p, t):
    a, b, c, d = (p[t[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6
want = vol(pts, tets).sum()
for ext in ("vtu", "msh"):
    m = meshio.read(base + "." + ext)
    t = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    if len(m.points) != nv or len(t) != nt:
        sys.exit("%s: %d points, %d tetrahedra; the TetGen files have %d, %d"
                 % (ext, len(m.points), len(t), nv, nt))
    v = vol(m.points, t)
    if (v <= 0).any() or abs(v.sum() - want) > 1e-12 * want:
        sys.exit("%s: volume %.15g, expected %.15g" % (ext, v.sum(), want))
    print(ext, "points", len(m.points), "tetrahedra", len(t))
m = meshio.read(base + ".msh")
tri = [c.data for c in m.cells if c.type == "triangle"]
ntri = sum(len(x) for x in tri)
if ntri != nf:
    sys.exit("msh: %d triangles, the .face file has %d" % (ntri, nf))
phys = m.cell_data["gmsh:physical"]
markers = set()
for c, p in zip(m.cells, phys):
    if c.type == "triangle":
        markers.update(int(x) for x in p)
if markers != set(range(1, 9)):
    sys.exit("msh: facet markers %s, expected 1..8" % sorted(markers))
reg = [c for c in m.cell_data["gmsh:physical"]]
print("msh triangles", ntri, "markers", sorted(markers))
PY
echo "ok"
