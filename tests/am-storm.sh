#!/bin/sh
# All-to-all ping storms: every PE sends random-length, random-content
# messages to every PE (itself included); each must arrive exactly once, in
# order, with the right bytes -- on ipc with 2, 4 and 16 PEs, on tcp, and
# with a tiny ZeroMQ high-water mark that forces the local send queue; with
# send coalescing (bundles travel; AM_COALESCE=0 still delivers) and
# am_flush (a flushed message leaves while its sender computes).
. "$top_srcdir/tests/am-lib.sh"

# Sums a runtime counter over the statistics files in $work/st.
stat_sum() {
    sed -n "s/.*\"$1\": \([0-9]*\).*/\1/p" "$work"/st/stats-*.json | awk '{s += $1} END {print s + 0}'
}

for np in 2 4 16; do
    n=400
    [ "$np" -eq 16 ] && n=40
    rm -rf "$work/st"
    job 120 "$AMRUN" -n "$np" --stats "$work/st" -- "$MP" storm "$n" 4000
    expect_ok "storm on $np PEs (ipc)"
    expect_line "^storm: $np PEs, $((np * np * n)) messages delivered exactly once.* 0 failed checks" "storm $np"
    # Send coalescing: every bundle sent was taken apart, and with 2 and 4
    # PEs frames did travel in bundles (a round of storm_work sends 8
    # frames round-robin, so to 16 PEs each goes alone).
    sent=$(stat_sum bundles_sent)
    [ "$np" -gt 4 ] || [ "$sent" -gt 0 ] || fail "storm on $np PEs: no frames were bundled"
    [ "$sent" -eq "$(stat_sum bundles_recv)" ] ||
        fail "storm on $np PEs: $sent bundles sent, $(stat_sum bundles_recv) received"
done

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
AM_HWM=4 job 120 "$AMRUN" -n 4 --stats "$work/st" -- "$MP" storm 500 4000
expect_ok "storm with AM_HWM=4"
expect_line "^storm: 4 PEs, 8000 messages delivered exactly once" "storm hwm"
queued=$(sed -n 's/.*"queued_sends": \([0-9]*\).*/\1/p' "$work"/st/stats-*.json | awk '{s += $1} END {print s + 0}')
[ "$queued" -gt 0 ] || fail "with AM_HWM=4 no send went through the local queue"
echo "storm: ok ($queued sends waited in the local queue with AM_HWM=4)"
