#!/bin/sh
# All-to-all ping storms: every PE sends random-length, random-content
# messages to every PE (itself included); each must arrive exactly once, in
# order, with the right bytes -- on ipc with 2, 4 and 16 PEs, on tcp, and
# with a tiny ZeroMQ high-water mark that forces the local send queue; with
# send coalescing (bundles travel; AM_COALESCE=0 still delivers) and
# am_flush (a flushed message leaves while its sender computes); through
# the same-host rings (the default on ipc) and through ZeroMQ (AM_SHM=0),
# and through rings far smaller than the messages (written in pieces,
# reassembled, wrapping round).
. "$top_srcdir/tests/am-lib.sh"

for np in 2 4 16; do
  for shm in 1 0; do
    n=400
    [ "$np" -eq 16 ] && n=40
    rm -rf "$work/st"
    AM_SHM=$shm job 120 "$AMRUN" -n "$np" --stats "$work/st" -- "$MP" storm "$n" 4000
    expect_ok "storm on $np PEs (ipc, AM_SHM=$shm)"
    expect_line "^storm: $np PEs, $((np * np * n)) messages delivered exactly once.* 0 failed checks" "storm $np"
    if [ "$shm" -eq 1 ]; then
        [ "$(shm_on_recv)" -eq $((np * (np - 1))) ] ||
            fail "storm on $np PEs: $(shm_on_recv) of $((np * (np - 1))) pairs use a ring"
        continue
    fi
    [ "$(shm_on_recv)" -eq 0 ] || fail "AM_SHM=0 still used rings"
    # Send coalescing: every bundle sent was taken apart, and with 2 and 4
    # PEs frames did travel in bundles (a round of storm_work sends 8
    # frames round-robin, so to 16 PEs each goes alone).
    sent=$(stat_sum bundles_sent)
    [ "$np" -gt 4 ] || [ "$sent" -gt 0 ] || fail "storm on $np PEs: no frames were bundled"
    [ "$sent" -eq "$(stat_sum bundles_recv)" ] ||
        fail "storm on $np PEs: $sent bundles sent, $(stat_sum bundles_recv) received"
  done
done

# Rings of 4 KiB with messages up to 20,000 bytes, none sent by ZeroMQ
# (AM_SHM_BIG=0): most frames are larger than the ring or than its free
# room, so they are written in pieces as the receiver frees room (waiting
# in the send queue meanwhile) and reassembled, and the ring wraps round
# thousands of times; every message must still arrive once, in order,
# intact.
rm -rf "$work/st"
AM_SHM=1 AM_SHM_RING=4k AM_SHM_BIG=0 job 120 "$AMRUN" -n 3 --stats "$work/st" -- "$MP" storm 300 20000
expect_ok "storm through 4 KiB rings"
expect_line "^storm: 3 PEs, 2700 messages delivered exactly once.* 0 failed checks" "storm small rings"
[ "$(shm_on_recv)" -eq 6 ] || fail "storm through 4 KiB rings: $(shm_on_recv) of 6 pairs use a ring"
[ "$(stat_sum queued_sends)" -gt 0 ] || fail "4 KiB rings never made a frame wait"

# The same messages with AM_SHM_BIG=8k: the larger ones go by ZeroMQ,
# announced in the ring (SHM_VIA), between frames that take the ring.
rm -rf "$work/st"
AM_SHM=1 AM_SHM_RING=64k AM_SHM_BIG=8k job 120 "$AMRUN" -n 3 --stats "$work/st" -- "$MP" storm 300 20000
expect_ok "storm with large frames by ZeroMQ"
expect_line "^storm: 3 PEs, 2700 messages delivered exactly once.* 0 failed checks" "storm shm_via"
via=$(grep -o '"shm_via": {"sent": [0-9]*' "$work"/st/stats-*.json | sed 's/.*: //' | awk '{s += $1} END {print s + 0}')
[ "$via" -gt 0 ] || fail "AM_SHM_BIG=8k sent no frame by ZeroMQ"

# Without coalescing every frame travels alone, as before.
rm -rf "$work/st"
AM_COALESCE=0 job 120 "$AMRUN" -n 4 --stats "$work/st" -- "$MP" storm 400 4000
expect_ok "storm with AM_COALESCE=0"
expect_line "^storm: 4 PEs, 6400 messages delivered exactly once.* 0 failed checks" "storm uncoalesced"
[ "$(stat_sum bundles_sent)" -eq 0 ] || fail "AM_COALESCE=0 still bundled"

# am_flush hands a waiting message over at once: it arrives while its
# sender computes without polling.
job 60 "$AMRUN" -n 2 -- "$MP" flush
expect_ok "am_flush"
expect_line "^flush: the message arrived after" "am_flush"

job 120 "$AMRUN" -n 4 -t tcp -- "$MP" storm 300 4000
expect_ok "storm on 4 PEs (tcp)"
expect_line "^storm: 4 PEs, 4800 messages delivered exactly once" "storm tcp"

rm -rf "$work/st"
AM_SHM=0 AM_HWM=4 job 120 "$AMRUN" -n 4 --stats "$work/st" -- "$MP" storm 500 4000
expect_ok "storm with AM_HWM=4"
expect_line "^storm: 4 PEs, 8000 messages delivered exactly once" "storm hwm"
queued=$(sed -n 's/.*"queued_sends": \([0-9]*\).*/\1/p' "$work"/st/stats-*.json | awk '{s += $1} END {print s + 0}')
[ "$queued" -gt 0 ] || fail "with AM_HWM=4 no send went through the local queue"
echo "storm: ok ($queued sends waited in the local queue with AM_HWM=4)"
