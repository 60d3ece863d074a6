#!/bin/sh
# Headers that promise absurd sizes (10^12 vertices, a billion corners,
# 2^32 - 1 binary STL triangles, 4 * 10^9 points of a .node) in files of a
# few bytes are refused with a file:line message and exit status 1, and
# nothing is written. The readers run under 'ulimit -v' of 256 MB (ASan's
# allocation limit under the sanitizers), so one that allocated for the
# promised count before reading fails with "out of memory" instead, and
# the message check fails. (The control frames'
# absurd sizes, such as a GATHER claiming 1 GiB, are refused in the
# regression corpus of tests/fuzz/replay_control: bad-*.)
set -u
fail() { echo "FAIL: $*"; exit 1; }
tool=$top_builddir/tests/plc_tool
pdr=$top_builddir/pdr
[ -x "$tool" ] && [ -x "$pdr" ] || { echo "plc_tool or pdr not built"; exit 99; }
work=$(pwd)/huge-counts.$$
mkdir -p "$work" || exit 99
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 99

printf '1000000000000 3 0 0\n1 0 0 0\n' >huge.poly
printf '# header\n999999999 3 0 0\n1 0 0 0\n2 1 0 0\n' >huge.smesh
printf 'OFF\n1000000000000 1 0\n' >huge.off
printf 'OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n999999999 0 1 2\n' >corners.off
printf '3 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n1 0\n1\n999999999 1 2 3\n' >corners.poly
# 80 header bytes, the count 0xffffffff, one 50-byte triangle.
{ head -c 80 /dev/zero | tr '\0' 'x'; printf '\377\377\377\377'; head -c 50 /dev/zero; } >huge.stl
printf '4000000000 3 0 0\n1 0 0 0\n' >huge.node
printf '1000000000000 3 0 0\n1 0 0 0\n' >tera.node

# The address-space limit. Under AddressSanitizer 'ulimit -v' cannot be
# used (its shadow memory alone needs terabytes of address space, and the
# program aborts at start); there ASan's own limit does the same job: an
# allocation above 256 MB returns NULL, and a reader that allocated first
# says "out of memory" instead of the message below.
if (ulimit -v 262144 && exec "$pdr" --version) >/dev/null 2>&1; then
    limited() { (ulimit -v 262144 && exec "$@"); }
else
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}max_allocation_size_mb=256:allocator_may_return_null=1"
    export ASAN_OPTIONS
    limited() { "$@"; }
    echo "huge counts: 'ulimit -v' cannot run pdr here (AddressSanitizer?); ASan's 256 MB allocation limit instead"
fi

# command | file | the message that must appear, verbatim
while IFS='|' read -r cmd file msg; do
    [ -n "$file" ] || continue
    rm -f w.* out.*
    case $cmd in
    plc) run="$tool $file -o w.poly" ;;
    delaunay) run="$pdr delaunay $file -o out" ;;
    esac
    # shellcheck disable=SC2086
    limited $run >stdout 2>stderr
    rc=$?
    [ $rc -eq 1 ] || { cat stderr; fail "$file: exit $rc, expected 1"; }
    grep -Fqx -- "$msg" stderr || { cat stderr; fail "$file: missing message: $msg"; }
    for w in w.* out.*; do
        [ -e "$w" ] && fail "$file: $w written although the input was refused"
    done
done <<'TABLE'
plc|huge.poly|huge.poly:1: vertex count 1000000000000 is out of range [0, 1000000000]
plc|huge.smesh|huge.smesh:4: unexpected end of file while reading the vertex list
plc|huge.off|huge.off:2: vertex count 1000000000000 is out of range [0, 1000000000]
plc|corners.off|corners.off:6: unexpected end of file while reading vertex index
plc|corners.poly|corners.poly:7: unexpected end of file while reading vertex index
plc|huge.stl|huge.stl: neither ASCII STL (no 'solid' at the start) nor binary STL (the header's 4294967295 triangles need 214748364834 bytes, the file has 134)
delaunay|huge.node|huge.node:2: file ends after 1 of 4000000000 points
delaunay|tera.node|tera.node:1: point count 1000000000000 is out of range [0, 4294967278]
TABLE
echo "huge counts: ok"
