#!/bin/sh
# Latency injection delays every message: a round trip with --latency 2ms
# (2 ms each way) must take at least 4 ms, and one with a bandwidth cap
# must take at least the serialisation time. This checks that the delay is
# applied (a correctness property); the figures are not benchmarks.
. "$top_srcdir/tests/am-lib.sh"

rtt() { sed -n 's/^rtt_us \([0-9.]*\) min_us \([0-9.]*\)$/\2/p' "$work/out"; }

job 60 "$AMRUN" -n 2 -- "$MP" rtt 50
expect_ok "rtt without latency"
base=$(rtt)
[ -n "$base" ] || fail "no round trip time printed"

job 60 "$AMRUN" -n 2 --latency 2ms -- "$MP" rtt 20
expect_ok "rtt with --latency 2ms"
lat=$(rtt)
[ "$(echo "$lat >= 4000" | bc)" -eq 1 ] ||
    fail "with --latency 2ms the shortest round trip took $lat us (< 4000 us)"

job 60 "$AMRUN" -n 2 --latency 1ms-3ms -- "$MP" rtt 20
expect_ok "rtt with --latency 1ms-3ms"
rnd=$(rtt)
[ "$(echo "$rnd >= 2000" | bc)" -eq 1 ] ||
    fail "with --latency 1ms-3ms the shortest round trip took $rnd us (< 2000 us)"

# 32-byte payload + 24-byte header = 56 bytes each way at 100 kB/s: 1.12 ms.
job 60 "$AMRUN" -n 2 --bandwidth 100kB -- "$MP" rtt 10
expect_ok "rtt with --bandwidth 100kB"
bw=$(rtt)
[ "$(echo "$bw >= 1120" | bc)" -eq 1 ] ||
    fail "with --bandwidth 100kB the shortest round trip took $bw us (< 1120 us)"
# A job that only starts and stops: a BYE that reaches a PE still in the
# final barrier waits in the latency queue, and must not hold am_finalize
# until its 5 s bound (it used to, on most PEs of such a job).
# Each PE times its own am_finalize: the job's wall time also holds the
# start of 8 processes, which a loaded 2-core machine can stretch to seconds.
job 60 "$AMRUN" -n 8 --latency 100us-2ms -- "$MP" idle
expect_ok "idle job with --latency 100us-2ms"
fins=$(sed -n 's/^PE [0-9]* finalize_s \([0-9.]*\)$/\1/p' "$work/out" | sort -n)
[ "$(echo "$fins" | grep -c .)" -eq 8 ] || fail "the idle job did not print 8 finalize times"
fin=$(echo "$fins" | tail -1)
[ "$(echo "$fin < 2.5" | bc)" -eq 1 ] ||
    fail "am_finalize held a PE of an idle 8-PE job with --latency 100us-2ms for $fin s (job: $elapsed s)"

echo "latency: ok (shortest round trip $base us; with 2ms: $lat us; 1ms-3ms: $rnd us; 100kB/s: $bw us; idle job: longest am_finalize $fin s)"
