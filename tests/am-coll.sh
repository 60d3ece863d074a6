#!/bin/sh
# Collectives (barrier, allreduce sum/min/max of f64 and i64, gather of
# variable-size blobs, a collective from a thread) on 1, 2, 4 and 16 PEs,
# and the per-PE statistics files of --stats (in a directory made with its
# missing parents, as mkdir -p does; a file in the way is a clean error).
. "$top_srcdir/tests/am-lib.sh"

for np in 1 2 4 16; do
    job 60 "$AMRUN" -n "$np" -- "$MP" coll
    expect_ok "coll on $np PEs"
    expect_line "^coll: $np PEs: barrier, allreduce sum/min/max, gather ok" "coll $np"
done

job 60 "$AMRUN" -n 3 --stats "$work/new/stats" -- "$MP" coll
expect_ok "coll with --stats"
for r in 0 1 2; do
    f=$work/new/stats/stats-$r.json
    [ -f "$f" ] || fail "no $f"
    grep -q "\"rank\": $r," "$f" || fail "$f does not say rank $r"
    grep -q '"poll_excess_s"' "$f" || fail "$f has no excess poll time"
done
if [ -n "${PYTHON3:-}" ]; then
    "$PYTHON3" -c 'import json, sys; [json.load(open(f)) for f in sys.argv[1:]]' "$work"/new/stats/*.json ||
        fail "statistics files are not valid JSON"
fi
: >"$work/plain" || exit 99
job 60 "$AMRUN" -n 2 --stats "$work/plain/stats" -- "$MP" coll
[ "$rc" -ne 0 ] || fail "--stats under a file exited 0"
expect_line "cannot create --stats directory $work/plain/stats: Not a directory" "--stats under a file"
echo "coll: ok"
