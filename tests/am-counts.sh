#!/bin/sh
# Send accounting: every PE sends messages of known sizes to the next one by
# each send path (am_send, am_send_buf, am_send_zc, am_call answered by
# am_reply and by am_reply_to), and checks that its statistics count each
# exactly once, sent and received: in total, per handler, per control type
# and in the reply counters. Also with frames waiting in the local send
# queue (high-water mark 1) and in latency queues.
. "$top_srcdir/tests/am-lib.sh"

for np in 1 3; do
    job 60 "$AMRUN" -n "$np" -- "$MP" counts
    expect_ok "counts on $np PEs"
    [ "$(grep -c '^counts: PE [0-9]*: 16 messages, 70287 bytes each way, counted once' "$work/out")" -eq "$np" ] ||
        fail "counts on $np PEs: not every PE reported"
done
AM_HWM=1 job 60 "$AMRUN" -n 3 -- "$MP" counts
expect_ok "counts with a high-water mark of 1"
job 60 "$AMRUN" -n 2 --latency 100us-1ms -- "$MP" counts
expect_ok "counts with injected latency"
echo "counts: ok"
