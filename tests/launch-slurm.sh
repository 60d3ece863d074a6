#!/bin/sh
# pdr mesh --parallel under Slurm. Where srun is installed and a Slurm
# controller answers (sinfo), a real 'srun -N 1 -n 3' runs the job on one
# node. Otherwise the test starts the 3 PEs itself with the variables srun
# sets for each task (SLURM_PROCID, SLURM_NTASKS, plus the job's ids), which
# is all libam reads from Slurm. Either way rank 0's endpoint goes through
# a rendezvous file, on tcp, and the merged mesh must pass pdr check.
. "$top_srcdir/tests/launch-lib.sh"

start=$(date +%s.%N)
if command -v srun >/dev/null 2>&1 && timeout 10 sinfo -h >/dev/null 2>&1; then
    how="srun -N 1 -n 3"
    # shellcheck disable=SC2086
    timeout --kill-after=5 120 srun -N 1 -n 3 --time=2 \
        env AM_RENDEZVOUS="file:$work/rdv" AM_BOOT_TIMEOUT=60 \
        "$PDR" mesh --parallel $MESH_OPTS -o "$work/slurm" "$work/cic.poly" \
        >"$work/slurm.out" 2>&1
    rc=$?
else
    if command -v srun >/dev/null 2>&1; then
        echo "srun found but no Slurm controller answers: Slurm's environment by hand"
    else
        echo "srun not found: Slurm's environment by hand"
    fi
    how="3 tasks with SLURM_PROCID/SLURM_NTASKS"
    pids=
    for r in 0 1 2; do
        # shellcheck disable=SC2086
        env SLURM_PROCID=$r SLURM_NTASKS=3 SLURM_NPROCS=3 SLURM_LOCALID=$r \
            SLURM_NODEID=0 SLURM_JOB_ID=$$ SLURM_STEP_ID=0 \
            AM_RENDEZVOUS="file:$work/rdv" AM_BOOT_TIMEOUT=30 \
            timeout --kill-after=5 60 \
            "$PDR" mesh --parallel $MESH_OPTS -o "$work/slurm" "$work/cic.poly" \
            >"$work/slurm.out.$r" 2>&1 &
        pids="$pids $!"
    done
    at_exit "kill $pids 2>/dev/null"
    rc=0
    for p in $pids; do
        wait "$p" || rc=$?
    done
    cp "$work/slurm.out.0" "$work/slurm.out"
    for r in 1 2; do
        [ -s "$work/slurm.out.$r" ] && sed "s/^/PE $r: /" "$work/slurm.out.$r"
    done
fi
echo "$how: exit $rc after $(elapsed_since "$start") s"
[ "$rc" -eq 0 ] || { sed 's/^/  | /' "$work/slurm.out"; fail "$how: pdr mesh --parallel exited $rc"; }
check_mesh slurm "$work/slurm.out" 3
no_leftovers
echo "launch-slurm: ok"
