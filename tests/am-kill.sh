#!/bin/sh
# A PE killed with SIGKILL mid-run must make the other PEs exit with a
# clear error naming it, on their own (the launcher's grace period is set
# longer than the bound checked here), instead of hanging.
. "$top_srcdir/tests/am-lib.sh"

kill_case() {
    np=$1
    victim=$2
    shift 2
    job 60 "$AMRUN" -n "$np" --grace 40 "$@" -- "$MP" kill "$victim"
    [ "$rc" -ne 0 ] || fail "job with a killed PE exited 0"
    [ "$rc" -ne 124 ] || fail "job with a killed PE hung until the timeout"
    [ "$(echo "$elapsed < 15" | bc)" -eq 1 ] || fail "the PEs took $elapsed s to notice"
    expect_line "PE $victim (pid [0-9]*) was killed by signal 9" "kill"
    expect_line "^am: PE [0-9]*: PE $victim went away" "kill"
    others=$(grep -c "^am-run: PE [0-9]* (pid [0-9]*) exited with status 1$" "$work/out")
    [ "$others" -eq $((np - 1)) ] || fail "$others of $((np - 1)) surviving PEs exited with status 1"
    echo "kill: $np PEs ($*): PE $victim killed, the others exited with an error after $elapsed s"
}

kill_case 4 2
kill_case 4 0 -t tcp
kill_case 16 5
echo "kill: ok"
