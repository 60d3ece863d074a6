#!/bin/sh
# The output stages of pdr mesh run side by side on threads for meshes of
# 50,000 tetrahedra or more (mesher/base/fj.h): every file must be the
# same byte for byte whatever the number of threads (PDR_THREADS=1, 3, the
# cores), and so must the summary's mesh and quality lines; a file that
# cannot be created fails the run with one message and leaves nothing.
set -u
fail() { echo "FAIL: $*"; exit 1; }
tmp=$(pwd)/mesh-threads.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || exit 99
for t in 1 3 cores; do
    mkdir "$tmp/$t" || exit 99
    if [ "$t" = cores ]; then
        env -u PDR_THREADS "$PDR" mesh -a 2e-5 -f node,vtu,msh -o "$tmp/$t/m" "$tmp/cic.poly" \
            >"$tmp/$t/out" 2>&1 || fail "PDR_THREADS unset: pdr mesh exited $?"
    else
        PDR_THREADS=$t "$PDR" mesh -a 2e-5 -f node,vtu,msh -o "$tmp/$t/m" "$tmp/cic.poly" \
            >"$tmp/$t/out" 2>&1 || fail "PDR_THREADS=$t: pdr mesh exited $?"
    fi
    nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$tmp/$t/out")
    [ "${nt:-0}" -ge 50000 ] || fail "PDR_THREADS=$t: $nt tetrahedra, the test needs 50000"
    grep -E '^(mesh|quality|left above)' "$tmp/$t/out" >"$tmp/$t/summary"
done
for t in 3 cores; do
    for ext in node ele face vtu msh; do
        cmp -s "$tmp/1/m.$ext" "$tmp/$t/m.$ext" || fail "PDR_THREADS=$t: m.$ext differs from one thread's"
    done
    cmp -s "$tmp/1/summary" "$tmp/$t/summary" || fail "PDR_THREADS=$t: the summary differs"
done
ls "$tmp"/*/ | grep -q '\.tmp\.' && fail "temporary file left"

# Every file fails (no such directory): one message, for the first file,
# and nothing written.
PDR_THREADS=3 "$PDR" mesh -a 2e-5 -f node,vtu,msh -o "$tmp/none/m" "$tmp/cic.poly" \
    >"$tmp/err" 2>&1 && fail "an unwritable output did not fail"
n=$(grep -c 'cannot create' "$tmp/err")
[ "$n" -eq 1 ] || fail "$n 'cannot create' lines, expected 1"
grep -q "none/m.node: cannot create" "$tmp/err" || fail "the message does not name m.node"
[ ! -e "$tmp/none" ] || fail "output directory appeared"

# A bad PDR_THREADS is named and ignored: the run writes its files.
mkdir "$tmp/bad" || exit 99
PDR_THREADS=zero "$PDR" mesh -a 2e-5 -o "$tmp/bad/m" "$tmp/cic.poly" >"$tmp/bad.out" 2>&1 ||
    fail "PDR_THREADS=zero: pdr mesh exited $?"
grep -q "^pdr mesh: PDR_THREADS='zero' is not a count from 1 to 64; ignored" "$tmp/bad.out" ||
    fail "PDR_THREADS=zero: no message"
cmp -s "$tmp/1/m.ele" "$tmp/bad/m.ele" || fail "PDR_THREADS=zero: m.ele differs"
echo "ok"
