#!/bin/sh
# Termination detection under a randomized work-spawning workload: handlers,
# threads (after random sleeps) and timers send work to random PEs, so PEs
# go idle and are re-activated. Termination must be declared (bounded time),
# only once every message was handled, and nothing may arrive afterwards.
# Two epochs per run; ipc with 2, 4, 16 PEs, tcp, and random latency.
. "$top_srcdir/tests/am-lib.sh"

check_term() {
    expect_ok "$1"
    [ "$(grep -c '^term: epoch [01], .* all handled before termination was declared' "$work/out")" -eq 2 ] ||
        fail "$1: termination not declared correctly in both epochs"
}

for np in 2 4 16; do
    job 120 "$AMRUN" -n "$np" -- "$MP" term 4 6
    check_term "term on $np PEs (ipc)"
done
job 120 "$AMRUN" -n 4 -t tcp -- "$MP" term 4 6
check_term "term on 4 PEs (tcp)"
job 120 "$AMRUN" -n 4 --latency 100us-1ms -- "$MP" term 4 6
check_term "term on 4 PEs with injected latency"
echo "term: ok"
