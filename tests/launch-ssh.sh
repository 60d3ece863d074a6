#!/bin/sh
# am-run --hostfile over a real ssh: the test starts its own sshd on a free
# port of 127.0.0.1, with a host key, a client key and every other file in
# its temporary directory, and am-run reaches it through --ssh (a wrapper
# that gives ssh the port and the key). 3 PEs on host 127.0.0.1 run
# pdr mesh --parallel over tcp with CURVE (the keys travel on ssh's
# standard input); sshd's log must show a session for each, and the merged
# mesh must pass pdr check. Skipped unless root (sshd must be able to log
# in as the user running it) and /usr/sbin/sshd is installed (Debian
# package openssh-server).
. "$top_srcdir/tests/launch-lib.sh"

[ "$(id -u)" -eq 0 ] || skip "not root: sshd can only run as root here"
sshd=/usr/sbin/sshd
[ -x "$sshd" ] || skip "$sshd not found (Debian package openssh-server)"
for p in ssh ssh-keygen python3; do
    command -v $p >/dev/null 2>&1 || skip "$p not found"
done

# sshd insists on its privilege separation directory (compiled in). Make it
# if the machine has none, and remove it again afterwards.
if [ ! -d /run/sshd ]; then
    mkdir -m 0755 /run/sshd || skip "cannot make /run/sshd"
    at_exit "rmdir /run/sshd 2>/dev/null"
fi

d=$work/ssh
mkdir -m 0700 "$d" || exit 99
ssh-keygen -q -t ed25519 -N '' -C pdr-test-host -f "$d/host_key" || exit 99
ssh-keygen -q -t ed25519 -N '' -C pdr-test-client -f "$d/client_key" || exit 99
cp "$d/client_key.pub" "$d/authorized_keys"
# A free port (the kernel's choice; sshd fails clearly if it was taken since).
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])') ||
    exit 99
cat >"$d/sshd_config" <<CONFIG
Port $port
ListenAddress 127.0.0.1
HostKey $d/host_key
PidFile $d/sshd.pid
AuthorizedKeysFile $d/authorized_keys
StrictModes no
PubkeyAuthentication yes
PasswordAuthentication no
KbdInteractiveAuthentication no
PermitRootLogin prohibit-password
UsePAM no
X11Forwarding no
AllowTcpForwarding no
PrintMotd no
LogLevel INFO
CONFIG
"$sshd" -t -f "$d/sshd_config" >"$d/sshd.test" 2>&1 ||
    { cat "$d/sshd.test"; fail "sshd rejects the test's configuration"; }
"$sshd" -D -e -f "$d/sshd_config" >"$d/sshd.log" 2>&1 &
sshd_pid=$!
at_exit "kill $sshd_pid 2>/dev/null; wait $sshd_pid 2>/dev/null"

cat >"$work/ssh-wrap" <<WRAP
#!/bin/sh
# ssh to the test's sshd: its port, the test's key, no known-hosts file, no
# password prompt, and no user configuration.
exec ssh -F /dev/null -p $port -i $d/client_key -o IdentitiesOnly=yes \\
    -o StrictHostKeyChecking=no -o UserKnownHostsFile=/dev/null \\
    -o BatchMode=yes -o ConnectTimeout=10 -o LogLevel=ERROR "\$@"
WRAP
chmod +x "$work/ssh-wrap"

# Wait (at most 10 s) until sshd accepts a session.
ok=no
for _ in $(seq 1 40); do
    kill -0 "$sshd_pid" 2>/dev/null || { cat "$d/sshd.log"; fail "sshd exited"; }
    if timeout 10 "$work/ssh-wrap" 127.0.0.1 true 2>"$d/probe.err"; then
        ok=yes
        break
    fi
    sleep 0.25
done
[ "$ok" = yes ] || { cat "$d/probe.err" "$d/sshd.log"; fail "sshd on port $port accepts no session"; }
before=$(grep -c 'Accepted publickey' "$d/sshd.log")

printf '# the test sshd\n127.0.0.1 slots=3\n' >"$work/hosts"
start=$(date +%s.%N)
# shellcheck disable=SC2086
timeout --kill-after=5 90 "$top_builddir/am-run" -n 3 --hostfile "$work/hosts" \
    --ssh "$work/ssh-wrap" --timeout 80 -- \
    "$PDR" mesh --parallel $MESH_OPTS -o "$work/ssh" "$work/cic.poly" \
    >"$work/ssh.out" 2>&1
rc=$?
echo "am-run -n 3 --hostfile (sshd on 127.0.0.1:$port): exit $rc after $(elapsed_since "$start") s"
[ "$rc" -eq 0 ] || { sed 's/^/  | /' "$work/ssh.out" "$d/sshd.log"; fail "am-run over ssh exited $rc"; }
sessions=$(($(grep -c 'Accepted publickey' "$d/sshd.log") - before))
[ "$sessions" -eq 3 ] || { cat "$d/sshd.log"; fail "sshd accepted $sessions sessions for the job, not 3"; }
echo "sshd accepted 3 sessions for the job"
check_mesh ssh "$work/ssh.out" 3
no_leftovers
echo "launch-ssh: ok"
