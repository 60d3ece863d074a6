#!/bin/sh
# tools/stress-parallel at a tiny scale: four random parallel runs of 3-4
# PEs (20,000 tetrahedra, random parts and latency), every second one a
# fault run (a PE killed in run 2, one stopped in run 4):
#  - the script exits 0 and its summary counts two completed runs checked
#    by pdr check and two fault runs that ended cleanly;
#  - it prints one line per run.
set -u
tmp=$(pwd)/stress-smoke.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

timeout 240 "$top_srcdir/tools/stress-parallel" --pdr "$PDR" --runs 4 --pes "3 4" \
    --tets 20000 --fault-every 2 --time 200 --out "$tmp/out" >"$tmp/log" 2>&1
rc=$?
cat "$tmp/log"
[ "$rc" -eq 0 ] || fail "tools/stress-parallel exited $rc"
grep -q '^stress-parallel: 4 runs (2 completed and checked, 2 fault runs ended cleanly), failures: 0' \
    "$tmp/log" || fail "unexpected summary"
[ "$(grep -c '^run [0-9]*: ' "$tmp/log")" -eq 4 ] || fail "not one line per run"
grep -q 'SIGKILL to a PE: ended with status' "$tmp/log" || fail "no killed-PE run"
grep -q 'SIGSTOP to a PE: ended with status' "$tmp/log" || fail "no stopped-PE run"
