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
    expect_killed "$np" "$victim" kill
    echo "kill: $np PEs ($*): PE $victim killed, the others exited with an error after $elapsed s"
}

kill_case 4 2
kill_case 4 0 -t tcp
kill_case 16 5
echo "kill: ok"
