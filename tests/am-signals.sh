#!/bin/sh
# Signals to am-run itself. SIGTERM, SIGINT and SIGHUP are forwarded to the
# PEs and am-run cleans up; SIGKILL cannot be caught, so the PEs must die
# of their parent-death signal and the clean-up helper must remove the
# job's socket directory. In every case no PE may be left running and no
# socket directory left behind (it used to be: every PE kept running).
. "$top_srcdir/tests/am-lib.sh"

mkdir "$work/pids" "$work/t" || exit 99
kill_pes() {
    for f in "$work"/pids/pid-*; do
        [ -f "$f" ] && kill -KILL "$(cat "$f")" 2>/dev/null
    done
}
trap 'kill_pes; rm -rf "$work"' EXIT

for sig in TERM INT HUP KILL; do
    rm -f "$work"/pids/pid-*
    # Not under timeout(1), which would take the signal's place as the
    # PEs' parent: am-run's own --timeout and the job's 30 s bound it.
    TMPDIR=$work/t "$AMRUN" -n 4 --timeout 60 -- "$MP" busy "$work/pids" 30 "$tag" \
        >"$work/out" 2>&1 &
    amrun=$!
    i=0
    while [ "$(ls "$work/pids" | wc -l)" -lt 4 ]; do
        i=$((i + 1))
        [ $i -lt 300 ] || fail "the PEs did not start within 30 s"
        sleep 0.1
    done
    dir=$(ls -d "$work"/t/am-* 2>/dev/null)
    [ -n "$dir" ] || fail "no socket directory in $work/t"
    kill -"$sig" $amrun
    i=0
    while kill -0 $amrun 2>/dev/null; do
        i=$((i + 1))
        [ $i -lt 100 ] || fail "am-run still running 10 s after SIG$sig"
        sleep 0.1
    done
    wait $amrun
    rc=$?
    no_leftovers
    i=0
    while [ -e "$dir" ]; do
        i=$((i + 1))
        [ $i -lt 50 ] || fail "SIG$sig to am-run left $dir: $(ls "$dir")"
        sleep 0.1
    done
    echo "SIG$sig to am-run: exit $rc, no PE left, socket directory removed"
done
echo "signals: ok"
