#!/bin/sh
# All-to-all ping storms: every PE sends random-length, random-content
# messages to every PE (itself included); each must arrive exactly once, in
# order, with the right bytes -- on ipc with 2, 4 and 16 PEs, on tcp, and
# with a tiny ZeroMQ high-water mark that forces the local send queue.
. "$top_srcdir/tests/am-lib.sh"

for np in 2 4 16; do
    n=400
    [ "$np" -eq 16 ] && n=40
    job 120 "$AMRUN" -n "$np" -- "$MP" storm "$n" 4000
    expect_ok "storm on $np PEs (ipc)"
    expect_line "^storm: $np PEs, $((np * np * n)) messages delivered exactly once.* 0 failed checks" "storm $np"
done

job 120 "$AMRUN" -n 4 -t tcp -- "$MP" storm 300 4000
expect_ok "storm on 4 PEs (tcp)"
expect_line "^storm: 4 PEs, 4800 messages delivered exactly once" "storm tcp"

AM_HWM=4 job 120 "$AMRUN" -n 4 --stats "$work/st" -- "$MP" storm 500 4000
expect_ok "storm with AM_HWM=4"
expect_line "^storm: 4 PEs, 8000 messages delivered exactly once" "storm hwm"
queued=$(sed -n 's/.*"queued_sends": \([0-9]*\).*/\1/p' "$work"/st/stats-*.json | awk '{s += $1} END {print s + 0}')
[ "$queued" -gt 0 ] || fail "with AM_HWM=4 no send went through the local queue"
echo "storm: ok ($queued sends waited in the local queue with AM_HWM=4)"
