#!/bin/sh
# The launchers: am-run and 'pdr run' options and exit statuses, Ctrl-C,
# --timeout, jobs started by foreign launchers (Open MPI, MPICH/PMI and
# Slurm environment variables with a file rendezvous), and a hostfile job
# started through ssh -- a fake ssh on PATH that runs the command locally.
. "$top_srcdir/tests/am-lib.sh"

# --- usage
"$AMRUN" --help >"$work/out" 2>&1 || fail "am-run --help exited $?"
expect_line "^Usage: am-run -n P" "am-run --help"
"$AMRUN" >"$work/out" 2>&1
[ $? -eq 2 ] || fail "am-run without arguments should exit 2"
expect_line "-n P is required" "am-run"
for bad in "-n 0 true" "-n x true" "-n 2 --latency fast true" \
    "-n 2 --bandwidth 9 true" "-n 2 -t udp true" "-n 2" "--bogus" \
    "-n 2 --sched idle true" "-n 2 --cpu-bind all true"; do
    # shellcheck disable=SC2086
    "$AMRUN" $bad >"$work/out" 2>&1
    [ $? -eq 2 ] || fail "am-run $bad should be a usage error (2)"
done
"$PDR" run --help >"$work/out" 2>&1 || fail "pdr run --help exited $?"
expect_line "^Usage: pdr run -n P" "pdr run --help"
"$PDR" --help >"$work/out" 2>&1
expect_line "^  run " "pdr --help"

# --- exit statuses: the first failing PE's status, 128+N for signal N
job 30 "$AMRUN" -n 3 -- sh -c 'test "$AM_RANK" = 1 && exit 3; exit 0'
[ "$rc" -eq 3 ] || fail "a PE exiting 3 should make am-run exit 3, not $rc"
expect_line "PE 1 (pid [0-9]*) exited with status 3" "exit status"
job 30 "$AMRUN" -n 2 -- sh -c 'test "$AM_RANK" = 0 && kill -9 $$; exit 0'
[ "$rc" -eq 137 ] || fail "a PE killed by signal 9 should make am-run exit 137, not $rc"
job 30 "$AMRUN" -n 2 -- ./no-such-program-here
[ "$rc" -eq 127 ] || fail "a missing program should give 127, not $rc"
expect_line "cannot run ./no-such-program-here" "missing program"
job 30 "$AMRUN" -n 4 -- sh -c 'test "$AM_SIZE" = 4 && test "$AM_RANK" -lt 4'
expect_ok "rank and size in the environment"

# --- pdr run does what am-run does
job 60 "$PDR" run -n 2 -- "$MP" coll
expect_ok "pdr run -n 2 am_mp coll"
expect_line "^coll: 2 PEs" "pdr run"

# --- --timeout, and Ctrl-C (SIGINT to the launcher) stop the whole job
job 30 "$AMRUN" -n 3 --timeout 1 -- "$MP" sleep 20
[ "$rc" -eq 124 ] || fail "--timeout 1 should exit 124, not $rc"
[ "$(echo "$elapsed < 10" | bc)" -eq 1 ] || fail "--timeout 1 took $elapsed s"
"$AMRUN" -n 3 -- "$MP" sleep 20 "$tag" >"$work/out" 2>&1 &
launcher=$!
sleep 0.5
kill -INT "$launcher"
start=$(date +%s)
wait "$launcher"
rc=$?
[ "$rc" -eq 130 ] || fail "Ctrl-C should make am-run exit 130, not $rc"
[ $(($(date +%s) - start)) -lt 10 ] || fail "Ctrl-C took too long"
no_leftovers

# --- --sched: the launcher and every PE run under the policy asked for;
# AM_SCHED set by hand reaches am_init, which refuses a bad one.
job 30 "$AMRUN" -n 2 --sched batch -- sh -c 'chrt -p $$ | grep -q SCHED_BATCH'
expect_ok "--sched batch: the PEs run as SCHED_BATCH"
job 30 env AM_SCHED=idle "$AMRUN" -n 2 -- "$MP" coll
[ "$rc" -ne 0 ] || fail "AM_SCHED=idle should make am_init fail"
expect_line "bad AM_SCHED 'idle' (expected other, batch, fifo or rr)" "AM_SCHED=idle"
job 60 env AM_SCHED=batch "$AMRUN" -n 2 -- "$MP" coll
expect_ok "AM_SCHED=batch am_mp coll"
nobody="setpriv --reuid 65534 --regid 65534 --clear-groups"
if [ "$(id -u)" -eq 0 ] && command -v setpriv >/dev/null 2>&1 &&
    $nobody "$AMRUN" --help >/dev/null 2>&1; then
    job 30 "$AMRUN" -n 2 --sched fifo -- sh -c 'chrt -p $$ | grep -q SCHED_FIFO'
    expect_ok "--sched fifo (as root): the PEs run as SCHED_FIFO"
    # Without the privilege: refused before any PE starts, with the reason.
    job 30 $nobody "$AMRUN" -n 2 --sched fifo -- true
    [ "$rc" -eq 2 ] || fail "--sched fifo without privilege should exit 2, not $rc"
    expect_line "fifo and rr need root or CAP_SYS_NICE" "--sched fifo without privilege"
else
    echo "--sched fifo not tried: needs root, setpriv, and an am-run user nobody can run"
fi

# --- --cpu-bind: by default (none) the PEs are left where the kernel
# puts them; where a host has as many PEs as processors, auto binds each
# PE, all its threads, to a processor of its own, and with more or fewer
# leaves them; core binds round robin whatever their number; AM_CPU_BIND
# set by hand is checked by am_init.
ncpu=$(taskset -pc $$ 2>/dev/null | sed 's/.*: //' | tr ',' '\n' |
    awk -F- '{n += (NF == 2 ? $2 - $1 + 1 : 1)} END {print n + 0}')
if [ "${ncpu:-0}" -ge 2 ] && [ "$ncpu" -le 16 ]; then
    job 30 "$AMRUN" -n "$ncpu" -- "$MP" affinity
    expect_ok "no --cpu-bind, $ncpu PEs"
    grep -q '^PE 0 cpus [0-9]*[-,]' "$work/out" || fail "without --cpu-bind PE 0 was bound"
    job 30 "$AMRUN" -n "$ncpu" --cpu-bind auto -- "$MP" affinity
    expect_ok "--cpu-bind auto, $ncpu PEs"
    a=$(sed -n 's/^PE 0 cpus \([^ ]*\) threads.*/\1/p' "$work/out")
    b=$(sed -n 's/^PE 1 cpus \([^ ]*\) threads.*/\1/p' "$work/out")
    case "$a$b" in *[-,]*|*mixed*|"") fail "--cpu-bind auto: PEs on '$a' and '$b', not one processor each" ;; esac
    [ "$a" != "$b" ] || fail "--cpu-bind auto: both PEs on processor $a"
    job 30 "$AMRUN" -n $((ncpu - 1)) --cpu-bind auto -- "$MP" affinity
    expect_ok "--cpu-bind auto, fewer PEs than processors"
    grep -q '^PE 0 cpus [0-9]*[-,]' "$work/out" || fail "--cpu-bind auto with fewer PEs than processors bound PE 0"
    job 30 "$AMRUN" -n $((ncpu + 1)) --cpu-bind auto -- "$MP" affinity
    expect_ok "--cpu-bind auto, more PEs than processors"
    grep '^PE ' "$work/out" | grep -qv 'cpus [0-9]*[-,]' &&
        fail "--cpu-bind auto with more PEs than processors bound a PE"
    job 30 "$AMRUN" -n $((ncpu + 1)) --cpu-bind core -- "$MP" affinity
    expect_ok "--cpu-bind core, more PEs than processors"
    [ "$(grep -c '^PE [0-9]* cpus [0-9]* threads' "$work/out")" -eq $((ncpu + 1)) ] ||
        fail "--cpu-bind core: not every PE bound to one processor"
    job 60 "$PDR" run -n "$ncpu" --cpu-bind core -- "$MP" affinity
    expect_ok "pdr run: --cpu-bind core"
    grep '^PE ' "$work/out" | grep -q 'cpus [0-9]* threads' || fail "pdr run --cpu-bind core: no PE bound"
else
    echo "--cpu-bind not tried: $ncpu processors (the test wants 2 to 16)"
fi
job 30 env AM_CPU_BIND=all AM_RANK=0 AM_SIZE=1 "$MP" idle
[ "$rc" -ne 0 ] || fail "AM_CPU_BIND=all should make am_init fail"
expect_line "bad AM_CPU_BIND 'all' (expected auto, core or none)" "AM_CPU_BIND=all"

# --- foreign launchers: rank and size from their variables, rank 0's
# endpoint through a rendezvous file, tcp on loopback.
foreign() {
    rankvar=$1
    sizevar=$2
    rm -f "$work/rdv"
    pids=
    for r in 0 1 2; do
        env "$rankvar=$r" "$sizevar=3" AM_RENDEZVOUS="file:$work/rdv" AM_JOB=77 \
            AM_BOOT_TIMEOUT=30 timeout 40 "$MP" coll "$tag" >"$work/out.$r" 2>&1 &
        pids="$pids $!"
    done
    for p in $pids; do
        wait "$p" || { cat "$work"/out.*; fail "$rankvar/$sizevar job failed"; }
    done
    grep -q "^coll: 3 PEs" "$work/out.0" || fail "$rankvar/$sizevar: no result"
    no_leftovers
}
foreign OMPI_COMM_WORLD_RANK OMPI_COMM_WORLD_SIZE
foreign PMI_RANK PMI_SIZE
foreign SLURM_PROCID SLURM_NTASKS

# --- two PEs that disagree on the job size: the hello negotiation refuses
# the pair with a message naming both sizes, and neither PE hangs.
rm -f "$work/rdv"
env OMPI_COMM_WORLD_RANK=0 OMPI_COMM_WORLD_SIZE=2 AM_RENDEZVOUS="file:$work/rdv" \
    AM_JOB=78 AM_BOOT_TIMEOUT=10 timeout 20 "$MP" coll "$tag" >"$work/mis.0" 2>&1 &
p0=$!
env OMPI_COMM_WORLD_RANK=1 OMPI_COMM_WORLD_SIZE=3 AM_RENDEZVOUS="file:$work/rdv" \
    AM_JOB=78 AM_BOOT_TIMEOUT=10 timeout 20 "$MP" coll "$tag" >"$work/mis.1" 2>&1 &
p1=$!
wait "$p0" && fail "rank 0 of a mismatched job should fail"
wait "$p1"
grep -q "rank 1 says the job has 3 PEs, this PE says 2" "$work/mis.0" ||
    { cat "$work"/mis.*; fail "job-size mismatch not named by rank 0"; }
no_leftovers

# --- hostfile launch through a fake ssh on PATH
mkdir "$work/bin"
cat >"$work/bin/ssh" <<FAKE
#!/bin/sh
# Fake ssh: logs the host, runs the command here, as sshd would there.
echo "\$1" >>"$work/ssh.log"
shift
exec sh -c "\$*"
FAKE
chmod +x "$work/bin/ssh"
printf '# two hosts\n127.0.0.1 slots=2\nlocalhost slots=2\n' >"$work/hosts"
PATH="$work/bin:$PATH" job 60 "$AMRUN" -n 4 --hostfile "$work/hosts" -- "$MP" storm 50 500
expect_ok "hostfile job"
expect_line "^storm: 4 PEs, 800 messages delivered exactly once" "hostfile job"
[ "$(wc -l <"$work/ssh.log")" -eq 4 ] || fail "ssh was not used for every rank"
[ "$(grep -c '^localhost$' "$work/ssh.log")" -eq 2 ] || fail "slots not honoured"
PATH="$work/bin:$PATH" job 30 "$AMRUN" -n 5 --hostfile "$work/hosts" -- true
[ "$rc" -eq 1 ] || fail "too few slots should fail (1), not $rc"
expect_line "lists 4 slots, -n 5 needs 5" "hostfile slots"
echo "launch: ok"
