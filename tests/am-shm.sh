#!/bin/sh
# The same-host rings (runtime/am_shm.c): a PE blocked in am_idle is woken
# by a frame written to its ring; a job where some pairs use rings and
# others ZeroMQ; and a peer killed while the rings to it are full. (Order,
# pieces, wrap-round and large frames by ZeroMQ: am-storm.sh.)
. "$top_srcdir/tests/am-lib.sh"
# These test the rings: they run with them even when the suite runs with
# AM_SHM=0.
AM_SHM=1
export AM_SHM

# Wake-up: 20 messages to a PE asleep in am_idle(30), through the ring
# and, for comparison, through ZeroMQ.
for shm in 1 0; do
    rm -rf "$work/st"
    AM_SHM=$shm job 60 "$AMRUN" -n 2 --stats "$work/st" -- "$MP" wake 20
    expect_ok "wake-up (AM_SHM=$shm)"
    expect_line "^wake: 20 messages to a sleeping PE" "wake"
    [ "$shm" -eq 0 ] || [ "$(shm_on_recv)" -eq 2 ] || fail "wake-up: the rings were not used"
    grep "^wake:" "$work/out"
done
AM_SHM=1

# Mixed: PE 1 has AM_SHM=0, so it makes no rings and uses none; the pairs
# without it use rings. Every message arrives once, in order.
rm -rf "$work/st"
job 120 "$AMRUN" -n 4 --stats "$work/st" -- sh -c \
    'if [ "$AM_RANK" = 1 ]; then AM_SHM=0; export AM_SHM; fi; exec "$@"' sh \
    "$MP" storm 300 4000
expect_ok "storm with PE 1 on ZeroMQ only"
expect_line "^storm: 4 PEs, 4800 messages delivered exactly once.* 0 failed checks" "storm mixed"
[ "$(shm_on_recv)" -eq 6 ] || fail "mixed job: $(shm_on_recv) of 6 pairs without PE 1 use a ring"

# Ring sizes (runtime/am_shm.c, ring_cap), from each PE's stats: 1 MiB on
# 2 PEs with a processor each, also when --cpu-bind core has narrowed
# each PE to one (the host's processors are counted before binding); 16
# KiB with more PEs than processors; AM_SHM_RING overrides both.
ring_bytes() {
    sed -n 's/^  "shm_ring_bytes": \([0-9]*\),$/\1/p' "$work"/st/stats-*.json | sort -u | tr '\n' ' ' |
        sed 's/ $//'
}
ring_size() { # EXPECTED WHAT COMMAND...
    want=$1 what=$2
    shift 2
    rm -rf "$work/st"
    job 60 "$@" --stats "$work/st" -- "$MP" wake 5
    expect_ok "ring size: $what"
    got=$(ring_bytes)
    [ "$got" = "$want" ] || fail "ring size: $what: rings of '$got' bytes, expected $want"
    echo "shm: $what: rings of $got bytes"
}
if command -v taskset >/dev/null; then
    cpus=$(sed -n 's/^Cpus_allowed_list:[[:space:]]*//p' /proc/self/status)
    first=$(echo "$cpus" | sed 's/[^0-9].*//')
    second=$(echo "$cpus" | tr ',' '\n' | awk -F- -v f="$first" '
            {lo = $1; hi = (NF == 2 ? $2 : $1); for (c = lo; c <= hi; c++) if (c != f) {print c; exit}}')
    ring_size 16384 "2 PEs on one processor" taskset -c "$first" "$AMRUN" -n 2
    AM_SHM_RING=64k ring_size 65536 "2 PEs on one processor, AM_SHM_RING=64k" \
        taskset -c "$first" "$AMRUN" -n 2
    if [ -n "$second" ]; then
        ring_size 1048576 "2 PEs on two processors" taskset -c "$first,$second" "$AMRUN" -n 2
        ring_size 1048576 "2 PEs bound to one processor each" \
            taskset -c "$first,$second" "$AMRUN" -n 2 --cpu-bind core
        ring_size 16384 "3 PEs on two processors" taskset -c "$first,$second" "$AMRUN" -n 3
    else
        echo "shm: one processor only: the two-processor ring sizes not tested"
    fi
fi

# The victim stops reading, the rings to it (64 KiB) fill, then it dies:
# every sender must exit with an error naming it, on its own and in
# bounded time. On 2 PEs each way round: the victim connected to the
# sender (rank 1 dies; rank 0 learns it by probing), and the sender
# connected to the victim (rank 0 dies); on 3 PEs both kinds at once.
killfull() {
    np=$1
    victim=$2
    AM_SHM_RING=64k job 60 "$AMRUN" -n "$np" --grace 40 -- "$MP" killfull 16384 "$victim"
    expect_killed "$np" "$victim" "killfull (senders on a full ring)"
    for pe in $(seq 0 $((np - 1))); do
        [ "$pe" -eq "$victim" ] && continue
        expect_line "^am_mp: PE $pe: frames wait for room in the ring" "killfull"
    done
    echo "shm: $np PEs, PE $victim killed behind full rings: the senders exited with an error after $elapsed s"
}
killfull 2 1
killfull 2 0
killfull 3 1
echo "shm: ok"
