#!/bin/sh
# A thread blocked in am_call (the callee answers after 300 ms, from a
# thread) must not block the other threads of its PE: another thread keeps
# completing round trips meanwhile.
. "$top_srcdir/tests/am-lib.sh"

for np in 2 4; do
    job 60 "$AMRUN" -n "$np" -- "$MP" rpc
    expect_ok "rpc on $np PEs"
    [ "$(grep -c '^rpc: PE [0-9]*: [0-9]* round trips by another thread while one waited' "$work/out")" -eq "$np" ] ||
        fail "rpc on $np PEs: not every PE reported"
done
job 60 "$AMRUN" -n 2 -t tcp -- "$MP" rpc
expect_ok "rpc on tcp"
echo "rpc: ok"
