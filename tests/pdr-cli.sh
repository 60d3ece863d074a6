#!/bin/sh
# The pdr program's command line: help, version, info, bad usage.
set -u
fail() { echo "FAIL: $*"; exit 1; }

"$PDR" --help >out.$$ 2>&1 || fail "pdr --help exited $?"
grep -q '^Usage: pdr COMMAND' out.$$ || fail "pdr --help prints no usage"
grep -q '^  info ' out.$$ || fail "pdr --help does not list 'info'"

"$PDR" --version >out.$$ || fail "pdr --version exited $?"
grep -q '^pdr [0-9][0-9.]*$' out.$$ || fail "pdr --version: $(cat out.$$)"

"$PDR" info >out.$$ || fail "pdr info exited $?"
grep -q '^libzmq  *4\.' out.$$ || fail "pdr info names no libzmq 4"
grep -q '^METIS  *5\.' out.$$ || fail "pdr info names no METIS 5"

"$PDR" no-such-command >out.$$ 2>&1
[ $? -eq 2 ] || fail "unknown command should exit 2"
grep -q "unknown command 'no-such-command'" out.$$ || fail "unclear message for an unknown command"

"$PDR" >out.$$ 2>&1
[ $? -eq 2 ] || fail "no command should exit 2"

"$PDR" info extra >out.$$ 2>&1
[ $? -eq 2 ] || fail "pdr info with an argument should exit 2"
rm -f out.$$
echo "pdr command line: ok"
