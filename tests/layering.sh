#!/bin/sh
# The layering of mesher/ (tools/check-layers): the tree as it is passes,
# and a copy with one upward include and one include without its folder
# fails, naming both lines.
set -u
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdr-layers-XXXXXX") || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
check=$top_srcdir/tools/check-layers

"$SHELL" "$check" "$top_srcdir/mesher" >"$tmp/out" 2>&1 ||
    fail "mesher/ breaks its layering:
$(cat "$tmp/out")"

cp -R "$top_srcdir/mesher" "$tmp/mesher" || exit 99
chmod -R u+w "$tmp/mesher"
f=$tmp/mesher/base/pdr_util.c
[ -f "$f" ] || exit 99
printf '#include "refine/refine.h"\n#include "tm.h"\n' >>"$f"
n=$(wc -l <"$f")
if "$SHELL" "$check" "$tmp/mesher" >"$tmp/out" 2>&1; then
    fail "an upward include was not caught"
fi
grep -q "base/pdr_util.c:$((n - 1)): base includes \"refine/refine.h\", a layer it may not use" \
    "$tmp/out" || fail "no line for the upward include: $(cat "$tmp/out")"
grep -q "base/pdr_util.c:$n: base includes \"tm.h\" without naming its folder" \
    "$tmp/out" || fail "no line for the folderless include: $(cat "$tmp/out")"
[ "$(wc -l <"$tmp/out")" -eq 2 ] || fail "unexpected lines: $(cat "$tmp/out")"
echo "ok: layering holds; an upward include is reported"
