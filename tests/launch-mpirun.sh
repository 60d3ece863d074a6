#!/bin/sh
# pdr mesh --parallel under Open MPI's real mpirun: 3 ranks on this host
# (libam takes rank and size from OMPI_COMM_WORLD_RANK/SIZE), rank 0's
# endpoint through a rendezvous file, tcp on 127.0.0.1. Open MPI itself is
# kept on the loopback interface too. The merged mesh must pass pdr check.
# Skipped where mpirun is not Open MPI's (Debian package openmpi-bin).
. "$top_srcdir/tests/launch-lib.sh"

command -v mpirun >/dev/null 2>&1 || skip "mpirun not found (Debian package openmpi-bin)"
ver=$(timeout 10 mpirun --version 2>&1 | head -n 1)
case $ver in
*"Open MPI"*) ;;
*) skip "mpirun is not Open MPI's: '$ver'" ;;
esac
echo "$ver"

# As root Open MPI wants --allow-run-as-root; --oversubscribe lets 3 ranks
# run on fewer cores. The MCA settings keep mpirun's own out-of-band
# channel (and its byte transfer layer, were the PEs to use it) on the
# loopback interface, and its process launcher local ('isolated': no ssh).
root=
[ "$(id -u)" -eq 0 ] && root=--allow-run-as-root
start=$(date +%s.%N)
# shellcheck disable=SC2086
timeout --kill-after=5 90 mpirun $root --oversubscribe -n 3 \
    --mca oob_tcp_if_include lo --mca btl self,tcp --mca btl_tcp_if_include lo \
    --mca plm isolated \
    env AM_RENDEZVOUS="file:$work/rdv" AM_BOOT_TIMEOUT=30 \
    "$PDR" mesh --parallel $MESH_OPTS -o "$work/mpi" "$work/cic.poly" \
    >"$work/mpi.out" 2>&1
rc=$?
echo "mpirun -n 3: exit $rc after $(elapsed_since "$start") s"
[ "$rc" -eq 0 ] || { sed 's/^/  | /' "$work/mpi.out"; fail "mpirun -n 3 pdr mesh --parallel exited $rc"; }
grep -q '^table 1 (s):' "$work/mpi.out" || fail "no Table 1 rows in the output"
check_mesh mpi "$work/mpi.out" 3
no_leftovers
echo "launch-mpirun: ok"
