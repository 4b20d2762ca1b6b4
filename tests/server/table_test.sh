#!/usr/bin/env bash
# Parameter tables: a 12-point table (two fields, bed.seed a column) runs locally and on a
# dembufd, with the same runs; `fetch --sweep --long` and `sweep --long` write the same tidy
# table, byte for byte, which pandas reads with one row per sample; `watch --sweep` exits when
# the sweep has; Python submits a table as a DataFrame. A bad table is refused naming the line.
# Usage: table_test.sh DEMBUF DEMBUFD PYTHON_DIR
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$3
export OMP_NUM_THREADS=1
start_daemon "$work/dembuf.db" "$work/dembufd.log"
# Bare-plate impacts (no bed to prepare): each takes milliseconds.
bare=(--preset e2 --set bed.thickness_m=0 --set time.output_interval_s=1e-4)
{
  printf 'projectile.speed_m_s\tprojectile.mass_kg\tbed.seed\n'
  for speed in 1 2 3 4 5 6; do printf '%s\t0.%s\t1\n%s\t0.3\t2\n' "$speed" "$speed" "$speed"; done
} > "$work/points.tsv"

"$dembuf" sweep --local "${bare[@]}" --table "$work/points.tsv" --long --out "$work/local" \
  > "$work/local.out" 2>&1 || fail "the local table sweep: $(cat "$work/local.out")"
[ "$(tail -n +2 "$work/local/sweep.csv" | wc -l)" = 12 ] || fail "local sweep.csv rows"

sweep=$("$dembuf" sweep "${bare[@]}" --table "$work/points.tsv" 2> "$work/err") ||
  fail "the daemon's table sweep: $(cat "$work/err")"
timeout 300 "$dembuf" watch --sweep "$sweep" > "$work/watch" || fail "watch --sweep: $(cat "$work/watch")"
tail -1 "$work/watch" | grep -q "12 of 12 jobs ended, done 12" || fail "watch --sweep: $(tail -1 "$work/watch")"
"$dembuf" fetch --sweep "$sweep" --long --no-plots --out "$work/fetched" > /dev/null ||
  fail "fetch --sweep --long"
cmp "$work/local/sweep_long.csv" "$work/fetched/sweep_long.csv" ||
  fail "the local and the daemon's long tables differ"
"$dembuf" status --sweep "$sweep" | grep -q "projectile.speed_m_s" || fail "status names the table's fields"

PYTHONPATH="$python_dir" /usr/bin/python3 - "$work" <<'PY' || fail "Python"
import sys
import pandas as pd
import dembuf
work = sys.argv[1]
long = dembuf.read_sweep_long(work + "/fetched")
runs = dembuf.read_sweep(work + "/fetched")
lengths = [len(pd.read_csv(f"{work}/fetched/{d}/plate_force.csv")) for d in
           pd.read_csv(work + "/fetched/sweep.csv").run_dir]
assert len(long) == sum(lengths), (len(long), sum(lengths))
assert list(long.columns[:4]) == ["run", "projectile.speed_m_s", "projectile.mass_kg", "bed.seed"]
peaks = long.groupby("run").plate_force_N.max()
assert peaks.index.tolist() == list(range(12)), peaks
table = pd.DataFrame({"projectile.speed_m_s": [2, 4], "projectile.mass_kg": [0.2, 0.4]})
with dembuf.connect() as daemon:
    sweep = daemon.submit_sweep(table=table, preset="e2", set={"bed.thickness_m": 0})
    frame = daemon.sweep(sweep)
    assert dembuf.frames.sweep_axes(frame)[:2] == list(table.columns), frame.columns
    assert len(frame) == 2, frame
    # A table of columns and no rows was stored as a sweep of no jobs (a review's find).
    try:
        daemon.submit_sweep(table=pd.DataFrame(columns=["bed.thickness_m"]), seeds=2)
        raise SystemExit("a table of no rows was accepted")
    except dembuf.DembufError as e:
        assert e.code == "INVALID_ARGUMENT" and "one row" in e.message, e
print(f"Python: {len(long)} samples of 12 runs; a DataFrame submitted as sweep {sweep}")
PY

# A bad table: refused before anything runs, naming the line (here and by the daemon).
printf 'projectile.speed_m_s\tbed.seed\n1\n' > "$work/bad.tsv"
for where in --local ""; do
  rc=0
  "$dembuf" sweep $where "${bare[@]}" --table "$work/bad.tsv" --out "$work/bad" 2> "$work/err" || rc=$?
  [ "$rc" = 2 ] && grep -q "bad.tsv line 2: 1 values for 2 columns" "$work/err" ||
    fail "a bad table ($where): exit $rc, $(cat "$work/err")"
done
echo "table: 12 points locally and on the daemon, the same long table; Python; a bad table refused"
