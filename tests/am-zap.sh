#!/bin/sh
# CURVE and ZAP on tcp (runtime/CONTROL.md, "CURVE and ZAP"), on 127.0.0.1
# only. A 2-PE job over tcp, with a key pair per PE made by am-run, waits
# while strangers try to get in, then exchanges messages:
#  - CURVE strangers that know the server's public key (PE 1's, or the
#    rendezvous') but hold a key pair of their own, and strangers in clear
#    (ZeroMQ's NULL mechanism), each several times: none completes a
#    handshake or gets a reply, PE 1 never sees their frames (0 rejected),
#    the job still delivers every message in order; strangers at PE 0 do
#    not make it probe PE 1 (a stranger's disconnect is not a peer's);
#  - PE 1's statistics count the refusals (security: zap_refused 3 from 1
#    address, handshakes_failed >= 5) and its log has exactly one line
#    about 127.0.0.1 and one about the failed clear-text handshakes; am-run
#    logs the strangers at its rendezvous once, and sums them up at the end.
# Then jobs started by hand (a rendezvous file, tcp on 127.0.0.1): with a
# key file AM_CURVE_KEYS of mode 0600 (am-run -n 2 --write-keys), the same
# file of mode 0644 (refused by every PE, saying why), and the older
# AM_CURVE_SERVER_PUBLIC/SECRET (one key pair shared by every PE); and an
# impostor holding PE 2's key pair who speaks as PE 1 to rank 0 of a 3-PE
# job: its handshake succeeds (the key is the job's), its frame is
# rejected (the key is not PE 1's).
. "$top_srcdir/tests/am-lib.sh"

ST=$top_builddir/tests/zap_stranger
[ -x "$ST" ] || { echo "zap_stranger not built"; exit 99; }
"$top_builddir/tests/curve_keypair" >/dev/null 2>&1
case $? in
0) ;;
77) echo "SKIP: this libzmq has no CURVE"; exit 77 ;;
*) exit 99 ;;
esac

mkdir "$work/d" "$work/stats" || exit 99
timeout --kill-after=5 90 "$AMRUN" -n 2 -t tcp --stats "$work/stats" -- \
    "$MP" zap "$work/d" 200 "$tag" >"$work/out" 2>&1 &
jobpid=$!
# On a failure the job is released first, so that nothing is left behind.
release() {
    touch "$work/d/go"
    wait "$jobpid"
}
for _ in $(seq 1 300); do
    [ -s "$work/d/info" ] && break
    kill -0 "$jobpid" 2>/dev/null || break
    sleep 0.1
done
[ -s "$work/d/info" ] || { release; fail "the job did not start"; }
read -r ep key rdv rdvkey jobid ep0 key0 <"$work/d/info"
echo "PE 1 at $ep, key $key; rendezvous $rdv, key $rdvkey; job $jobid"
[ "$key" != - ] && [ "$rdvkey" != - ] || { release; fail "CURVE is off in a tcp job"; }

# stranger WHAT ARGS: one attempt; it must be kept out.
stranger() {
    what=$1
    shift
    "$ST" "$@" >"$work/st" 2>&1
    st=$?
    sed "s/^/  $what: /" "$work/st"
    [ "$st" -eq 0 ] || { release; fail "$what got in: $(cat "$work/st")"; }
}
for i in 1 2 3; do
    stranger "CURVE stranger $i at PE 1" "$ep" curve "$key" frame
done
for i in 1 2; do
    stranger "clear-text stranger $i at PE 1" "$ep" null frame
done
# PE 0 has accepted a connection (PE 1's): a stranger's disconnect must not
# make PE 1 a suspect (no PING probes).
stranger "CURVE stranger at PE 0" "$ep0" curve "$key0" frame
stranger "clear-text stranger at PE 0" "$ep0" null frame
for i in 1 2 3; do
    stranger "CURVE stranger $i at the rendezvous" "$rdv" curve "$rdvkey" "GET $jobid"
done
stranger "clear-text stranger at the rendezvous" "$rdv" null "GET $jobid"
# Rank 0's key is the only one that may publish; a stranger cannot even ask.
stranger "CURVE stranger publishing at the rendezvous" "$rdv" curve "$rdvkey" \
    "PUT $jobid tcp://127.0.0.1:1"

release
rc=$?
no_leftovers
expect_ok "the job with strangers"
expect_line "^zap: PE 0 got its peer's 200 messages in order, rejected 0 frames (curve on)" "PE 0"
expect_line "^zap: PE 1 got its peer's 200 messages in order, rejected 0 frames (curve on)" "PE 1"

# The statistics of PE 1.
json=$work/stats/stats-1.json
[ -s "$json" ] || fail "no $json"
grep '"security"' "$json"
grep -q '"rejected": {"total": 0,' "$json" || fail "PE 1 rejected frames: $(grep rejected "$json")"
grep -q '"curve": true, "keys": 2, "zap_refused": 3, "strangers": 1,' "$json" ||
    fail "PE 1 did not count 3 refusals from 1 address: $(grep security "$json")"
failed=$(sed -n 's/.*"handshakes_failed": \([0-9]*\).*/\1/p' "$json")
[ "${failed:-0}" -ge 5 ] || fail "PE 1 counted $failed failed handshakes, not at least 5"

# One line per stranger address at PE 1, one for the clear-text ones, one
# at the rendezvous.
n=$(grep -c "^am: PE 1: refused a connection to this PE from 127.0.0.1: its CURVE key is not one of the job's" "$work/out")
[ "$n" -eq 1 ] || fail "PE 1 logged the stranger at 127.0.0.1 $n times, not once"
# (Which side notices the mismatch first varies: "does not use CURVE", or
# the stranger hung up first, "ended during the handshake".)
n=$(grep -c "^am: PE 1: a client of tcp://127.0.0.1:[0-9]* failed its handshake: " "$work/out")
[ "$n" -eq 1 ] || fail "PE 1 logged the clear-text strangers $n times, not once"
n=$(grep -c "^am-run: refused a connection to the rendezvous from 127.0.0.1" "$work/out")
[ "$n" -eq 1 ] || fail "am-run logged the rendezvous' stranger $n times, not once"
grep -q "^am-run: the rendezvous refused 4 connections from 1 address (keys not of the job)$" "$work/out" ||
    fail "am-run did not sum up the refusals at its rendezvous"
n=$(grep -c "refused\|failed its handshake" "$work/out")
[ "$n" -eq 6 ] || fail "$n lines about strangers, not 6 (2 at each PE, 2 at the rendezvous)"
grep -q '"ping": {"sent": 0,' "$work/stats/stats-0.json" ||
    fail "strangers' disconnects made PE 0 probe PE 1: $(grep -o '"ping": {[^}]*}' "$work/stats/stats-0.json")"
sed 's/^/  | /' "$work/out"

# --- jobs started by hand
# hand NAME VAR=VALUE...: a 2-PE job (am_mp coll) with these variables;
# outputs in $work/NAME.R, exit statuses in $codes.
hand() {
    name=$1
    shift
    rm -f "$work/rdv"
    pids=
    for r in 0 1; do
        env AM_RANK=$r AM_SIZE=2 AM_JOB=79 AM_RENDEZVOUS="file:$work/rdv" \
            AM_BOOT_TIMEOUT=10 "$@" timeout 30 "$MP" coll "$tag" \
            >"$work/$name.$r" 2>&1 &
        pids="$pids $!"
    done
    codes=
    for p in $pids; do
        wait "$p"
        codes="$codes $?"
    done
    no_leftovers
}
"$AMRUN" -n 2 --write-keys "$work/keys" || fail "am-run --write-keys failed"
[ "$(stat -c %a "$work/keys")" = 600 ] || fail "am-run --write-keys made a file of mode $(stat -c %a "$work/keys")"
"$AMRUN" -n 2 --write-keys "$work/keys" 2>/dev/null && fail "am-run --write-keys overwrote a key file"
hand file AM_CURVE_KEYS="$work/keys"
[ "$codes" = " 0 0" ] || { cat "$work"/file.*; fail "a job with a key file failed ($codes)"; }
grep -q "^coll: 2 PEs" "$work/file.0" || fail "the job with a key file gave no result"
echo "by hand with AM_CURVE_KEYS=FILE (mode 0600): ok"
chmod 644 "$work/keys"
hand open AM_CURVE_KEYS="$work/keys"
[ "$codes" = " 1 1" ] || { cat "$work"/open.*; fail "a key file others can read was used ($codes)"; }
grep -q "only its owner can read (mode 0644; chmod 600 it)" "$work/open.0" ||
    { cat "$work/open.0"; fail "no clear error for a key file of mode 0644"; }
echo "by hand with a key file of mode 0644: refused"
pair=$("$top_builddir/tests/curve_keypair") || exit 99
hand shared AM_CURVE_SERVER_PUBLIC="${pair% *}" AM_CURVE_SERVER_SECRET="${pair#* }"
[ "$codes" = " 0 0" ] || { cat "$work"/shared.*; fail "a job with AM_CURVE_SERVER_PUBLIC/SECRET failed ($codes)"; }
echo "by hand with AM_CURVE_SERVER_PUBLIC/SECRET: ok"

(umask 077 && "$top_builddir/tests/curve_keypair" -n 3 >"$work/keys3") || exit 99
rm -f "$work/rdv"
env AM_RANK=0 AM_SIZE=3 AM_JOB=80 AM_RENDEZVOUS="file:$work/rdv" \
    AM_CURVE_KEYS="$work/keys3" AM_BOOT_TIMEOUT=3 timeout 30 "$MP" coll "$tag" \
    >"$work/imp.0" 2>&1 &
p0=$!
for _ in $(seq 1 100); do
    [ -s "$work/rdv" ] && break
    sleep 0.05
done
key() { awk -v w="$1" -v r="$2" '$1 == w && $2 == r { print $3 }' "$work/keys3"; }
STRANGER_PUBLIC=$(key public 2) STRANGER_SECRET=$(key secret 2) STRANGER_RANK=1 \
    "$ST" "$(cat "$work/rdv")" curve "$(key public 0)" frame >"$work/st" 2>&1
st=$?
wait "$p0"
no_leftovers
sed 's/^/  impostor: /' "$work/st" "$work/imp.0"
[ "$st" -eq 1 ] || fail "the impostor with a key of the job was not admitted ($st)"
grep -q "dropped a frame from PE 1: unknown routing id: its CURVE key is PE 2's" "$work/imp.0" ||
    fail "rank 0 did not reject a frame from PE 2's key under PE 1's routing id"
echo "zap: ok"
