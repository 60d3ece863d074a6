#!/bin/sh
# pdr mesh -n 2: the interface band (mesher/par/par_band.h). On 2 PEs each
# PE, once its local work is done, gives its half of the band along the
# interface to the other PE in one transfer. When a PE sees its local work
# done depends on timing, so the runs that must give bands use the
# trigger PDR_PAR_BAND=3,1,256 (margin 3, one band, the first window of
# 256 steps with a distributed cavity: early, so the bands are large). On
# cube-in-cube, the tee and TetGen's example.poly, without and with
# injected latency (100us-1ms):
#  - both PEs gave a band and took one (the PDR_PAR_TRACE lines);
#  - the merged mesh passes pdr check against the input with radius-edge
#    bound 2, and nothing is left above the bound;
# with the default trigger cube-in-cube meshes and checks the same way
# (bands or not); and with the band off (PDR_PAR_BAND=0) no PE gives one.
# Each run is bounded by timeout.
set -u
tmp=$(pwd)/mesh-parallel-band.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

"$PDR" domain cube-in-cube -o "$tmp/cic.poly" >/dev/null || exit 99
"$PDR" domain tee -o "$tmp/tee.poly" >/dev/null || exit 99
ex=${TETGEN_EXAMPLE:-/usr/share/doc/tetgen/examples/example.poly}

# NAME IN ARGS...: a 2-PE run with a trace line at every start of work,
# which must succeed and check; prints the last "bands GIVEN/TAKEN" of
# each PE.
run() {
    name=$1
    in=$2
    shift 2
    PDR_PAR_TRACE=1e-9 timeout 120 "$PDR" mesh -n 2 "$@" -q 2 -o "$tmp/$name" "$in" \
        >"$tmp/$name.out" 2>"$tmp/$name.err" ||
        { rc=$?; tail -20 "$tmp/$name.err"; fail "$name: pdr mesh exited $rc"; }
    "$PDR" check --plc "$in" --max-ratio 2 "$tmp/$name" >"$tmp/$name.chk" 2>&1 ||
        { cat "$tmp/$name.chk"; fail "$name: pdr check found defects"; }
    grep -q '^left above the bound: 0 tetrahedra' "$tmp/$name.out" ||
        fail "$name: tetrahedra left above the bound"
    for pe in 0 1; do
        grep "^trace PE $pe:" "$tmp/$name.err" | tail -1 | sed -n 's/.* bands \([0-9]*\/[0-9]*\) .*/\1/p'
    done
}

for lat in "" "--latency 100us-1ms"; do
    for d in cic tee ex; do
        case $d in
        cic) in=$tmp/cic.poly args="-a 1e-4" ;;
        tee) in=$tmp/tee.poly args="-a 1e-4" ;;
        ex)
            if [ ! -r "$ex" ]; then
                echo "example.poly skipped: $ex not found (Debian package tetgen)"
                continue
            fi
            in=$ex args="--rank0-points 0"
            ;;
        esac
        name=$d${lat:+-lat}
        bands=$(PDR_PAR_BAND=3,1,256 run "$name" "$in" $args $lat) || { echo "$bands"; exit 1; }
        # Both PEs gave one band and took the other's.
        [ "$(echo $bands)" = "1/1 1/1" ] || fail "$name: bands given/taken per PE: $(echo $bands)"
        echo "$name: bands $(echo $bands), mesh checks"
    done
done

bands=$(run default "$tmp/cic.poly" -a 1e-4) || { echo "$bands"; exit 1; }
echo "default: bands $(echo $bands), mesh checks"

bands=$(PDR_PAR_BAND=0 run off "$tmp/cic.poly" -a 1e-4) || { echo "$bands"; exit 1; }
[ "$(echo $bands)" = "0/0 0/0" ] || fail "PDR_PAR_BAND=0: bands given/taken per PE: $(echo $bands)"
echo "off: no band, mesh checks"
exit 0
