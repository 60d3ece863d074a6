# tests/launch-lib.sh -- helpers for tests/launch-*.sh and tests/lan-netns.sh
# (sourced). Each of those tests runs pdr mesh --parallel on a small input
# (cube-in-cube, -q 2 -a 1e-4) under a real launcher and checks the mesh
# rank 0 writes with pdr check.
#
# Temporary files live in $work, removed on exit; 'at_exit CMD' adds a
# clean-up command (run last added first, also when the test is killed by
# SIGINT, SIGTERM or SIGHUP). Exit codes: 0 pass, 1 fail, 77 skip, 99
# harness error.
set -u

[ -x "${PDR:?PDR is set by make check}" ] || { echo "$PDR not built"; exit 99; }
test_name=$(basename "$0" .sh)
work=$(mktemp -d "${TMPDIR:-/tmp}/$test_name.XXXXXX") || exit 99
cleanups=
at_exit() {
    cleanups="$1
$cleanups"
}
cleanup() {
    trap - EXIT INT TERM HUP
    eval "$cleanups"
    rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

skip() {
    echo "SKIP: $*"
    exit 77
}

fail() {
    echo "FAIL: $*"
    exit 1
}

# The input and the refinement options every test uses.
"$PDR" domain cube-in-cube -o "$work/cic.poly" >/dev/null || exit 99
MESH_OPTS="-q 2 -a 1e-4"

# check_mesh NAME OUT P: rank 0's output OUT says the job had P PEs and no
# tetrahedron was left above the bound, and the merged mesh $work/NAME.{node,ele,face} passes
# pdr check against the input with radius-edge bound 2.
check_mesh() {
    grep -q "^parallel: $3 PEs," "$2" ||
        { sed 's/^/  | /' "$2"; fail "$1: no 'parallel: $3 PEs' in rank 0's output"; }
    grep -q '^left above the bound: 0 tetrahedra' "$2" ||
        { sed 's/^/  | /' "$2"; fail "$1: no 'left above the bound: 0' in rank 0's output"; }
    for ext in node ele face; do
        [ -s "$work/$1.$ext" ] || fail "$1: $work/$1.$ext not written"
    done
    "$PDR" check --plc "$work/cic.poly" --max-ratio 2 "$work/$1" >"$work/$1.chk" 2>&1 ||
        { sed 's/^/  | /' "$work/$1.chk"; fail "$1: pdr check found defects"; }
    echo "$1: $(sed -n 's/^mesh: \([0-9]* vertices, [0-9]* tetrahedra\).*/\1/p' "$2"), pdr check passed"
}

# Waits up to 5 s for every process whose command line names the input (all
# the PEs, and the ssh or mpirun commands that started them) to be gone.
no_leftovers() {
    for _ in 1 2 3 4 5 6 7 8 9 10; do
        left=$(ps -eo pid=,args= | grep -F -e "$work/cic.poly" | grep -v -e grep)
        [ -z "$left" ] && return 0
        sleep 0.5
    done
    fail "processes left behind: $left"
}

# elapsed_since START: seconds since START (a date +%s.%N value).
elapsed_since() {
    echo "$(date +%s.%N) - $1" | bc
}
