# tests/am-lib.sh -- helpers for libam's multi-process tests (sourced).
#
# Every job runs under timeout(1) with a hard limit and carries a unique
# tag=... argument, so that the test can check afterwards that no PE process
# is left. Temporary files live in $work (mktemp -d), removed on exit.
# Exit codes: 0 pass, 1 fail, 77 skip, 99 harness error.
set -u

AMRUN=${top_builddir:?}/am-run
MP=$top_builddir/tests/am_mp
[ -x "$AMRUN" ] && [ -x "$MP" ] || { echo "am-run or am_mp not built"; exit 99; }
test_name=$(basename "$0" .sh)
tag="tag=amtest-$$-$test_name"
work=$(mktemp -d "${TMPDIR:-/tmp}/$test_name.XXXXXX") || exit 99
trap 'rm -rf "$work"' EXIT

fail() {
    echo "FAIL: $*"
    [ -f "$work/out" ] && sed 's/^/  | /' "$work/out"
    exit 1
}

# job LIMIT AM-RUN-ARGS -- MODE ARGS: runs am_mp under am-run within LIMIT
# seconds; output in $work/out, exit status in $rc, seconds in $elapsed.
job() {
    limit=$1
    shift
    start=$(date +%s.%N)
    timeout --kill-after=5 "$limit" "$@" "$tag" >"$work/out" 2>&1
    rc=$?
    elapsed=$(echo "$(date +%s.%N) - $start" | bc)
    no_leftovers
}

# Waits up to 5 s for every process carrying our tag to be gone.
no_leftovers() {
    for _ in 1 2 3 4 5 6 7 8 9 10; do
        left=$(ps -eo pid=,args= | grep -F -e "$tag" | grep -v -e grep -e timeout)
        [ -z "$left" ] && return 0
        sleep 0.5
    done
    fail "processes left behind: $left"
}

expect_ok() {
    [ "$rc" -eq 0 ] || fail "$* exited $rc"
}

expect_line() {
    grep -q -e "$1" "$work/out" || fail "no line matching '$1' in the output of $2"
}

# Sums a runtime counter over the statistics files in $work/st.
stat_sum() {
    sed -n "s/.*\"$1\": \([0-9]*\).*/\1/p" "$work"/st/stats-*.json | awk '{s += $1} END {print s + 0}'
}

# The SHM_ON frames received (one per ordered pair that uses a ring).
shm_on_recv() {
    grep -o '"shm_on": {"sent": [0-9]*, "sent_bytes": [0-9]*, "recv": [0-9]*' "$work"/st/stats-*.json |
        sed 's/.*"recv": //' | awk '{s += $1} END {print s + 0}'
}

# expect_killed NP VICTIM WHAT: the job just run (job) lost PE VICTIM to
# SIGKILL and the others noticed: it exited non-zero before its timeout
# and within 15 s, am-run named the victim, a survivor blamed it, and the
# NP - 1 others exited with status 1.
expect_killed() {
    [ "$rc" -ne 0 ] || fail "$3: job with a killed PE exited 0"
    [ "$rc" -ne 124 ] || fail "$3: job with a killed PE hung until the timeout"
    [ "$(echo "$elapsed < 15" | bc)" -eq 1 ] || fail "$3: the PEs took $elapsed s to notice"
    expect_line "PE $2 (pid [0-9]*) was killed by signal 9" "$3"
    expect_line "^am: PE [0-9]*: PE $2 went away" "$3"
    others=$(grep -c "^am-run: PE [0-9]* (pid [0-9]*) exited with status 1$" "$work/out")
    [ "$others" -eq $(($1 - 1)) ] || fail "$3: $others of $(($1 - 1)) surviving PEs exited with status 1"
}
