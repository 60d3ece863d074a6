#!/bin/sh
# pdr mesh -n P: no parallel run goes on for ever (issue 12).
#  - the progress bound (mesher/par/par_run.h, PAR_RUN_STALL_WINDOW): with
#    PDR_PAR_STALL set so that an ordinary run's work per inserted point
#    is too much (a stretch of 4,096 units, one point per unit), every PE
#    stops: exit 1, the message naming the cause, no output file, no PE
#    left running; with the defaults the same run meshes;
#  - its other leg, on the clock (PAR_RUN_STALL_SECONDS): with the
#    seconds set below any step's time, the first attempt that inserts
#    nothing stops every PE the same way, the message naming that cause;
#  - --max-points bounds each PE's points: past it every PE stops the
#    same way, with the bound named.
# Each run is bounded by timeout; the job's PEs are children of pdr mesh,
# which ends them.
set -u
tmp=$(pwd)/mesh-parallel-stall.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || exit 99

# NAME WHAT ARGS...: a run that must stop with status 1, the message
# matching WHAT, and write nothing.
stops() {
    name=$1
    what=$2
    shift 2
    timeout 60 "$PDR" mesh -n 2 -q 2 "$@" -o "$tmp/$name" "$tmp/cic.poly" >"$tmp/$name.out" 2>&1
    rc=$?
    [ "$rc" -eq 1 ] || { cat "$tmp/$name.out"; fail "$name: exit $rc, not 1"; }
    grep -q "$what" "$tmp/$name.out" || { cat "$tmp/$name.out"; fail "$name: no '$what'"; }
    for ext in node ele face; do
        [ ! -e "$tmp/$name.$ext" ] || fail "$name: $name.$ext written"
    done
    # shellcheck disable=SC2009
    if ps -eo args | grep -v grep | grep -q -- "-o $tmp/$name "; then
        fail "$name: a PE outlived the job"
    fi
    echo "$name: $(grep "$what" "$tmp/$name.out" | head -n 1)"
}

PDR_PAR_STALL=4096,1 stops stall 'the parallel refinement makes no progress: its last' -a 1e-5
PDR_PAR_STALL=1e12,1,1e-9 stops clock 'it inserted no point in the last' -a 1e-5
# The default bound leaves the same run alone.
timeout 60 "$PDR" mesh -n 2 -q 2 -a 1e-5 -o "$tmp/free" "$tmp/cic.poly" >"$tmp/free.out" 2>&1 ||
    { cat "$tmp/free.out"; fail "free: the default bound stopped an ordinary run"; }
[ -e "$tmp/free.ele" ] || fail "free: no mesh"

stops points 'inserted [0-9]* points, the bound of --max-points' -a 1e-5 --mo-size 2000 \
    --max-points 2000
echo "ok"
