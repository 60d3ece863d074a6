#!/bin/sh
# libam under SCHED_FIFO on one processor, where a process keeps the
# processor until it blocks, so that every wait must block:
# - the same-host rings (runtime/am_shm.c, "Every wait ends in a block"):
#   4 PEs, rings of 4 KiB and messages up to 20,000 bytes, so that writers
#   keep meeting full rings and stop inside a frame (often inside its
#   header) until the reader frees room. A reader that does not block
#   there holds the processor for good and the job hangs: here it must end
#   in seconds. Then 2 PEs bound to a processor each (--cpu-bind core),
#   which use the rings too.
# - the launcher after am_finalize: the PEs closed the report pipe but
#   linger before they exit; a launcher that does not block then (its
#   poll found the closed pipe readable at once) keeps them from exiting.
# Needs root or CAP_SYS_NICE (else SKIP).
. "$top_srcdir/tests/am-lib.sh"

command -v chrt >/dev/null && command -v taskset >/dev/null ||
    { echo "SKIP: chrt or taskset missing"; exit 77; }
chrt -f 1 true 2>/dev/null ||
    { echo "SKIP: cannot run under SCHED_FIFO (needs root or CAP_SYS_NICE)"; exit 77; }
# The first processor this test may run on.
cpu=$(sed -n 's/^Cpus_allowed_list:[[:space:]]*\([0-9]*\).*/\1/p' /proc/self/status)
[ -n "$cpu" ] || { echo "SKIP: no processor list in /proc/self/status"; exit 77; }

# The rings are what is tested, whatever the suite's AM_SHM; the job's
# socket directory goes into $work, so that a killed job leaves nothing.
AM_SHM=1
TMPDIR=$work
export AM_SHM TMPDIR

# A run takes a fraction of a second; the bound is for the hang.
for i in 1 2 3; do
    rm -rf "$work/st"
    AM_SHM_RING=4k AM_SHM_BIG=0 job 30 taskset -c "$cpu" "$AMRUN" -n 4 --sched fifo \
        --stats "$work/st" -- "$MP" storm 300 20000
    [ "$rc" -ne 124 ] && [ "$rc" -ne 137 ] ||
        fail "4 PEs on processor $cpu under SCHED_FIFO hung (run $i, stopped after $elapsed s)"
    expect_ok "storm, 4 PEs on one processor under SCHED_FIFO"
    expect_line "^storm: 4 PEs, 4800 messages delivered exactly once.* 0 failed checks" "storm fifo"
    [ "$(shm_on_recv)" -eq 12 ] || fail "4 PEs under SCHED_FIFO: $(shm_on_recv) of 12 pairs use a ring"
    [ "$(stat_sum queued_sends)" -gt 0 ] || fail "the 4 KiB rings never made a frame wait"
    echo "fifo: run $i, 4 PEs on processor $cpu under SCHED_FIFO: $elapsed s"
done

# PEs that linger 50 ms after am_finalize, the launcher on their processor
# at the same priority (am-run --sched sets its own policy too).
for i in 1 2; do
    AM_MP_LINGER_MS=50 job 30 taskset -c "$cpu" "$AMRUN" -n 4 --sched fifo -- "$MP" coll
    [ "$rc" -ne 124 ] && [ "$rc" -ne 137 ] ||
        fail "4 PEs lingering after am_finalize under SCHED_FIFO: the job hung (run $i, stopped after $elapsed s)"
    expect_ok "coll, PEs lingering after am_finalize under SCHED_FIFO"
    echo "fifo: run $i, 4 PEs lingering after am_finalize on processor $cpu: $elapsed s"
done

# Bound PEs (one processor each, shared with the PE's ZeroMQ I/O thread).
if [ "$(nproc)" -ge 2 ]; then
    rm -rf "$work/st"
    AM_SHM_RING=4k job 30 "$AMRUN" -n 2 --sched fifo --cpu-bind core \
        --stats "$work/st" -- "$MP" storm 400 20000
    [ "$rc" -ne 124 ] && [ "$rc" -ne 137 ] || fail "2 bound PEs under SCHED_FIFO hung"
    expect_ok "storm, 2 bound PEs under SCHED_FIFO"
    expect_line "^storm: 2 PEs, 1600 messages delivered exactly once.* 0 failed checks" "storm bound"
    [ "$(shm_on_recv)" -eq 2 ] || fail "2 bound PEs under SCHED_FIFO: $(shm_on_recv) of 2 pairs use a ring"
fi
echo "fifo: ok"
