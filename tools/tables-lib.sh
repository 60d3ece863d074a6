# tools/tables-lib.sh -- shell functions shared by tools/table1,
# tools/table2, tools/figures and tools/bench-parallel (sourced, not
# run). POSIX sh and awk.
#
# The caller sets: pdr (the pdr program), work (a scratch directory),
# run_timeout (seconds per pdr command), keep (yes: keep the meshes).

# tl_die MESSAGE: the calling script's name and MESSAGE on stderr, exit 1.
tl_die() {
    echo "${0##*/}: $*" >&2
    exit 1
}

tl_now() { date +%s.%N; }

# tl_header: comment lines naming the machine, the date and the program.
tl_header() {
    echo "# ${0##*/}, $(date -u '+%Y-%m-%d %H:%M UTC'), $(uname -n)"
    echo "# cpu: $(sed -n 's/^model name[^:]*: //p' /proc/cpuinfo | head -1), $(nproc) cores," \
        "$(awk '/^MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo)," \
        "load average $(cut -d' ' -f1-3 /proc/loadavg)"
    tl_rev=$(git -C "$(dirname "$pdr")" rev-parse --short HEAD 2>/dev/null || echo unknown)
    echo "# pdr: $("$pdr" --version) (commit $tl_rev); scheduling: ${sched:-other}"
}

# tl_poly NAME: writes the built-in domain NAME (cube-in-cube, tee) to
# $work/NAME.poly once and prints its path.
tl_poly() {
    [ -f "$work/$1.poly" ] || "$pdr" domain "$1" -o "$work/$1.poly" >/dev/null ||
        tl_die "pdr domain $1 failed"
    echo "$work/$1.poly"
}

# tl_volume POLY: the domain's volume, as pdr check measures it on the
# conforming initial mesh.
tl_volume() {
    tl_b=$work/volume.$$
    timeout --foreground "$run_timeout" "$pdr" mesh -Q --mo-only -o "$tl_b" "$1" \
        >/dev/null 2>&1 || tl_die "pdr mesh --mo-only $1 failed"
    tl_v=$(timeout --foreground "$run_timeout" "$pdr" check --plc "$1" "$tl_b" 2>/dev/null |
        sed -n 's/^  domain (from the input) *\([0-9.eE+-]*\)$/\1/p')
    rm -f "$tl_b".node "$tl_b".ele "$tl_b".face
    [ -n "$tl_v" ] || tl_die "pdr check printed no domain volume for $1"
    echo "$tl_v"
}

# tl_maxvol VOLUME TETS: the volume bound that gives about TETS
# tetrahedra (a mesh with radius-edge bound 2 and volume bound V has
# about 2 VOLUME / V of them; pdr's --mo-size uses the same rule).
tl_maxvol() { awk -v v="$1" -v n="$2" 'BEGIN { printf "%.9g\n", 2 * v / n }'; }

# tl_tets SIZE SCALE: the rounded number of tetrahedra SIZE * SCALE.
tl_tets() { awk -v s="$1" -v k="$2" 'BEGIN { printf "%.0f\n", s * k }'; }

# tl_label N: 1000000 -> 1M, 20000 -> 20k, 999 -> 999.
tl_label() {
    awk -v n="$1" 'BEGIN {
        if (n >= 1e6 && n % 1e5 == 0) printf "%gM\n", n / 1e6
        else if (n >= 1e3 && n % 100 == 0) printf "%gk\n", n / 1e3
        else printf "%d\n", n }'
}

# tl_chrt: chrt's arguments for the scheduling policy $sched (--sched of
# the scripts: other, batch, fifo or rr; empty: other), under which every
# pdr mesh runs, the sequential ones too; tl_check_sched refuses another
# value before anything runs.
tl_chrt() {
    case ${sched:-other} in
    batch) echo "-b 0" ;;
    fifo) echo "-f 1" ;;
    rr) echo "-r 1" ;;
    *) echo "-o 0" ;;
    esac
}
tl_check_sched() {
    case ${sched:-other} in
    other | batch | fifo | rr) ;;
    *)
        echo "${0##*/}: --sched is other, batch, fifo or rr, not '$sched'" >&2
        exit 2
        ;;
    esac
}

# tl_mesh NAME POLY MAXVOL NP ARGS...: runs 'pdr mesh -q 2 -a MAXVOL' on
# POLY (with -n NP when NP > 0, and ARGS), output base $work/NAME, its
# summary in $work/NAME.out and its wall seconds in $work/NAME.wall.
# Returns pdr's status.
tl_mesh() {
    tl_n=$1 tl_p=$2 tl_v=$3 tl_np=$4
    shift 4
    [ "$tl_np" -gt 0 ] && set -- -n "$tl_np" "$@"
    [ "$tl_np" -gt 0 ] && [ -n "${sched:-}" ] && set -- "$@" --sched "$sched"
    tl_t0=$(tl_now)
    tl_st=0
    # shellcheck disable=SC2046
    timeout --foreground "$run_timeout" chrt $(tl_chrt) "$pdr" mesh -q 2 -a "$tl_v" \
        -o "$work/$tl_n" "$@" "$tl_p" >"$work/$tl_n.out" 2>&1 || tl_st=$?
    tl_t1=$(tl_now)
    awk -v a="$tl_t0" -v b="$tl_t1" 'BEGIN { printf "%.3f\n", b - a }' >"$work/$tl_n.wall"
    [ "$tl_st" -eq 0 ] ||
        echo "${0##*/}: pdr mesh $tl_n failed (status $tl_st): $(tail -3 "$work/$tl_n.out")" >&2
    return "$tl_st"
}

# tl_check NAME POLY: 'pdr check --plc POLY --max-ratio 2' on $work/NAME;
# prints ok or FAIL (the report in $work/NAME.chk); then removes the mesh
# unless keep=yes.
tl_check() {
    if timeout --foreground "$run_timeout" "$pdr" check --plc "$2" --max-ratio 2 "$work/$1" \
        >"$work/$1.chk" 2>&1 && grep -q '^ok: 0 defects' "$work/$1.chk"; then
        echo ok
    else
        echo FAIL
    fi
    [ "$keep" = yes ] || rm -f "$work/$1".node "$work/$1".ele "$work/$1".face
}

# tl_count OUT: the tetrahedra of the mesh a pdr mesh summary reports.
tl_count() { sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$1"; }

# tl_stats DIR: one line per PE from DIR/table1-RANK.json, in rank order:
#   rank exec completed masked_local masked_dist setback tolerance(0..1)
#   service poll poll_excess idle
# The tolerance is masked / (masked + setback), 1 without either, as pdr
# computes it. With TL_WALL=1 the work times are the wall-clock ones
# (completed_cavity_wall_s, masked_wall_s as local with 0 distributed,
# setback_wall_s) where the rows have them (pdr mesh --work-clock): what a
# breakdown of the execution time needs.
tl_stats() {
    awk -v wall="${TL_WALL:-0}" '
    FNR == 1 { r = -1 }
    {
        line = $0
        if (!match(line, /"[a-z_]+": *[-0-9.eE+]+/)) next
        kv = substr(line, RSTART, RLENGTH)
        k = kv; sub(/^"/, "", k); sub(/".*/, "", k)
        v = kv; sub(/^[^:]*: */, "", v)
        if (k == "rank") { r = v + 0; seen[r] = 1; if (r + 1 > n) n = r + 1 }
        else if (r >= 0) { val[r, k] = v + 0; has[r, k] = 1 }
    }
    END {
        for (i = 0; i < n; i++) {
            if (!seen[i]) { print "tl_stats: no row of PE " i > "/dev/stderr"; exit 1 }
            if (wall && has[i, "completed_cavity_wall_s"]) {
                val[i, "completed_cavity_s"] = val[i, "completed_cavity_wall_s"]
                val[i, "masked_local_s"] = val[i, "masked_wall_s"]
                val[i, "masked_distributed_s"] = 0
                val[i, "setback_s"] = val[i, "setback_wall_s"]
            }
            m = val[i, "masked_local_s"] + val[i, "masked_distributed_s"]
            d = m + val[i, "setback_s"]
            printf "%d %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", i,
                val[i, "execution_s"], val[i, "completed_cavity_s"], val[i, "masked_local_s"],
                val[i, "masked_distributed_s"], val[i, "setback_s"], (d > 0 ? m / d : 1),
                val[i, "service_s"], val[i, "poll_s"], val[i, "poll_excess_s"], val[i, "idle_s"]
        }
    }' "$1"/table1-*.json
}

# tl_worst_avg: reads tl_stats lines, prints the worst (least
# latency-tolerant, lowest rank on a tie) PE's row and the average row:
#   worst|average PE exec completed m_local m_dist setback tolerance% poll excess
# The average row's tolerance is that of the averages, as pdr prints it.
tl_worst_avg() {
    awk '
    { n++; for (j = 2; j <= 11; j++) s[j] += $j
      if (n == 1 || $7 < wt) { w = $0; wt = $7 } }
    END {
        if (!n) exit 1
        split(w, a, " ")
        printf "worst %d %.3f %.3f %.3f %.3f %.3f %.1f %.3f %.3f\n", a[1], a[2], a[3], a[4],
            a[5], a[6], 100 * a[7], a[9], a[10]
        for (j = 2; j <= 11; j++) s[j] /= n
        m = s[4] + s[5]; d = m + s[6]
        printf "average %d %.3f %.3f %.3f %.3f %.3f %.1f %.3f %.3f\n", n, s[2], s[3], s[4],
            s[5], s[6], (d > 0 ? 100 * m / d : 100), s[9], s[10]
    }'
}
