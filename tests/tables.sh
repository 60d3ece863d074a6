#!/bin/sh
# tools/table1, tools/table2 and tools/figures end to end at a tiny scale
# (--scale 0.01: 10k and 20k tetrahedra, 2 PEs, latency 100us-1ms):
#  - both scripts exit 0, every mesh passed pdr check;
#  - table1.csv has the header, a worst-PE and an average row of pdr per
#    domain and size, each with numbers that parse, the paper's row beside
#    them with its published values, and pdr's worst row equal to the one
#    pdr mesh printed in its summary; table1.md has the same rows;
#  - table2.csv has a traditional, a parallel and a sequential row per size,
#    numbers that parse, totals that are the sums of the stages, a parallel
#    refinement that did the work, and table2.md the speed-up row;
#  - with gnuplot: tools/figures pe-time and fig9 draw PNGs with their data.
set -u
tmp=$(pwd)/tables.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
tools=$top_srcdir/tools
num='^-?[0-9]+(\.[0-9]+)?$'

# ---------------------------------------------------------------- table1
"$tools/table1" --pdr "$PDR" --scale 0.01 -n 2 --sizes "1e6 2e6" --out "$tmp/t1" \
    >"$tmp/t1.log" 2>&1 || { cat "$tmp/t1.log"; fail "tools/table1 exited non-zero"; }
csv=$tmp/t1/table1.csv
[ "$(head -1 "$csv")" = "source,mesh,size,target_tets,tets,row,pe,execution_s,completed_cavity_s,masked_local_s,masked_distributed_s,setback_s,latency_tolerance_pct,poll_s,poll_excess_s,excess_pct_of_execution,check,wall_s,max_volume" ] ||
    fail "table1.csv header: $(head -1 "$csv")"
[ "$(grep -c '^pdr,' "$csv")" -eq 8 ] || fail "table1.csv: not 8 pdr rows: $(cat "$csv")"
[ "$(grep -c '^paper,' "$csv")" -eq 4 ] || fail "table1.csv: not 4 paper rows"
for d in cube-in-cube tee; do
    for s in 10k 20k; do
        grep -q "^pdr,$d,$s,.*,worst," "$csv" || fail "table1.csv: no worst row for $d $s"
        grep -q "^pdr,$d,$s,.*,average,2," "$csv" || fail "table1.csv: no average row for $d $s"
    done
done
awk -F, -v num="$num" 'NR > 1 && $1 == "pdr" {
    if (NF != 19) { print "fields " NF ": " $0; bad = 1 }
    for (i = 7; i <= 16; i++) if ($i !~ num) { print "column " i " not a number: " $0; bad = 1 }
    if ($5 !~ /^[0-9]+$/ || $5 < 0.8 * $4 || $5 > 1.2 * $4) { print "tetrahedra: " $0; bad = 1 }
    if ($13 < 0 || $13 > 100 || $8 <= 0) { print "range: " $0; bad = 1 }
    if ($9 < $10 + $11 - 0.0015) { print "masked above completed: " $0; bad = 1 }
    if ($17 != "ok") { print "check: " $0; bad = 1 }
} END { exit bad }' "$csv" || fail "table1.csv rows"
grep -q '^paper,cube-in-cube,1M,1000000,,paper,16,53.9,26.6,16.1,6.0,2.7,89.1,17.4,9.5,' "$csv" ||
    fail "table1.csv: the paper's cube-in-cube 1M row"
grep -q '^paper,tee,2M,2000000,,paper,16,82.4,48.7,19.8,4.5,4.6,84.2,20.1,11.2,' "$csv" ||
    fail "table1.csv: the paper's tee 2M row"
# pdr's own summary names the same worst PE with the same numbers.
for d in cube-in-cube tee; do
    for s in 10k 20k; do
        out=$tmp/t1/runs/$d-$s.out
        set -- $(sed -n 's/^  worst PE \([0-9]*\) *\([0-9.]*\) *\([0-9.]*\) *\([0-9.]*\) (\([0-9.]*\)) *\([0-9.]*\) *\([0-9.]*\)% *\([0-9.]*\) (\([0-9.]*\))$/\1,\2,\3,\4,\5,\6,\7,\8,\9/p' "$out")
        [ $# -eq 1 ] || fail "$d $s: no worst PE line in $out"
        grep -q "^pdr,$d,$s,[0-9]*,[0-9]*,worst,$1," "$csv" ||
            fail "$d $s: summary says 'worst PE $1', table1.csv: $(grep "^pdr,$d,$s,.*,worst," "$csv")"
    done
done
[ "$(grep -c '^| .*pdr: worst PE' "$tmp/t1/table1.md")" -eq 4 ] || fail "table1.md worst rows"
[ "$(grep -c '^| .*\*\*paper\*\*' "$tmp/t1/table1.md")" -eq 4 ] || fail "table1.md paper rows"
grep -q '^| mesh | size | tetrahedra | row | execution | completed cavity | masked local (dist) | setback | % latency tolerance | poll (excess) |' \
    "$tmp/t1.log" || fail "tools/table1 did not print the table"
echo "table1: ok"

# ---------------------------------------------------------------- table2
"$tools/table2" --pdr "$PDR" --scale 0.01 -n 2 --sizes "1e6 2e6" --sched batch --out "$tmp/t2" \
    >"$tmp/t2.log" 2>&1 || { cat "$tmp/t2.log"; fail "tools/table2 exited non-zero"; }
grep -q 'pdr: .*; scheduling: batch$' "$tmp/t2/table2.md" ||
    fail "table2.md does not say --sched batch: $(grep 'pdr: ' "$tmp/t2/table2.md")"
csv=$tmp/t2/table2.csv
[ "$(head -1 "$csv")" = "source,mesh,size,target_tets,pipeline,tets,mo_tets,generate_s,partition_s,distribute_s,refine_s,total_s,gather_s,merge_s,check,wall_s,max_volume" ] ||
    fail "table2.csv header: $(head -1 "$csv")"
for s in 10k 20k; do
    for p in traditional parallel sequential; do
        [ "$(grep -c "^pdr,cube-in-cube,$s,[0-9]*,$p," "$csv")" -eq 1 ] || fail "table2.csv: $s $p row"
    done
done
awk -F, -v num="$num" 'NR > 1 {
    if (NF != 17 || $15 != "ok") { print "row: " $0; bad = 1 }
    n = ($5 == "sequential") ? 8 : 14
    for (i = 8; i <= n; i++) if (i != 12 && $i !~ num) { print "column " i ": " $0; bad = 1 }
    if ($12 !~ num) { print "total: " $0; bad = 1 }
    if ($5 != "sequential") {
        s = $8 + $9 + $10 + $11
        if (s - $12 > 0.0025 || $12 - s > 0.0025) { print "total is not the sum: " $0; bad = 1 }
        if ($5 == "traditional" && $7 != $6) { print "Mo is not the whole mesh: " $0; bad = 1 }
        if ($5 == "parallel" && ($7 >= $6 / 2 || $11 <= 0)) { print "parallel: " $0; bad = 1 }
    }
} END { exit bad }' "$csv" || fail "table2.csv rows"
[ "$(grep -c 'traditional / parallel' "$tmp/t2/table2.md")" -eq 2 ] || fail "table2.md speed-up rows"
echo "table2: ok"

# ---------------------------------------------------------------- figures
if command -v gnuplot >/dev/null 2>&1; then
    "$tools/figures" pe-time --pdr "$PDR" "$tmp/t1/runs/tee-20k.stats" "$tmp/pe.png" >"$tmp/f.log" 2>&1 ||
        { cat "$tmp/f.log"; fail "tools/figures pe-time"; }
    head -c 8 "$tmp/pe.png" | od -An -c | grep -q 'P   N   G' || fail "pe-time: not a PNG"
    [ "$(grep -c '^[0-9]' "$tmp/pe.dat")" -eq 2 ] || fail "pe-time.dat: $(cat "$tmp/pe.dat")"
    "$PDR" mesh -Q -q 2 -a 1e-3 -o "$tmp/m" "$tmp/t1/runs/tee.poly" || fail "pdr mesh for fig9"
    "$tools/figures" fig9 --pdr "$PDR" --plc "$tmp/t1/runs/tee.poly" "$tmp/m" "$tmp/f9.png" \
        >"$tmp/f.log" 2>&1 || { cat "$tmp/f.log"; fail "tools/figures fig9"; }
    head -c 8 "$tmp/f9.png" | od -An -c | grep -q 'P   N   G' || fail "fig9: not a PNG"
    [ "$(grep -c '^[0-9]' "$tmp/f9.dat")" -eq 36 ] || fail "fig9.dat: $(cat "$tmp/f9.dat")"
    echo "figures: ok"
else
    echo "figures: skipped (gnuplot not installed)"
fi
