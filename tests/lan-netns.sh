#!/bin/sh
# A parallel refinement across a small LAN: two "hosts" made as network
# namespaces joined by one veth pair, each end with a link-local address
# (169.254.77.1/30 and .2/30) and nothing else; the namespaces reach
# nothing but each other. 4 PEs, 2 per namespace, run pdr mesh --parallel
# over tcp with CURVE (a key pair per PE, made for the job by
# tests/curve_keypair -n 4, in a key file of mode 0600: AM_CURVE_KEYS):
# rank 0 binds AM_ROOT, every PE binds and advertises its namespace's
# address (AM_BIND). Checked:
#  - the merged mesh rank 0 writes passes pdr check, and the veth carried
#    the job's traffic (its byte counters);
#  - CURVE and ZAP are on: the same job with PE 3 holding a key pair that
#    is not the job's (though it knows every PE's public key) cannot
#    start: rank 0's ZAP handler refuses it, and says so once for its
#    address 169.254.77.2 however often PE 3 retries; every PE exits
#    non-zero within the boot timeout (AM_BOOT_TIMEOUT=5 s), rank 0 names
#    PE 3 as the one whose hello never came, and no mesh is written.
# The namespaces and the veth pair are removed at the end, also when the
# test fails or is killed. Skipped unless root and 'ip netns add' and
# 'ip link add ... type veth' work, and where libzmq has no CURVE.
. "$top_srcdir/tests/launch-lib.sh"

[ "$(id -u)" -eq 0 ] || skip "not root: network namespaces need root"
command -v ip >/dev/null 2>&1 || skip "ip not found (Debian package iproute2)"
keys=$work/keys
(umask 077 && "$top_builddir/tests/curve_keypair" -n 4 >"$keys")
case $? in
0) ;;
77) skip "this libzmq has no CURVE" ;;
*) exit 99 ;;
esac
# The job's keys with PE 3's pair swapped for a foreign one.
other=$("$top_builddir/tests/curve_keypair") || exit 99
bad_keys=$work/bad_keys
# (awk, not sed: Z85 keys may hold '&'.)
(umask 077 && awk -v pub="${other% *}" -v sec="${other#* }" '
    $1 == "public" && $2 == 3 { print "public 3 " pub; next }
    $1 == "secret" && $2 == 3 { print "secret 3 " sec; next }
    { print }' "$keys" >"$bad_keys") || exit 99

# Names unique to this run; interface names stay within 15 characters.
nsa=pdr-lan-$$-a
nsb=pdr-lan-$$-b
va=pdrv$$a
vb=pdrv$$b
ip netns add "$nsa" 2>"$work/netns.err" ||
    skip "cannot make a network namespace: $(head -n 1 "$work/netns.err")"
at_exit "ip netns delete $nsa 2>/dev/null"
ip netns add "$nsb" || fail "ip netns add $nsb"
at_exit "ip netns delete $nsb 2>/dev/null"
# The pair is made in this namespace and moved at once; should the test
# end in between, deleting one end deletes both.
ip link add "$va" type veth peer name "$vb" 2>"$work/veth.err" ||
    skip "cannot make a veth pair: $(head -n 1 "$work/veth.err")"
at_exit "ip link delete $va 2>/dev/null"
ip link set "$va" netns "$nsa" && ip link set "$vb" netns "$nsb" ||
    fail "cannot move the veth ends into the namespaces"
# IPv6 off on the veth ends, so nothing (router solicitations, duplicate
# address probes) is sent besides the job's own traffic.
for x in "$nsa $va 169.254.77.1/30" "$nsb $vb 169.254.77.2/30"; do
    # shellcheck disable=SC2086
    set -- $x
    ip netns exec "$1" sysctl -q -w "net.ipv6.conf.$2.disable_ipv6=1" >/dev/null 2>&1
    ip -n "$1" addr add "$3" dev "$2" && ip -n "$1" link set "$2" up &&
        ip -n "$1" link set lo up || fail "cannot configure $2 in $1"
done

pes=
# pe NAME RANK NAMESPACE ADDRESS KEYS: starts one PE of the 4-PE job in
# NAMESPACE, bound to ADDRESS, with the CURVE key file KEYS; output in
# $work/NAME.out.RANK.
pe() {
    # shellcheck disable=SC2086
    timeout --kill-after=5 60 ip netns exec "$3" env AM_RANK="$2" AM_SIZE=4 \
        AM_JOB=$$ AM_TRANSPORT=tcp AM_ROOT=tcp://169.254.77.1:7000 AM_BIND="$4" \
        AM_CURVE_KEYS="$5" AM_BOOT_TIMEOUT="${boot:-30}" \
        "$PDR" mesh --parallel $MESH_OPTS -o "$work/$1" "$work/cic.poly" \
        >"$work/$1.out.$2" 2>&1 &
    pes="$pes $!"
}
at_exit 'kill $pes 2>/dev/null'
# wait_job NAME: waits for the PEs; $rc is 0 if all exited 0, else the
# status of the last that did not; $codes lists every PE's status.
wait_job() {
    rc=0
    codes=
    for p in $pes; do
        wait "$p"
        c=$?
        codes="$codes $c"
        [ "$c" -eq 0 ] || rc=$c
    done
    pes=
    for r in 1 2 3; do
        [ -s "$work/$1.out.$r" ] && sed "s/^/PE $r: /" "$work/$1.out.$r"
    done
    return 0
}
veth_bytes() { # rx + tx bytes of the veth end in namespace a
    ip netns exec "$nsa" cat "/sys/class/net/$va/statistics/rx_bytes" \
        "/sys/class/net/$va/statistics/tx_bytes" | awk '{ s += $1 } END { print s }'
}

# --- the job, 2 PEs per namespace
bytes0=$(veth_bytes)
start=$(date +%s.%N)
pe lan 0 "$nsa" 169.254.77.1 "$keys"
pe lan 1 "$nsa" 169.254.77.1 "$keys"
pe lan 2 "$nsb" 169.254.77.2 "$keys"
pe lan 3 "$nsb" 169.254.77.2 "$keys"
wait_job lan
echo "4 PEs in 2 namespaces, tcp with CURVE: exit statuses$codes after $(elapsed_since "$start") s"
[ "$rc" -eq 0 ] || { sed 's/^/  | /' "$work/lan.out.0"; fail "the job across the namespaces failed ($codes)"; }
check_mesh lan "$work/lan.out.0" 4
bytes=$(($(veth_bytes) - bytes0))
echo "the veth pair carried $bytes bytes"
# The submeshes of PEs 2 and 3 go out and come back: far more than this.
[ "$bytes" -gt 100000 ] || fail "only $bytes bytes crossed the veth pair"
no_leftovers

# --- CURVE is on: PE 3 holds another key pair and cannot join
boot=5
start=$(date +%s.%N)
pe bad 0 "$nsa" 169.254.77.1 "$keys"
pe bad 1 "$nsa" 169.254.77.1 "$keys"
pe bad 2 "$nsb" 169.254.77.2 "$keys"
pe bad 3 "$nsb" 169.254.77.2 "$bad_keys"
wait_job bad
took=$(elapsed_since "$start")
echo "PE 3 with a key pair not of the job: exit statuses$codes after $took s"
sed 's/^/  | /' "$work/bad.out.0"
for c in $codes; do
    [ "$c" -ne 0 ] || fail "a PE of the job with a wrong key exited 0 ($codes)"
    [ "$c" -ne 124 ] && [ "$c" -ne 137 ] || fail "a PE of the job with a wrong key was killed by timeout ($codes)"
done
[ "$(echo "$took < 30" | bc)" -eq 1 ] || fail "the job with a wrong key took $took s to fail"
grep -q 'timed out after 5 s waiting for hellos: PEs 3$' "$work/bad.out.0" ||
    fail "rank 0 did not name PE 3 as the one it waited for"
n=$(grep -c "refused a connection to this PE from 169.254.77.2: its CURVE key is not one of the job's" "$work/bad.out.0")
[ "$n" -eq 1 ] || fail "rank 0 logged PE 3's refused key $n times, not once"
grep -q "the CURVE handshake with PE 0 at tcp://169.254.77.1:7000 failed: the other side refused the key" "$work/bad.out.3" ||
    { sed 's/^/  3| /' "$work/bad.out.3"; fail "PE 3 did not say that rank 0 refused its key"; }
for f in "$work"/bad.*; do
    case $f in *.out.*) ;; *) fail "the failed job wrote $f" ;; esac
done
no_leftovers
echo "lan-netns: ok"
