#!/bin/sh
# Flow control: every PE floods one PE -- from threads, from the main
# context and from handlers -- and memory stays bounded, every message
# arrives exactly once, termination detection still ends the job, and a
# handler that sends past its queue is refused with AM_EFULL. Two PEs that
# flood each other while their handlers answer every message do not
# deadlock. Each job is bounded in time (am-lib.sh).
#
# The bounds (runtime/CONTROL.md, "Flow control"): at most AM_SEND_WINDOW
# bytes in flight from one PE to another, at most AM_SEND_QUEUE bytes of a
# PE's handler sends waiting for one destination; a message counts its
# payload plus 88 bytes. PE 0 below can thus hold at most 7 windows from
# the others plus its own window and queue toward itself, on top of the
# program's own memory (about 7 MiB): the bounds leave room for ZeroMQ's
# and malloc's slack. Without flow control PE 0's memory grew with the
# volume sent (it peaked at 369, 198, 213 and 47 MiB in the first four
# jobs below) and no handler send was ever refused.
. "$top_srcdir/tests/am-lib.sh"

win=1048576
queue=4194304

# 8 PEs, 4 threads and the main context each sending 3000 messages of 2-4
# KiB to PE 0 (plus the handlers' bursts: about 720 MiB in all).
AM_SEND_WINDOW=$win AM_SEND_QUEUE=$queue \
    job 240 "$AMRUN" -n 8 -- "$MP" flood 3000 4096 4 48
expect_ok "flood on 8 PEs"
expect_line "^flood: 8 PEs, [0-9]* messages .* delivered exactly once, checksums agree" "flood"
expect_line "^flood: a handler's sends to PE 0 stopped by AM_EFULL" "flood overflow"
grep '^flood' "$work/out"

# The same with the default bounds, on 4 PEs.
job 240 "$AMRUN" -n 4 -- "$MP" flood 2000 4096 4 96
expect_ok "flood on 4 PEs with the default bounds"
expect_line "^flood: 4 PEs, [0-9]* messages .* delivered exactly once" "flood defaults"
grep '^flood' "$work/out"

# Injected latency and a bandwidth cap: frames wait in the receiver's
# latency queue, which the window bounds as well.
AM_SEND_WINDOW=$win AM_SEND_QUEUE=$queue \
    job 240 "$AMRUN" -n 4 --latency 100us-1ms --bandwidth 800Mbit -- "$MP" flood 600 4096 2 48
expect_ok "flood under injected latency and bandwidth"
expect_line "^flood: 4 PEs, [0-9]* messages .* delivered exactly once" "flood latency"
grep '^flood' "$work/out"

# Pairs flooding each other while their handlers answer each message, with
# small windows, and once more with a tiny ZeroMQ high-water mark.
AM_SEND_WINDOW=65536 AM_SEND_QUEUE=1048576 \
    job 240 "$AMRUN" -n 4 -- "$MP" flood-pair 3000 2048 4 24
expect_ok "flood-pair"
expect_line "^flood-pair: 4 PEs, [0-9]* messages .* delivered exactly once" "flood-pair"
grep '^flood' "$work/out"
AM_HWM=4 AM_SEND_WINDOW=65536 AM_SEND_QUEUE=1048576 \
    job 240 "$AMRUN" -n 2 --latency 50us-500us -- "$MP" flood-pair 1000 2048 4 24
expect_ok "flood-pair with AM_HWM=4 and latency"
expect_line "^flood-pair: 2 PEs, [0-9]* messages .* delivered exactly once" "flood-pair hwm"
grep '^flood' "$work/out"
echo "flood: ok"
